"""KeyposeTeleop: a LeRobot teleoperator whose actions come from a keypose sequence, for scripted
demonstrations recorded with ``lerobot-record`` (cameras and all) without a leader arm.

Importing this package registers the teleoperator type ``keypose`` with LeRobot
(``TeleoperatorConfig.register_subclass``, as LeRobot's own teleoperators do), so it needs
LeRobot installed. ``lerobot-record`` imports it by itself when the ``lerobot_teleoperator_keypose``
plugin package is installed (docs/python.md), or when given
``--teleop.discover_packages_path=keypose.teleop``.
"""

from .config_keypose_teleop import KeyposeTeleopConfig
from .keypose_teleop import KeyposeTeleop

__all__ = ["KeyposeTeleop", "KeyposeTeleopConfig"]
