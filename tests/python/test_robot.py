"""keypose.Robot: limits, the tool's pose (forward kinematics) and the joints for a tool pose
(inverse kinematics), against the robot files, the published models' numbers the Rust tests
use, hand-derived geometry and the command line's tool path."""

import json
import math
import os

import numpy as np
import pytest

import keypose
from conftest import SO101_JOINTS, cli, repo, robot_file

CALIBRATION = "tests/data/lerobot_so101_follower.json"
DEG_PER_TICK = 360 / 4096


def test_limits_are_the_robot_files():
    robot = keypose.Robot("so101")
    assert robot.name == "so101" and robot.joints == SO101_JOINTS
    assert list(robot.limits) == SO101_JOINTS
    for joint in robot_file("so101")["joints"]:
        limits = robot.limits[joint["name"]]
        written = joint["limits"]
        assert (limits.min, limits.max, limits.velocity, limits.acceleration) == (
            written["min"],
            written["max"],
            written["velocity"],
            written["acceleration"],
        )
        assert limits.unit == "deg"


def test_a_lerobot_type_name_is_its_built_in_arm():
    assert keypose.Robot("so101_follower").joints == SO101_JOINTS


def test_the_tool_at_zero_is_where_the_official_models_put_it():
    # SO-101: the tcp measured in MuJoCo on the official model (tests/motion/robots.rs).
    so101 = keypose.Robot("so101").tool([0] * 6)
    assert so101.xyz == pytest.approx((0.39136, -0.00001, 0.22647), abs=1e-4)
    # OpenMANIPULATOR-X: 0.286 m in front, 0.2045 m up at zero; a quarter turn of joint1 about
    # the vertical axis through x = 0.012 puts the tool 0.274 m from that axis along +y.
    omx = keypose.Robot("omx")
    assert omx.tool([0] * len(omx.joints)).xyz == pytest.approx((0.2860, 0.0, 0.2045), abs=1e-4)
    turned = omx.tool([90] + [0] * (len(omx.joints) - 1))
    assert turned.xyz == pytest.approx((0.012, 0.274, 0.2045), abs=1e-9)
    # The tool frame turns with the base: yaw grows by the quarter turn.
    at_zero = omx.tool([0] * len(omx.joints))
    assert turned.rpy[2] - at_zero.rpy[2] == pytest.approx(90.0, abs=1e-9)


def test_the_tool_path_is_the_command_lines(tmp_path):
    sequence = keypose.load(repo("sequences/so101_wave.json"))
    t, q = sequence.sample(rate=10)
    out = cli("sample", repo("sequences/so101_wave.json"), "--rate", 10, "--tool", "--format", "json", check_code=0)
    samples = json.loads(out.stdout)
    assert samples["columns"][-3:] == ["tool_x", "tool_y", "tool_z"]
    robot = sequence.robot
    for pose, row in zip(q, samples["rows"]):
        assert robot.tool(pose).xyz == tuple(row[-3:])


def test_a_solved_pose_puts_the_tool_where_asked_inside_the_limits():
    robot = keypose.Robot("so101")
    limits = list(robot.limits.values())
    for xyz in ([0.25, 0.0, 0.15], [0.2, 0.1, 0.1], [0.3, -0.05, 0.2]):
        q = robot.solve(xyz)
        assert isinstance(q, np.ndarray) and q.shape == (6,)
        assert robot.tool(q).xyz == pytest.approx(xyz, abs=1e-6)
        assert all(l.min <= v <= l.max for v, l in zip(q, limits))


def test_a_solved_pose_meets_an_orientation_the_arm_can_reach():
    # A pose the arm reaches (joints well inside their limits), then that pose's tool pose
    # solved back: position and orientation are met.
    robot = keypose.Robot("so101")
    q0 = [10, -30, 40, 20, 15, 0]
    pose = robot.tool(q0)
    q = robot.solve(pose.xyz, rpy=pose.rpy, seed=[0] * 6)
    back = robot.tool(q)
    assert back.xyz == pytest.approx(pose.xyz, abs=1e-6)
    assert back.rpy == pytest.approx(pose.rpy, abs=1e-4)


def _rotation(rpy_deg):
    """URDF's R = Rz(yaw)·Ry(pitch)·Rx(roll), written out."""
    r, p, y = np.radians(rpy_deg)
    rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    return rz @ ry @ rx


def test_a_tool_pointing_down():
    robot = keypose.Robot("so101")
    q = robot.solve([0.2, 0.0, 0.05], approach="down")
    pose = robot.tool(q)
    assert pose.xyz == pytest.approx((0.2, 0.0, 0.05), abs=1e-6)
    # One of the tool frame's axes (its approach axis) points straight down.
    axes = _rotation(pose.rpy).T
    assert min(np.linalg.norm(axis - [0, 0, -1]) for axis in axes) < 1e-3


def test_a_target_out_of_reach_is_an_input_error_saying_how_far():
    robot = keypose.Robot("so101")
    with pytest.raises(keypose.InputError, match="cannot reach") as raised:
        robot.solve([1.0, 0.0, 0.2])
    assert raised.value.file is None and "mm" in raised.value.reason
    with pytest.raises(keypose.InputError, match="xyz"):
        robot.solve([0.2, 0.0])
    with pytest.raises(keypose.InputError, match="approach"):
        robot.solve([0.2, 0.0, 0.1], approach="up")


def test_a_pose_of_the_wrong_length_or_joint_is_an_input_error():
    robot = keypose.Robot("so101")
    with pytest.raises(keypose.InputError, match="expected 6 values"):
        robot.tool([0, 0])
    with pytest.raises(keypose.InputError, match="no joint"):
        robot.tool({"elbow": 1})
    with pytest.raises(keypose.InputError, match="finite"):
        robot.tool([math.nan] * 6)


def _calibrated_ends():
    """Each joint's ends from the LeRobot calibration, worked out by hand: the zero is the middle
    of the recorded range, each end half the range away at 360/4096° a tick
    (tests/commands/calibrated_limits.rs: elbow_flex ±1117.5 ticks = ±98.2177734375°)."""
    recorded = json.loads(repo(CALIBRATION).read_text())
    return {
        name: (r["range_max"] - r["range_min"]) / 2 * DEG_PER_TICK
        for name, r in recorded.items()
        if name != "wrist_roll"  # recorded over the whole turn: it keeps the robot's limits
    }


def test_a_lerobot_calibration_file_sets_the_recorded_ranges():
    robot = keypose.Robot("so101", calibration=repo(CALIBRATION))
    ends = _calibrated_ends()
    assert ends["elbow_flex"] == 98.2177734375
    for name, half in ends.items():
        limits = robot.limits[name]
        assert (limits.min, limits.max) == pytest.approx((-half, half), abs=1e-9), name


def test_a_lerobot_robot_id_finds_the_calibration_where_lerobot_keeps_it(tmp_path, monkeypatch):
    folder = tmp_path / "robots" / "so_follower"
    folder.mkdir(parents=True)
    (folder / "my_follower.json").write_text(repo(CALIBRATION).read_text())
    monkeypatch.setenv("HF_LEROBOT_CALIBRATION", str(tmp_path))
    robot = keypose.Robot("so101_follower", robot_id="my_follower")
    assert robot.limits["elbow_flex"].max == pytest.approx(98.2177734375, abs=1e-9)
    with pytest.raises(keypose.InputError, match="no LeRobot calibration"):
        keypose.Robot("so101_follower", robot_id="someone_else")


def test_an_unknown_robot_is_an_input_error_with_the_command_lines_message(tmp_path):
    with pytest.raises(keypose.InputError) as raised:
        keypose.Robot("nonesuch")
    path = tmp_path / "seq.json"
    path.write_text(repo("sequences/so101_wave.json").read_text())
    out = cli("check", path, "--robot", "nonesuch", check_code=2)
    assert out.stderr == f"error: {raised.value}\n"


def test_an_rpy_in_radians_given_to_solve_is_named_as_such():
    # The API's angles are degrees (as its joint values); a file's rpy is radians. [3.14, 0, 0]
    # in degrees is a tool nearly level, which the SO-101 cannot hold there.
    robot = keypose.Robot("so101")
    with pytest.raises(keypose.InputError) as error:
        robot.solve([0.25, 0.0, 0.05], rpy=[3.14, 0.0, 0.0])
    assert "rpy here is in degrees" in str(error.value)
    assert "that is [179.9, 0.0, 0.0] degrees" in str(error.value)
