"""LeRobot's plugin entry for keypose's teleoperator: importing it registers
``--teleop.type=keypose`` (keypose.teleop.KeyposeTeleop)."""

from keypose.teleop import KeyposeTeleop, KeyposeTeleopConfig

__all__ = ["KeyposeTeleop", "KeyposeTeleopConfig"]
