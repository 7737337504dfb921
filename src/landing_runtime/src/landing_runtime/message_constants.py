"""The constants a ROS message defines (``uint8 STATE_LANDED=2``, ``string TRACKING=TRACKING``), read from its
generated class, so that a package checks a value against the message's own list instead of a copy."""


def message_constants(message_class, prefix=""):
    """The values of ``message_class``'s constants whose names start with ``prefix``, in definition order."""
    return tuple(value for name, value in vars(message_class).items()
                 if name.isupper() and name.startswith(prefix) and isinstance(value, (int, float, str)))
