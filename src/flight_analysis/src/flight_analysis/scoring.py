"""Scoring of a finished flight from the simulator's ground truth (SPEC section 7), ROS-free."""

PAD_TOLERANCE_M = 0.25  # "landed on the pad" = resting on it within this horizontal error
SURFACE_PAD, SURFACE_GROUND, SURFACE_VEHICLE = 1, 2, 3


def outcome(touchdown, resting_pad_error, emergency_ordered):
    """(outcome, touchdown_error_m) of a flight.

    ``touchdown``: None, or an object with ``surface``, ``crashed`` and ``pad_error`` (the simulator's
    classification at first contact); ``resting_pad_error``: horizontal drone-to-pad distance once the
    drone has come to rest (None if unknown); ``emergency_ordered``: whether the supervisor or the operator
    had ordered an emergency landing before the touchdown."""
    if touchdown is None:
        return "timeout", None
    if touchdown.crashed:
        return "crashed", None
    if touchdown.surface == SURFACE_PAD:
        resting = touchdown.pad_error if resting_pad_error is None else resting_pad_error
        if resting <= PAD_TOLERANCE_M:
            return "landed_on_pad", round(float(touchdown.pad_error), 4)
        return "landed_off_pad", None
    if touchdown.surface == SURFACE_GROUND and emergency_ordered:
        return "emergency_landed", None
    return "landed_off_pad", None
