"""The configuration of KeyposeTeleop: ``--teleop.type=keypose --teleop.sequence=FILE …``."""

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from lerobot.teleoperators.config import TeleoperatorConfig  # type: ignore[import-untyped]

from keypose import InputError

# The frame rates a dataset may be recorded at (LeRobot's fps is a whole number).
_FPS = range(1, 1001)
# How a command line or a config file spells a boolean (draccus may hand over the text).
_TRUE = {"true", "yes", "1", "on"}
_FALSE = {"false", "no", "0", "off"}


@TeleoperatorConfig.register_subclass("keypose")
@dataclass
class KeyposeTeleopConfig(TeleoperatorConfig):
    """``sequence``: the keypose sequence file to play. ``fps``: the rate ``get_action`` is
    called at, the dataset's (``--dataset.fps``, 30 by default): each call is the next frame.
    ``robot_calibration`` (a file) or ``robot_id`` (the id LeRobot calibrated the follower
    with): the follower's calibration, for the gripper's 0…100 % and the −100…100 range.
    ``use_degrees``: the follower's own setting (SO arms: True by default, Koch: False).
    ``robot_type``: the follower's type (``so101_follower``, ``koch_follower``, …): a sequence for
    another arm is refused, as ``keypose.lerobot.play`` refuses it. When not given, the
    ``--robot.type`` of the command line that runs the teleoperator (``lerobot-record``) is
    taken, so that recording a Koch sequence on an SO-101 fails before anything moves."""

    sequence: Optional[Path] = None
    fps: int = 30
    robot_calibration: Optional[Path] = None
    robot_id: Optional[str] = None
    use_degrees: bool = True
    robot_type: Optional[str] = None

    def __post_init__(self) -> None:
        """Bad values are ``keypose.InputError`` naming the field, before anything connects."""
        fps = self.fps
        if isinstance(fps, bool) or not isinstance(fps, int) or fps not in _FPS:
            raise InputError(f"fps: expected a whole number of frames per second from 1 to 1000, found {fps!r}")
        self.use_degrees = _boolean("use_degrees", self.use_degrees)


def _boolean(field: str, value: object) -> bool:
    """`value` as a boolean: a bool, or one of the spellings a command line uses."""
    if isinstance(value, bool):
        return value
    if isinstance(value, str) and value.strip().lower() in _TRUE | _FALSE:
        return value.strip().lower() in _TRUE
    raise InputError(f"{field}: expected true or false, found {value!r}")
