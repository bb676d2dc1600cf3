"""The configuration of KeyposeTeleop: ``--teleop.type=keypose --teleop.sequence=FILE …``."""

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from lerobot.teleoperators.config import TeleoperatorConfig  # type: ignore[import-untyped]


@TeleoperatorConfig.register_subclass("keypose")
@dataclass
class KeyposeTeleopConfig(TeleoperatorConfig):
    """``sequence``: the keypose sequence file to play. ``fps``: the rate ``get_action`` is
    called at, the dataset's (``--dataset.fps``, 30 by default): each call is the next frame.
    ``robot_calibration`` (a file) or ``robot_id`` (the id LeRobot calibrated the follower
    with): the follower's calibration, for the gripper's 0…100 % and the −100…100 range.
    ``use_degrees``: the follower's own setting (SO arms: True by default, Koch: False)."""

    sequence: Optional[Path] = None
    fps: int = 30
    robot_calibration: Optional[Path] = None
    robot_id: Optional[str] = None
    use_degrees: bool = True
