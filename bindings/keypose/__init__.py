"""keypose from Python: sequences of keyframes on robot arms, checked exactly against the
joints' limits, sampled, retimed and saved; robots' limits and kinematics.

The native module ``keypose._keypose`` is built from keypose's Rust library; this package
re-exports it (``_keypose.pyi`` has its types). docs/python.md in keypose's repository tells
how to use it.
"""

from ._keypose import (
    Contact,
    Error,
    HardwareError,
    InputError,
    JointSummary,
    LimitError,
    Limits,
    Report,
    Robot,
    Sequence,
    ToolPose,
    Violation,
    __version__,
    load,
)

# keypose.lerobot drives a LeRobot robot object it is handed and imports no LeRobot itself,
# so it comes with `import keypose` (`keypose.lerobot.play(robot, ...)`, as the README writes
# it). keypose.teleop, whose classes subclass LeRobot's, is imported by LeRobot's own plugin
# discovery and stays out.
from . import lerobot

__all__ = [
    "Contact",
    "Error",
    "HardwareError",
    "InputError",
    "JointSummary",
    "LimitError",
    "Limits",
    "Report",
    "Robot",
    "Sequence",
    "ToolPose",
    "Violation",
    "__version__",
    "load",
    "lerobot",
]

