# Types of the native module keypose._keypose: keypose's Python API, which keypose/__init__.py
# re-exports (checked against the module by mypy's stubtest, tests/python/test_package.py).
from os import PathLike
from typing import Any, Dict, List, Literal, Mapping, Optional, Sequence as Seq, Tuple, Union, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "cli_main",
    "load",
    "Sequence",
    "Report",
    "Contact",
    "Violation",
    "JointSummary",
    "Robot",
    "Limits",
    "ToolPose",
    "StopRequests",
    "play_lerobot",
    "Error",
    "InputError",
    "HardwareError",
    "LimitError",
    "__version__",
]

__version__: str

def cli_main(argv: List[str]) -> int:
    """Runs the `keypose` command line with `argv` (the program's name first); its exit code."""

_Path = Union[str, "PathLike[str]"]
_Pose = Union[Seq[float], Mapping[str, float], npt.NDArray[np.float64]]

class Error(Exception):
    """Every error keypose raises: the message is what the command line prints after `error: `."""

class InputError(Error):
    """Bad input (a file, an argument), and where it is."""

    file: Optional[str]
    """The file as named (`<keys>` for a sequence built in code; None for an argument)."""
    path: Optional[str]
    """The JSON path of the field, such as `$.keyframes[2].joints.elbow_flex`, or None."""
    line: Optional[int]
    """Line of a JSON syntax error (from 1), or None."""
    column: Optional[int]
    """Column of a JSON syntax error (from 1), or None."""
    reason: str
    """What is wrong, and what was expected."""

class HardwareError(Error):
    """The servos, the bus, the port or a helper process failed."""

class LimitError(Error):
    """The motion cannot be made to keep the joints' limits (what retiming cannot mend)."""

    report: Report
    """The check that says where."""

def load(
    path: _Path,
    *,
    robot: Optional[str] = None,
    calibration: Union[_Path, Seq[_Path], None] = None,
    robot_id: Union[str, Seq[str], None] = None,
    interpolation: Optional[Literal["step", "linear", "smooth", "cubic", "monotone"]] = None,
    payload: Optional[float] = None,
    robot_variant: Optional[Literal["5v", "7.4v", "12v"]] = None,
) -> Sequence:
    """Reads a sequence file and its robot as `keypose check FILE` does; `robot` replaces the
    robot the file names; a LeRobot calibration from a file or from the id LeRobot calibrated
    the arm with is applied to it (on a sequence of several arms a list, `"ARM=FILE"` or
    `"ARM=ID"` each); `payload` (kg at the TCP) and `robot_variant` (the servos' build) as
    `--payload` and `--robot-variant` give them."""

# Native classes: not to be subclassed.
@final
class Sequence:
    """A sequence on its robot (calibration applied)."""

    def __new__(
        cls,
        robot: Union[str, Robot],
        keys: Seq[Mapping[str, Any]],
        *,
        interpolation: Literal["step", "linear", "smooth", "cubic", "monotone"] = "cubic",
        description: Optional[str] = None,
    ) -> Sequence:
        """A sequence built from keys in code, each a dict as a sequence file writes a keyframe
        (`{"time": 1.0, "joints": {"elbow_flex": 30}}`); errors name `<keys>` and the JSON path
        `$.keyframes[i]…` of the key."""
    @property
    def joints(self) -> List[str]:
        """The joints' names: the columns of `sample`'s q."""
    @property
    def robot(self) -> Robot: ...
    @property
    def file(self) -> str: ...
    @property
    def interpolation(self) -> str: ...
    @property
    def start(self) -> float:
        """Time of the first played key, seconds."""
    @property
    def end(self) -> float:
        """Time of the last played key, seconds."""
    @property
    def key_times(self) -> List[float]: ...
    @property
    def keys(self) -> List[Dict[str, Any]]:
        """The keys as a sequence file writes them."""
    def sample(
        self, rate: float = 100.0
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(t, q) at `rate` Hz from the first to the last played key: t (n,) in seconds, q
        (n, len(joints)) in degrees (metres for a prismatic joint), as `keypose sample`."""
    def check(self) -> Report:
        """The exact check against the joints' limits, as `keypose check`."""
    def lerobot_frames(
        self, fps: int = 30, units: Literal["degrees", "range"] = "degrees"
    ) -> Tuple[List[str], npt.NDArray[np.float64]]:
        """The trajectory as LeRobot's frames at `fps`: feature names and values (frames, joints)
        in LeRobot's units, as `keypose export lerobot` writes its `action`."""
    def with_calibration(self, calibration: Union[_Path, Seq[_Path]]) -> Sequence:
        """The same keys on the same robot with the LeRobot calibration `calibration` applied
        (a list of `"ARM=FILE"` on a sequence of several arms)."""
    def retime(self, fastest: bool = False) -> Sequence:
        """Key times stretched until the limits hold, as `keypose retime`; LimitError when
        timing cannot mend it. `fastest=True`: as fast as the limits allow along the path,
        as `keypose retime --fastest`."""
    def save(self, path: _Path) -> None:
        """Writes the sequence atomically, in the layout of the file it was read from."""
    def to_json(self) -> str: ...

@final
class Report:
    """What the exact check found."""

    @property
    def passed(self) -> bool: ...
    @property
    def violations(self) -> List[Violation]: ...
    @property
    def contacts(self) -> List[Contact]:
        """Where the arm comes closer than its clearance to the floor, itself or another arm."""
    @property
    def torque(self) -> Optional[Dict[str, Any]]:
        """Each servo's load against its drive, as `keypose check --format json` gives it."""
    @property
    def joints(self) -> List[JointSummary]: ...
    @property
    def rate(self) -> float:
        """The control rate steps and corners were judged at, Hz."""
    @property
    def text(self) -> str:
        """The report as `keypose check` prints it."""

@final
class Contact:
    """One stretch of time where the arm comes closer than its clearance to something."""

    @property
    def kind(self) -> Literal["floor", "self", "between_arms"]: ...
    @property
    def bodies(self) -> Tuple[str, Optional[str]]: ...
    @property
    def start(self) -> float: ...
    @property
    def end(self) -> float: ...
    @property
    def deepest_time(self) -> float: ...
    @property
    def distance_mm(self) -> float:
        """Negative: that deep into it."""
    @property
    def cause(self) -> Literal["path", "unresolved"]: ...
    @property
    def key(self) -> Optional[int]:
        """The key whose pose is in it: the key to move."""
    @property
    def declared_by_key(self) -> Optional[int]: ...
    @property
    def advice(self) -> str: ...

@final
class Violation:
    """One stretch of time where a joint exceeds a limit."""

    @property
    def joint(self) -> str: ...
    @property
    def kind(self) -> Literal["position", "velocity", "acceleration"]: ...
    @property
    def cause(self) -> Literal["curve", "step", "corner"]: ...
    @property
    def unit(self) -> Literal["deg", "m"]: ...
    @property
    def segment(self) -> int:
        """From key `segment` to key `segment + 1`."""
    @property
    def segment_label(self) -> str: ...
    @property
    def start(self) -> float: ...
    @property
    def end(self) -> float: ...
    @property
    def peak_time(self) -> float: ...
    @property
    def peak(self) -> float: ...
    @property
    def limit(self) -> float: ...
    @property
    def excess(self) -> float: ...

@final
class JointSummary:
    """How close one joint comes to its limits."""

    @property
    def joint(self) -> str: ...
    @property
    def unit(self) -> Literal["deg", "m"]: ...
    @property
    def min_position(self) -> float: ...
    @property
    def max_position(self) -> float: ...
    @property
    def peak_velocity(self) -> float: ...
    @property
    def velocity_limit(self) -> float: ...
    @property
    def peak_acceleration(self) -> float: ...
    @property
    def acceleration_limit(self) -> float: ...

@final
class Limits:
    """A joint's limits in its unit and per second."""

    @property
    def min(self) -> float: ...
    @property
    def max(self) -> float: ...
    @property
    def velocity(self) -> float: ...
    @property
    def acceleration(self) -> float: ...
    @property
    def unit(self) -> Literal["deg", "m"]: ...

@final
class ToolPose:
    """Where the tool is: metres and URDF roll, pitch, yaw in degrees, base frame."""

    @property
    def xyz(self) -> Tuple[float, float, float]: ...
    @property
    def rpy(self) -> Tuple[float, float, float]: ...

@final
class Robot:
    """An arm: a built-in, a LeRobot robot type or a robot file, calibration applied."""

    def __new__(
        cls,
        name_or_path: str,
        *,
        calibration: Optional[_Path] = None,
        robot_id: Optional[str] = None,
    ) -> Robot: ...
    @property
    def name(self) -> str: ...
    @property
    def joints(self) -> List[str]: ...
    @property
    def limits(self) -> Dict[str, Limits]: ...
    @property
    def units(self) -> Dict[str, Literal["deg", "m"]]: ...
    @property
    def home(self) -> List[float]: ...
    @property
    def control_hz(self) -> float: ...
    def tool(self, q: _Pose) -> ToolPose:
        """Where the tool is at `q` (joint order, or a dict with the others at home)."""
    def solve(
        self,
        xyz: Seq[float],
        rpy: Optional[Seq[float]] = None,
        seed: Optional[_Pose] = None,
        *,
        approach: Optional[Literal["down", "down-or-tilted"]] = None,
    ) -> npt.NDArray[np.float64]:
        """The joints that put the tool at `xyz` (metres), oriented by `rpy` (degrees) or
        pointing as `approach` says, chosen as a sequence's tool key is, near `seed` (home)."""

@final
class StopRequests:
    """Stop requests for a playback: the first brakes to rest along the path, the second holds
    where the arm is."""

    def __new__(cls) -> StopRequests: ...
    def request(self) -> None:
        """Asks for a stop (safe from another thread or a signal handler)."""
    @property
    def count(self) -> int: ...

def play_lerobot(
    sequence: Sequence,
    robot: Any,
    motors: List[Dict[str, Any]],
    *,
    stop: StopRequests,
    rate: Optional[float] = None,
    speed: float = 1.0,
    max_stall: float = 0.25,
    judge_pace: bool = True,
    compensate_droop: bool = False,
) -> Dict[str, Any]:
    """keypose's player on a LeRobot robot object (keypose.lerobot.play is the way to call it)."""
