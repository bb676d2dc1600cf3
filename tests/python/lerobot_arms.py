"""LeRobot's own robot classes on keypose's emulated servo bus, for the LeRobot tests.

`keypose virtual-bus` (the installed console script) serves emulated servos on a
pseudo-terminal; LeRobot's `SO101Follower` / `KochFollower` connect to it through their own
motor bus (the vendor SDKs) exactly as to a USB adapter. The arm is calibrated by LeRobot's own
code: `set_half_turn_homings()` (the emulated servos apply the homing offset as the firmware
does), then a recorded range around the middle, written with `write_calibration()`.
"""

import json
import os
import subprocess
import tempfile
from contextlib import contextmanager
from pathlib import Path

from conftest import REPO, keypose_command

# The ranges of motion recorded by hand on a real SO-101 (tests/data/lerobot_so101_follower.json),
# in ticks, each put around the middle the half-turn homing makes (2047).
MIDDLE = 2047


# What `virtual-bus --physics` says on its way out: the physics' processor time.
PHYSICS_COST = "virtual-bus: the physics took "


def simulation_cache() -> Path:
    """keypose's Python environment with MuJoCo, the one the Rust suites build (scripts/test
    runs them first; alone, keypose builds it on first use, which takes minutes)."""
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    return target / "tmp" / "python_cache"


@contextmanager
def virtual_bus(robot: str, physics: bool = False):
    """`keypose virtual-bus --robot ROBOT` (with `--physics`: the arm in MuJoCo behind the
    servos): yields the pseudo-terminal's path, ends the bus after (it serves until its
    standard input closes). Its standard error goes to a file, never to a pipe nobody reads (a
    full pipe would stop the bus mid-write)."""
    command = [str(keypose_command()), "virtual-bus", "--robot", robot]
    env = dict(os.environ)
    if physics:
        command.append("--physics")
        env["KEYPOSE_CACHE"] = str(simulation_cache())
    with tempfile.TemporaryFile(mode="w+") as errors:
        bus = subprocess.Popen(
            command,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=errors,
            text=True,
            env=env,
        )
        try:
            port = bus.stdout.readline().strip()
            if not port.startswith("/dev/"):
                errors.seek(0)
                raise AssertionError(f"keypose virtual-bus printed {port!r}: {errors.read()}")
            yield port
        finally:
            bus.stdin.close()
            bus.wait(timeout=60)
            errors.seek(0)
            said = [line for line in errors.read().splitlines() if line.strip()]
            if physics:
                assert said and said[-1].startswith(PHYSICS_COST), f"keypose virtual-bus said: {said}"
                said = said[:-1]
            assert not said, f"keypose virtual-bus said: {said}"


def disconnect(robot, tries: int = 3) -> None:
    """`robot.disconnect()`, tried again when a servo's answer to LeRobot's torque-off write
    did not come in time. The emulated servos are another process: on a machine busy enough
    it is not scheduled within LeRobot's packet timeout (a few milliseconds), which LeRobot
    reports as "There is no status packet!" with the robot still connected."""
    for attempt in range(tries):
        try:
            robot.disconnect()
            return
        except ConnectionError:
            if attempt == tries - 1:
                raise


def spans(data_file: Path) -> dict:
    """Each motor's recorded span (range_max − range_min) in a LeRobot calibration file."""
    return {name: m["range_max"] - m["range_min"] for name, m in json.loads(data_file.read_text()).items()}


def calibrate(robot, motor_spans: dict, drive_modes: dict = None) -> None:
    """Calibrates the connected `robot` with LeRobot's own calls, the arm resting mid-range:
    half-turn homing, then each motor's span around the middle, written to the servos and kept
    as the robot's calibration (what `robot.calibrate()` does after its prompts)."""
    from lerobot.motors import MotorCalibration

    robot.bus.disable_torque()
    homings = robot.bus.set_half_turn_homings()
    calibration = {}
    for name, motor in robot.bus.motors.items():
        half = motor_spans[name] // 2
        calibration[name] = MotorCalibration(
            id=motor.id,
            drive_mode=(drive_modes or {}).get(name, 0),
            homing_offset=homings[name],
            range_min=MIDDLE - half,
            range_max=MIDDLE + half,
        )
    robot.bus.write_calibration(calibration)
    robot.calibration = calibration
    robot.configure()
    assert robot.is_calibrated


def reaches(robot, expected: dict, tolerance: dict, tries: int = 5000) -> dict:
    """The observation once every value in `expected` is within its `tolerance` (the emulated
    servos lag their goal by a time constant), read at most `tries` times: counted in reads,
    not in seconds, so a busy machine only makes it slower. Fails showing the last reading."""
    for _ in range(tries):
        now = robot.get_observation()
        if all(abs(now[key] - value) <= tolerance[key] for key, value in expected.items()):
            return now
    raise AssertionError(f"the arm did not reach {expected} within {tries} reads: {now}")
