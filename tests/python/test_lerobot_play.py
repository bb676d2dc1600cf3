"""keypose.lerobot.play on LeRobot's own SO101Follower and KochFollower, connected to keypose's
emulated servos (`keypose virtual-bus`) through LeRobot's motor bus and the vendor SDKs.

The oracles are LeRobot's: its bus's own normalisation (`_unnormalize` says which servo tick
each action became, `get_observation` reads where the servos are), the calibration's recorded
ranges (the servos' own position limits), the robot file's velocity limits, and hand-derived
tick arithmetic for where each key puts the servo.
"""

import json
import math
import os
import signal
from pathlib import Path

import pytest

import keypose
import keypose.lerobot
from conftest import SO101_JOINTS, repo, robot_file, write_sequence
from lerobot_arms import MIDDLE, calibrate, disconnect, reaches, spans, virtual_bus

from lerobot.robots.koch_follower import KochFollower, KochFollowerConfig
from lerobot.robots.so_follower import SO101Follower, SO101FollowerConfig

TICKS = 4096
SO101_SPANS = spans(repo("tests/data/lerobot_so101_follower.json"))


@pytest.fixture
def so101(tmp_path, request):
    """An SO101Follower on emulated STS3215 servos, calibrated by LeRobot; `use_degrees` from
    the test's parameter (True when not parametrised)."""
    use_degrees = getattr(request, "param", True)
    with virtual_bus("so101") as port:
        config = SO101FollowerConfig(
            port=port, id="follower", calibration_dir=tmp_path / "calibration", use_degrees=use_degrees
        )
        robot = SO101Follower(config)
        robot.connect(calibrate=False)
        calibrate(robot, SO101_SPANS)
        try:
            yield robot
        finally:
            disconnect(robot)


def recording(robot) -> list:
    """Keeps every action sent to `robot` (what keypose's player handed LeRobot), in order."""
    sent = []
    send = robot.send_action

    def send_action(action):
        sent.append(dict(action))
        return send(action)

    robot.send_action = send_action
    return sent


def ticks_sent(robot, actions: list, motor: str) -> list:
    """The servo ticks LeRobot's own bus made of `motor`'s value in each action."""
    motor_id = robot.bus.motors[motor].id
    return [robot.bus._unnormalize({motor_id: a[f"{motor}.pos"]})[motor_id] for a in actions]


def keypose_ticks(degrees: float) -> int:
    """The tick of a keypose joint value on this calibration: zero at the middle of the range,
    4096 ticks a turn (hand-derived; LeRobot's degrees divide by 4095 instead)."""
    return round(MIDDLE + degrees * TICKS / 360)


def velocity_step_ticks(joint: str, rate: float) -> float:
    """The most a goal may move in one period at the robot file's velocity limit, in ticks."""
    velocity = next(j for j in robot_file("so101")["joints"] if j["name"] == joint)["limits"]["velocity"]
    return velocity / rate * TICKS / 360


def wave(tmp_path: Path) -> Path:
    return write_sequence(
        tmp_path / "wave.json",
        "so101",
        [
            {"time": 0, "joints": {"elbow_flex": 30, "wrist_flex": 0}},
            # The wrist up at the elbow's 45°: down, the jaw would be in the desk.
            {"time": 1, "joints": {"elbow_flex": 45, "wrist_flex": -30}},
            {"time": 2, "joints": {"elbow_flex": 20, "wrist_flex": -25}},
        ],
        interpolation="cubic",
    )


def limiter_idle_unless_stalled(result):
    """The step limiter changes no goal of a plan that keeps the limits, unless the machine held
    the player back (a stall: the sequence ran late), when bounding the catch-up is its job.
    (Beside six busy loops two runs had 2 and 3 goals limited.)"""
    if result["stalls"] == 0 and result["late"] == 0:
        assert result["limited_goals"] == 0, result


@pytest.mark.parametrize("so101", [True, False], indirect=True, ids=["degrees", "range"])
def test_play_ends_at_the_last_key_in_the_robots_units(so101, tmp_path):
    result = keypose.lerobot.play(so101, wave(tmp_path))
    assert result["outcome"] == "finished"
    assert result["rate"] == robot_file("so101")["control_hz"]
    limiter_idle_unless_stalled(result)
    ends = {"elbow_flex": keypose_ticks(20), "wrist_flex": keypose_ticks(-25), "shoulder_pan": MIDDLE}
    calibration = so101.bus.calibration
    expected, tolerance = {}, {}
    for motor, tick in ends.items():
        low, high = calibration[motor].range_min, calibration[motor].range_max
        if so101.config.use_degrees:
            # LeRobot's degrees: (tick − middle) · 360 / 4095.
            expected[f"{motor}.pos"] = (tick - MIDDLE) * 360 / (TICKS - 1)
            tolerance[f"{motor}.pos"] = 1.01 * 360 / (TICKS - 1)
        else:
            # LeRobot's −100…100 of the recorded range.
            expected[f"{motor}.pos"] = (tick - low) / (high - low) * 200 - 100
            tolerance[f"{motor}.pos"] = 1.01 * 200 / (high - low)
    reaches(so101, expected, tolerance)


def test_goals_ease_in_from_the_measured_pose_within_the_limits(so101, tmp_path):
    sent = recording(so101)
    rate = 50.0
    result = keypose.lerobot.play(so101, wave(tmp_path), rate=rate)
    # Before torque goes on, the arm is held where it was measured; then a goal per cycle.
    assert result["outcome"] == "finished" and result["cycles"] == len(sent) - 1
    assert all(set(a) == {f"{m}.pos" for m in SO101_JOINTS} for a in sent)
    for motor in SO101_JOINTS:
        ticks = ticks_sent(so101, sent, motor)
        calibration = so101.bus.calibration[motor]
        # The servos' own position limits (write_calibration put the recorded range there).
        assert calibration.range_min <= min(ticks) and max(ticks) <= calibration.range_max, motor
        # The arm rested at the middle: held there, then the first goal is one period's step
        # from there.
        step = velocity_step_ticks(motor, rate)
        assert ticks[0] == MIDDLE and abs(ticks[1] - MIDDLE) <= step + 1, (motor, ticks[:3])
        # No step beyond the velocity limit over one period (one tick of rounding).
        largest = max(abs(b - a) for a, b in zip(ticks, ticks[1:]))
        assert largest <= step + 1, (motor, largest, step)
    # The first key was reached through the ramp: elbow_flex passes 30° on its way.
    assert keypose_ticks(30) in range(min(ticks_sent(so101, sent, "elbow_flex")), MIDDLE + 1000)


def interrupting(robot, at: list) -> list:
    """Records actions and sends this process SIGINT (Ctrl-C) just after action number
    `at[i]` went out, for each i: the moments are counted in goals, not in seconds."""
    sent = recording(robot)
    send = robot.send_action

    def send_action(action):
        done = send(action)
        if len(sent) in at:
            os.kill(os.getpid(), signal.SIGINT)
        return done

    robot.send_action = send_action
    return sent


def long_pan(tmp_path: Path) -> Path:
    return write_sequence(
        tmp_path / "pan.json",
        "so101",
        [
            {"time": 0, "joints": {"shoulder_pan": 0}},
            {"time": 4, "joints": {"shoulder_pan": 90}},
        ],
        interpolation="linear",
    )


def test_ctrl_c_brakes_to_rest_along_the_path_and_holds_with_torque_on(so101, tmp_path):
    sent = interrupting(so101, at=[120])
    # What the process had before: Python's own handler, or SIG_IGN in a process started in
    # the background, which inherits it.
    before = signal.getsignal(signal.SIGINT)
    result = keypose.lerobot.play(so101, long_pan(tmp_path), rate=50.0)
    assert result["outcome"] == "stopped"
    pan = ticks_sent(so101, sent, "shoulder_pan")
    steps = [b - a for a, b in zip(pan, pan[1:])]
    # Moving forwards when the stop came; from there on the steps only shrink, never reverse,
    # down to rest, short of the end (90° is 1024 ticks past the middle).
    after = steps[120:]
    assert steps[119] > 0 and all(s >= 0 for s in after)
    assert all(b <= a + 1 for a, b in zip(after, after[1:])), after
    assert after[-1] <= 1 and pan[-1] < keypose_ticks(90)
    # Holding there, torque on (LeRobot's read of the servos' register).
    assert all(so101.bus.read("Torque_Enable", m) == 1 for m in SO101_JOINTS)
    # The Ctrl-C handler the process had is back.
    assert signal.getsignal(signal.SIGINT) is before


def test_a_second_ctrl_c_holds_at_once(so101, tmp_path):
    sent = interrupting(so101, at=[120, 121])
    result = keypose.lerobot.play(so101, long_pan(tmp_path), rate=50.0)
    assert result["outcome"] == "held"
    # The hold goal is where the arm was measured, sent right after the second request: no
    # braking ramp of many goals follows.
    assert len(sent) <= 124
    assert all(so101.bus.read("Torque_Enable", m) == 1 for m in SO101_JOINTS)


def test_a_sequence_object_plays_too(so101):
    sequence = keypose.Sequence("so101", [{"time": 0, "joints": {"wrist_roll": 0}}, {"time": 1, "joints": {"wrist_roll": 20}}])
    result = keypose.lerobot.play(so101, sequence)
    assert result["outcome"] == "finished"
    reaches(so101, {"wrist_roll.pos": (keypose_ticks(20) - MIDDLE) * 360 / 4095}, {"wrist_roll.pos": 0.1})


def test_a_sequence_of_another_arm_is_refused_naming_the_motor(so101, tmp_path):
    # The Koch's joints have the SO-101's names and ids, but other servos behind them; the
    # SO-101's calibration is refused first, its shoulder_lift range 1.67× the Koch's travel.
    koch = write_sequence(tmp_path / "koch.json", "koch", [{"time": 0, "joints": {"elbow_flex": 10}}])
    sent = recording(so101)
    with pytest.raises(keypose.InputError, match=r"shoulder_lift's recorded range .* but koch's shoulder_lift moves through 124.3 deg .* made on another arm"):
        keypose.lerobot.play(so101, koch)
    assert sent == []


def test_an_uncalibrated_robot_is_refused(tmp_path):
    with virtual_bus("so101") as port:
        robot = SO101Follower(SO101FollowerConfig(port=port, id="blank", calibration_dir=tmp_path))
        robot.connect(calibrate=False)
        try:
            with pytest.raises(keypose.InputError, match="no calibration"):
                keypose.lerobot.play(robot, wave(tmp_path))
        finally:
            disconnect(robot)


def test_koch_follower_on_dynamixel_servos(tmp_path):
    with virtual_bus("koch") as port:
        robot = KochFollower(KochFollowerConfig(port=port, id="koch", calibration_dir=tmp_path, use_degrees=True))
        robot.connect(calibrate=False)
        try:
            calibrate(robot, {name: 2000 for name in robot.bus.motors})
            path = write_sequence(
                tmp_path / "koch.json",
                "koch",
                [{"time": 0, "joints": {"elbow_flex": 0}}, {"time": 1.5, "joints": {"elbow_flex": 40}}],
            )
            result = keypose.lerobot.play(robot, path)
            assert result["outcome"] == "finished"
            reaches(robot, {"elbow_flex.pos": (keypose_ticks(40) - MIDDLE) * 360 / 4095}, {"elbow_flex.pos": 0.1})
        finally:
            disconnect(robot)


def test_bimanual_so_follower_plays_a_sequence_of_two_arms(tmp_path):
    from lerobot.robots.bi_so_follower import BiSOFollower, BiSOFollowerConfig
    from lerobot.robots.so_follower import SOFollowerConfig

    with virtual_bus("so101") as left_port, virtual_bus("so101") as right_port:
        robot = BiSOFollower(BiSOFollowerConfig(
            id="pair", calibration_dir=tmp_path / "calibration",
            left_arm_config=SOFollowerConfig(port=left_port), right_arm_config=SOFollowerConfig(port=right_port)))
        robot.connect(calibrate=False)
        try:
            for arm in (robot.left_arm, robot.right_arm):
                calibrate(arm, SO101_SPANS)
            sent = recording(robot)
            sequence = tmp_path / "pair.json"
            sequence.write_text(json.dumps({
                "format": "keypose-sequence/1",
                # Apart: two arms on one base would be in each other.
                "robots": {"left": {"robot": "so101", "base": {"xyz": [0, 0.2, 0]}},
                           "right": {"robot": "so101", "base": {"xyz": [0, -0.2, 0]}}},
                "interpolation": "cubic",
                "keyframes": [
                    {"time": 0, "joints": {"left/elbow_flex": 0, "right/elbow_flex": 0}},
                    {"time": 1.5, "joints": {"left/elbow_flex": 30, "right/elbow_flex": -20}},
                ],
            }))
            result = keypose.lerobot.play(robot, sequence)
            assert result["outcome"] == "finished"
            limiter_idle_unless_stalled(result)
            # Every action names both arms' motors as BiSOFollower does.
            assert set(sent[0]) == {f"{arm}_{j}.pos" for arm in ("left", "right") for j in SO101_JOINTS}
            degrees = lambda ticks: (ticks - MIDDLE) * 360 / 4095  # noqa: E731
            tolerance = 1.01 * 360 / 4095
            reaches(robot, {"left_elbow_flex.pos": degrees(keypose_ticks(30)),
                            "right_elbow_flex.pos": degrees(keypose_ticks(-20))},
                    {"left_elbow_flex.pos": tolerance, "right_elbow_flex.pos": tolerance})
            # Torque stays on on both arms' buses.
            assert all(arm.bus.read("Torque_Enable", "elbow_flex") == 1 for arm in (robot.left_arm, robot.right_arm))
        finally:
            disconnect(robot)


def test_droop_compensation_leads_the_last_goal_by_the_weight_over_the_stiffness(so101, tmp_path):
    """The wave ends at home (0° everywhere), where the check finds the 5 V shoulder and elbow
    holding the arm's weight: the last goal leads by that torque over the servo's 6 N·m/rad
    (docs/robots.md §14), by hand, and the step limiter stays idle."""
    sent = recording(so101)
    wave = repo("sequences/so101_wave.json")
    result = keypose.lerobot.play(so101, wave, compensate_droop=True)
    assert result["outcome"] == "finished"
    limiter_idle_unless_stalled(result)
    droops = keypose.load(wave).check().torque["droops"]
    for joint in ("shoulder_lift", "elbow_flex"):
        home = [d for d in droops if d["joint"] == joint and d["key_label"] == "home"][-1]
        lead = math.degrees(home["torque"] / 6.0)
        assert abs(lead) > 3.0, (joint, lead)
        assert ticks_sent(so101, sent[-1:], joint)[0] == keypose_ticks(lead), (joint, lead)


def test_droop_compensation_off_sends_the_keys_themselves(so101):
    sent = recording(so101)
    result = keypose.lerobot.play(so101, repo("sequences/so101_wave.json"))
    assert result["outcome"] == "finished"
    for joint in ("shoulder_lift", "elbow_flex"):
        assert ticks_sent(so101, sent[-1:], joint)[0] == keypose_ticks(0.0), joint
