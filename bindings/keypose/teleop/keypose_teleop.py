"""KeyposeTeleop: LeRobot's teleoperator interface over a keypose sequence.

The sequence is loaded and checked against the arm's limits at ``connect()`` (a sequence that
breaks them is refused there, before anything moves) and sampled once, as ``keypose export
lerobot`` samples it, into LeRobot's units through the follower's calibration. Each
``get_action()`` is then the next frame, one ``1 / fps`` step along the trajectory, whatever the
wall clock did: a late call never skips ahead, so consecutive actions never ask for more than
the limits allow over one frame. After the last frame the last pose is held (the arm rests
there).

The first action is the sequence's first pose: the follower must be there, or near, before
recording starts (``keypose.lerobot.play`` with the sequence ramps it there from wherever it
is, at the limits). LeRobot hands a teleoperator no measurement of the follower to ease in from.
"""

import sys
from pathlib import Path
from typing import Any, Dict, List, Literal, Optional

from lerobot.teleoperators.teleoperator import Teleoperator  # type: ignore[import-untyped]

import keypose

from .config_keypose_teleop import KeyposeTeleopConfig


class KeyposeTeleop(Teleoperator):
    """Actions from a keypose sequence: one frame of the trajectory per ``get_action()``."""

    config_class = KeyposeTeleopConfig
    name = "keypose"

    def __init__(self, config: KeyposeTeleopConfig):
        super().__init__(config)
        self.config = config
        if config.sequence is None:
            raise keypose.InputError("--teleop.sequence: expected the keypose sequence file to play")
        # The names are known before connecting (lerobot-record reads the features first).
        self._sequence = self._load(config.sequence)
        self._check_follower(config.robot_type or follower_type_in(sys.argv))
        self._names = [f"{joint.replace('/', '_')}.pos" for joint in self._sequence.joints]
        self._frames: Optional[Any] = None
        self._next = 0

    def _load(self, sequence: Path) -> keypose.Sequence:
        return keypose.load(
            sequence,
            calibration=self.config.robot_calibration,
            robot_id=self.config.robot_id,
        )

    def _check_follower(self, robot_type: Optional[str]) -> None:
        """Refuses a sequence for another arm than the follower of type `robot_type` (the SO-100
        and SO-101, or an SO arm and a Koch, share motor names: the actions would fit)."""
        if robot_type is None:
            return
        follower = keypose.Robot(robot_type).name
        arm = self._sequence.robot.name
        if arm != follower:
            raise keypose.InputError(
                f"{self._sequence.file}: a sequence for {arm}, but the follower is {robot_type} "
                f"({follower}): its keys are another arm's joint values; teach or import one for "
                f"{follower}"
            )

    @property
    def action_features(self) -> Dict[str, type]:
        return {name: float for name in self._names}

    @property
    def feedback_features(self) -> Dict[str, type]:
        return {}

    @property
    def is_connected(self) -> bool:
        return self._frames is not None

    def connect(self, calibrate: bool = True) -> None:
        report = self._sequence.check()
        if not report.passed:
            raise keypose.LimitError(
                f"{self._sequence.file}: refusing to play a sequence that breaks the joints' limits "
                f"(try `keypose retime`):\n{report.text}"
            )
        units: Literal["degrees", "range"] = "degrees" if self.config.use_degrees else "range"
        names, frames = self._sequence.lerobot_frames(fps=self.config.fps, units=units)
        self._names = names
        self._frames = frames
        self._next = 0

    @property
    def is_calibrated(self) -> bool:
        # Nothing to calibrate: the follower's calibration converts the units.
        return True

    def calibrate(self) -> None:
        pass

    def configure(self) -> None:
        pass

    @property
    def finished(self) -> bool:
        """Whether every frame has been handed out (the last pose is held from then on)."""
        return self._frames is not None and self._next >= len(self._frames)

    def get_action(self) -> Dict[str, float]:
        if self._frames is None:
            raise keypose.Error(f"{self} is not connected: call connect() first")
        frame = self._frames[min(self._next, len(self._frames) - 1)]
        self._next += 1
        action = {name: float(value) for name, value in zip(self._names, frame)}
        return action

    def send_feedback(self, feedback: Dict[str, Any]) -> None:
        pass

    def disconnect(self) -> None:
        self._frames = None


def follower_type_in(argv: List[str]) -> Optional[str]:
    """The ``--robot.type`` a LeRobot command line gives (``--robot.type=T`` or ``--robot.type
    T``), if any."""
    for i, arg in enumerate(argv):
        if arg.startswith("--robot.type="):
            return arg.split("=", 1)[1]
        if arg == "--robot.type" and i + 1 < len(argv):
            return argv[i + 1]
    return None
