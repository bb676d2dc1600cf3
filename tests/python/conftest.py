"""Shared helpers of the Python package's tests: the repository's files, and the ``keypose``
command line the package installs (its console script), whose output the API is checked against.

scripts/test-python builds and installs the package into a fresh virtual environment and runs
these tests there; nothing here is skipped when missing: a missing command or file fails.
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

SO101_JOINTS = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"]


def repo(path: str) -> Path:
    """A file of the repository."""
    found = REPO / path
    assert found.exists(), f"{found} is missing from the repository"
    return found


def robot_file(name: str) -> dict:
    """A built-in robot's description as its file in robots/ writes it."""
    return json.loads(repo(f"robots/{name}.json").read_text())


def keypose_command() -> Path:
    """The console script the package installed beside this interpreter."""
    script = Path(sys.executable).parent / "keypose"
    assert script.exists(), (
        f"no `keypose` console script beside {sys.executable}: install the package with "
        "`pip install .` (scripts/test-python does)"
    )
    return script


def cli(*args, check_code=None) -> subprocess.CompletedProcess:
    """Runs the installed `keypose` with `args`; with `check_code`, asserts its exit code."""
    done = subprocess.run(
        [str(keypose_command()), *map(str, args)], capture_output=True, text=True, timeout=600
    )
    if check_code is not None:
        assert done.returncode == check_code, (
            f"keypose {' '.join(map(str, args))}: exit {done.returncode}, expected {check_code}\n"
            f"stdout: {done.stdout}\nstderr: {done.stderr}"
        )
    return done


def write_sequence(path: Path, robot: str, keys: list, interpolation: str = "linear") -> Path:
    """A sequence file of `keys` on `robot`."""
    path.write_text(
        json.dumps(
            {
                "format": "keypose-sequence/1",
                "robot": robot,
                "interpolation": interpolation,
                "keyframes": keys,
            },
            indent=2,
        )
    )
    return path


@pytest.fixture
def too_fast(tmp_path) -> Path:
    """shoulder_pan 0 → 100° in 0.5 s, linear: 200°/s, past the SO-101's 115°/s."""
    return write_sequence(
        tmp_path / "too_fast.json",
        "so101",
        [
            {"name": "a", "time": 0, "joints": {"shoulder_pan": 0}},
            {"name": "b", "time": 0.5, "joints": {"shoulder_pan": 100}},
            {"name": "c", "time": 3, "joints": {"shoulder_pan": 100}},
        ],
    )
