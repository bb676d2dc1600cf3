"""keypose with LeRobot: sequences played through a connected LeRobot robot object.

``play(robot, sequence)`` runs keypose's own player (the Rust one: ramp from the measured pose,
step limiter, position guard, soft stop on Ctrl-C, rest at the end) with the robot's
``get_observation()`` and ``send_action()`` as its bus. Units go through the robot's own
calibration (``robot.bus.calibration``): each goal is handed to LeRobot as the normalised value
(degrees with ``use_degrees=True``, else −100…100; the gripper 0…100) that LeRobot's bus turns
back into exactly the servo tick keypose's guard let through.

LeRobot itself is not a dependency of keypose: this module uses the robot object it is given.
"""

from __future__ import annotations

import json
import os
import signal
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Tuple, Union

from . import _keypose
from ._keypose import Sequence, StopRequests

__all__ = ["play", "calibration_json", "motors_of"]

_SequenceLike = Union[str, "os.PathLike[str]", Sequence]


def _arms(robot: Any) -> List[Tuple[Optional[str], Any]]:
    """The robot's arms: ``[(None, robot)]`` for one arm, ``[("left", robot.left_arm),
    ("right", robot.right_arm)]`` for LeRobot's bimanual robots, each with its own bus."""
    if hasattr(robot, "bus"):
        return [(None, robot)]
    if hasattr(robot, "left_arm") and hasattr(robot, "right_arm"):
        return [("left", robot.left_arm), ("right", robot.right_arm)]
    raise _keypose.InputError(
        f"robot: {robot!r} is not a LeRobot robot with a motor bus (robot.bus), nor a bimanual "
        "one (robot.left_arm, robot.right_arm); expected a connected SO101Follower, KochFollower "
        "or BiSOFollower"
    )


def calibration_json(robot: Any) -> Dict[str, Dict[str, int]]:
    """The calibration of one arm (``robot.bus.calibration``) as LeRobot writes its calibration
    file: per motor ``id``, ``drive_mode``, ``homing_offset``, ``range_min``, ``range_max``."""
    calibration = getattr(robot.bus, "calibration", None)
    if not calibration:
        raise _keypose.InputError(
            f"robot: {robot} has no calibration: calibrate it with LeRobot first "
            "(lerobot-calibrate), or connect it with its calibration file"
        )
    return {
        name: {
            "id": int(c.id),
            "drive_mode": int(c.drive_mode),
            "homing_offset": int(c.homing_offset),
            "range_min": int(c.range_min),
            "range_max": int(c.range_max),
        }
        for name, c in calibration.items()
    }


def motors_of(robot: Any) -> List[Dict[str, Any]]:
    """How the robot's motor buses normalise each motor, what the player converts goals with:
    ``joint`` (keypose's name: ``left/shoulder_pan`` on a bimanual robot), ``name`` (on its
    arm's bus), ``key`` (in actions), ``arm``, ``id``, ``model``, ``norm_mode``, ``range_min``,
    ``range_max``, ``mirrored`` (drive_mode 1 on a bus that applies it) and ``resolution``
    (ticks a turn)."""
    motors = []
    for arm, one in _arms(robot):
        bus = one.bus
        calibration = calibration_json(one)
        for name, motor in bus.motors.items():
            c = calibration[name]
            motors.append(
                {
                    "joint": name if arm is None else f"{arm}/{name}",
                    "name": name,
                    "key": f"{name}.pos" if arm is None else f"{arm}_{name}.pos",
                    "arm": arm,
                    "id": int(motor.id),
                    "model": str(motor.model),
                    "norm_mode": str(getattr(motor.norm_mode, "value", motor.norm_mode)),
                    "range_min": c["range_min"],
                    "range_max": c["range_max"],
                    "mirrored": bool(getattr(bus, "apply_drive_mode", False) and c["drive_mode"]),
                    "resolution": int(bus.model_resolution_table[motor.model]),
                }
            )
    return motors


@contextmanager
def _calibration_files(robot: Any) -> Iterator[List[str]]:
    """Each arm's calibration in a file of its own, as keypose's calibration loader takes them:
    ``[FILE]`` for one arm, ``["left=FILE", "right=FILE"]`` for two."""
    with tempfile.TemporaryDirectory(prefix="keypose-lerobot-") as folder:
        given = []
        for arm, one in _arms(robot):
            path = Path(folder) / f"{arm or 'arm'}.json"
            path.write_text(json.dumps(calibration_json(one), indent=4))
            given.append(str(path) if arm is None else f"{arm}={path}")
        yield given


def _sequence_on(robot: Any, sequence: _SequenceLike) -> Sequence:
    """The sequence on its own robot (the arm its file names: LeRobot's robot objects do not
    tell an SO-100 from an SO-101) with the LeRobot arms' calibrations applied."""
    with _calibration_files(robot) as calibration:
        if isinstance(sequence, Sequence):
            return sequence.with_calibration(calibration)
        return _keypose.load(sequence, calibration=calibration)


@contextmanager
def _ctrl_c_stops(stop: StopRequests) -> Iterator[None]:
    """Ctrl-C (SIGINT) asks the playback to stop instead of raising KeyboardInterrupt: the
    first brakes to rest along the path, the second holds at once. Only the main thread can
    set a handler; elsewhere a KeyboardInterrupt still counts as a stop request."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, lambda _signum, _frame: stop.request())
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def play(
    robot: Any,
    sequence: _SequenceLike,
    *,
    rate: Union[float, None] = None,
    speed: float = 1.0,
    max_stall: float = 0.25,
    judge_pace: bool = True,
    stop: Union[StopRequests, None] = None,
    compensate_droop: bool = False,
) -> Dict[str, Any]:
    """Plays ``sequence`` (a file or a ``keypose.Sequence``) on the connected LeRobot ``robot``
    with keypose's player, at ``rate`` Hz (the robot's control rate by default).

    The player reads the arm, ramps from there to the first pose, streams each goal through
    the step limiter and the position guard, and holds the final pose at the end, torque on.
    Ctrl-C brakes to rest along the path and holds (a second Ctrl-C holds at once); so does
    ``stop.request()`` from another thread. A goal held ``max_stall`` s beyond its period brakes
    and raises ``HardwareError``; so do stalls too frequent to keep up with the rate (unless
    ``judge_pace`` is False), and any exception of the robot. ``compensate_droop`` sends goals
    that lead the path by each servo's droop under the arm's weight (``keypose play
    --compensate-droop``: the standard 5 V SO-101 otherwise rests 3–6° below its keys).

    Returns what the playback did: ``outcome`` (``finished``, ``stopped`` or ``held``), ``rate``,
    ``cycles``, ``approach_seconds``, ``max_tracking_error`` (and its joint), ``limited_goals``
    (goals the limiter changed; 0 in ordinary playback), ``late`` and ``stalls``.
    """
    played = _sequence_on(robot, sequence)
    stop = stop if stop is not None else StopRequests()
    with _ctrl_c_stops(stop):
        return _keypose.play_lerobot(
            played,
            robot,
            motors_of(robot),
            stop=stop,
            rate=rate,
            speed=speed,
            max_stall=max_stall,
            judge_pace=judge_pace,
            compensate_droop=compensate_droop,
        )
