"""Manual control of the drone: keyboard teleop and PS4 joystick (thesis chapter 3.4, Tables 3.1-3.2)."""
