"""keypose.load and keypose.Sequence: samples, the check, retiming and saving, against the
command line's output and hand-derived numbers."""

import json

import numpy as np
import pytest

import keypose
from conftest import SO101_JOINTS, cli, repo, robot_file, write_sequence

WAVE = "sequences/so101_wave.json"


def test_a_loaded_sequence_has_its_robots_joints_in_the_robot_files_order():
    sequence = keypose.load(repo(WAVE))
    order = [j["name"] for j in robot_file("so101")["joints"]]
    assert sequence.joints == order == SO101_JOINTS
    assert sequence.robot.joints == order
    assert sequence.file == str(repo(WAVE))


def test_samples_are_the_command_lines_to_the_last_bit():
    sequence = keypose.load(repo(WAVE))
    for rate in (100, 37.5):
        t, q = sequence.sample(rate=rate)
        out = cli("sample", repo(WAVE), "--rate", rate, "--format", "json", check_code=0)
        samples = json.loads(out.stdout)
        assert samples["columns"] == ["time", *sequence.joints]
        assert samples["units"] == "deg"
        rows = np.array(samples["rows"])
        assert t.shape == (len(rows),) and q.shape == (len(rows), len(sequence.joints))
        assert np.array_equal(t, rows[:, 0])
        assert np.array_equal(q, rows[:, 1:])


def test_a_linear_sequence_samples_as_worked_out_by_hand():
    # elbow_flex 0 → 90° over 2 s, then holds to 3 s: 45°/s, so 22.5° at 0.5 s; 100 Hz from
    # 0 to 3 s inclusive is 301 rows at k / 100 s.
    sequence = keypose.Sequence(
        "so101",
        [
            {"time": 0, "joints": {"elbow_flex": 0}},
            {"time": 2, "joints": {"elbow_flex": 90}},
            {"time": 3, "joints": {"elbow_flex": 90}},
        ],
        interpolation="linear",
    )
    t, q = sequence.sample()
    assert t.shape == (301,)
    assert np.allclose(t, np.arange(301) / 100, rtol=0, atol=1e-12)
    elbow = q[:, sequence.joints.index("elbow_flex")]
    assert elbow[50] == pytest.approx(22.5, abs=1e-9)
    assert elbow[100] == pytest.approx(45.0, abs=1e-9)
    assert elbow[200] == pytest.approx(90.0, abs=1e-9)
    assert elbow[300] == pytest.approx(90.0, abs=1e-9)
    # Joints no key names stay at 0.
    assert np.all(q[:, sequence.joints.index("shoulder_pan")] == 0)
    # The arrays are the caller's to change.
    q[0, 0] = 1.0


def test_the_check_is_the_command_lines(too_fast):
    for path, code in ((repo(WAVE), 0), (too_fast, 1)):
        report = keypose.load(path).check()
        out = cli("check", path, check_code=code)
        assert report.text == out.stdout
        assert str(report) == out.stdout
        assert report.passed == (code == 0)
        found = json.loads(cli("check", path, "--format", "json").stdout)
        assert len(report.violations) == len(found["violations"])
        for v, j in zip(report.violations, found["violations"]):
            assert (v.joint, v.kind, v.peak, v.limit) == (j["joint"], j["kind"], j["peak"], j["limit"])


def test_a_key_in_the_desk_is_a_contact_the_command_line_reports_too(tmp_path):
    # The elbow at 80° with the shoulder level puts the gripper in the desk at key 1; the
    # limits hold.
    path = write_sequence(
        tmp_path / "desk.json",
        "so101",
        [
            {"name": "home", "time": 0, "joints": {"elbow_flex": 0}},
            {"name": "into-desk", "time": 3, "joints": {"elbow_flex": 80}},
            {"name": "back", "time": 6, "joints": {"elbow_flex": 0}},
        ],
        interpolation="cubic",
    )
    report = keypose.load(path).check()
    assert not report.passed and report.violations == []
    found = json.loads(cli("check", path, "--format", "json", check_code=1).stdout)
    contacts = found["clearance"]["contacts"]
    assert [(c.kind, c.bodies, c.key, c.distance_mm) for c in report.contacts] == [
        (c["kind"], tuple(c["bodies"]), c["key"], c["distance_mm"]) for c in contacts
    ]
    gripper = next(c for c in report.contacts if c.bodies[0] == "gripper")
    assert gripper.kind == "floor" and gripper.key == 1 and gripper.distance_mm < -70
    assert "raise key 'into-desk'" in gripper.advice


def test_a_segment_too_fast_is_a_velocity_violation_of_the_distance_over_the_time(too_fast):
    report = keypose.load(too_fast).check()
    assert not report.passed
    limit = robot_file("so101")["joints"][0]["limits"]["velocity"]
    (velocity,) = [v for v in report.violations if v.kind == "velocity"]
    # 100° in 0.5 s.
    assert velocity.joint == "shoulder_pan"
    assert velocity.peak == pytest.approx(200.0, abs=1e-9)
    assert velocity.limit == limit
    assert velocity.excess == pytest.approx(200.0 - limit, abs=1e-9)
    assert velocity.segment == 0 and velocity.segment_label == "a → b"
    assert velocity.unit == "deg" and velocity.cause == "curve"
    assert 0 <= velocity.start <= velocity.peak_time <= velocity.end <= 0.5
    assert "shoulder_pan velocity 200.000 deg/s vs limit 115.000 deg/s" in str(velocity)


def test_the_readme_sequences_peaks_are_the_readmes(tmp_path):
    # The README's first sequence and the peaks its `keypose check` table shows: shoulder_lift
    # −90 → −20° over 2 s, key-time cubic with level ends: 1.5 · 70/2 = 52.5°/s and 6 · 70/4 =
    # 105°/s².
    path = write_sequence(
        tmp_path / "first.json",
        "so101",
        [
            {"name": "rest", "time": 0, "joints": {"shoulder_lift": -90, "elbow_flex": 90, "wrist_flex": 0}},
            {"name": "reach", "time": 2, "joints": {"shoulder_lift": -20, "elbow_flex": 30, "wrist_flex": 30}},
            {"name": "back", "time": 4, "joints": {"shoulder_lift": -90, "elbow_flex": 90, "wrist_flex": 0}},
        ],
        interpolation="cubic",
    )
    report = keypose.load(path).check()
    assert report.passed and report.violations == []
    lift = {s.joint: s for s in report.joints}["shoulder_lift"]
    assert (lift.min_position, lift.max_position) == (-90.0, -20.0)
    assert lift.peak_velocity == pytest.approx(52.5, abs=1e-9)
    assert lift.peak_acceleration == pytest.approx(105.0, abs=1e-9)
    assert lift.velocity_limit == robot_file("so101")["joints"][1]["limits"]["velocity"]


def test_retiming_gives_the_command_lines_sequence_and_it_passes(too_fast, tmp_path):
    sequence = keypose.load(too_fast)
    retimed = sequence.retime()
    written = tmp_path / "retimed.json"
    cli("retime", too_fast, "-o", written, check_code=0)
    assert retimed.to_json() == written.read_text()
    assert retimed.check().passed
    before, after = sequence.key_times, retimed.key_times
    assert all(b - a >= d - c - 1e-12 for (a, b), (c, d) in zip(zip(after, after[1:]), zip(before, before[1:])))
    assert after[1] > before[1]


def test_retiming_what_time_cannot_mend_raises_limit_error_with_the_check(tmp_path):
    # A step: shoulder_pan jumps 100° within one control period, however long the segment.
    path = write_sequence(
        tmp_path / "step.json",
        "so101",
        [{"time": 0, "joints": {"shoulder_pan": 0}}, {"time": 2, "joints": {"shoulder_pan": 100}}],
        interpolation="step",
    )
    cli("retime", path, check_code=1)
    with pytest.raises(keypose.LimitError) as raised:
        keypose.load(path).retime()
    assert isinstance(raised.value, keypose.Error)
    assert "cannot be fixed by retiming" in str(raised.value)
    causes = {(v.joint, v.cause) for v in raised.value.report.violations}
    assert causes == {("shoulder_pan", "step")}
    assert not raised.value.report.passed


def test_the_fastest_retiming_is_what_the_cli_writes_and_passes_the_check(tmp_path):
    fastest = keypose.load(repo(WAVE)).retime(fastest=True)
    assert fastest.check().passed
    out = tmp_path / "fast.json"
    cli("retime", repo(WAVE), "--fastest", "-o", str(out), check_code=0)
    by_cli = keypose.load(str(out))
    assert fastest.key_times == pytest.approx(by_cli.key_times, abs=1e-9)
    # The wave as keyed lasts 8.8 s; timed as fast as its limits allow, it is shorter.
    assert fastest.end < keypose.load(repo(WAVE)).end


def test_saving_keeps_the_files_own_layout_and_reads_back_the_same(tmp_path):
    out = tmp_path / "wave.json"
    sequence = keypose.load(repo(WAVE))
    sequence.save(out)
    assert out.read_bytes() == repo(WAVE).read_bytes()
    again = keypose.load(out)
    assert again.keys == sequence.keys
    assert np.array_equal(again.sample()[1], sequence.sample()[1])
    # No temporary file is left beside it.
    assert [p.name for p in tmp_path.iterdir()] == ["wave.json"]


def test_a_sequence_built_from_keys_saves_as_a_file_the_command_line_checks(tmp_path):
    keys = [
        {"name": "rest", "time": 0, "joints": {"elbow_flex": 0}},
        {"name": "up", "time": 2, "joints": {"elbow_flex": -60}},
    ]
    sequence = keypose.Sequence(keypose.Robot("so101"), keys, interpolation="monotone")
    assert sequence.file == "<keys>" and sequence.interpolation == "monotone"
    assert sequence.keys == keys
    path = tmp_path / "built.json"
    sequence.save(path)
    out = cli("check", path, check_code=0)
    assert out.stdout.splitlines()[1:] == sequence.check().text.splitlines()[1:]


def test_a_bad_file_raises_input_error_with_the_command_lines_message(tmp_path):
    path = write_sequence(
        tmp_path / "bad.json",
        "so101",
        [{"time": 0, "joints": {"elbo_flex": 0}}, {"time": 1, "joints": {"elbow_flex": 10}}],
    )
    with pytest.raises(keypose.InputError) as raised:
        keypose.load(path)
    out = cli("check", path, check_code=2)
    assert out.stderr == f"error: {raised.value}\n"
    error = raised.value
    assert error.file == str(path)
    assert error.path == "$.keyframes[0].joints.elbo_flex"
    assert error.line is None and error.column is None
    assert str(error) == f"{path}: $.keyframes[0].joints.elbo_flex: {error.reason}"
    assert "elbow_flex" in error.reason  # what was expected: the robot's joints


def test_a_syntax_error_says_its_line_and_column(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{"format": "keypose-sequence/1",\n  "robot": "so101",\n  "keyframes": [,]}')
    with pytest.raises(keypose.InputError) as raised:
        keypose.load(path)
    assert (raised.value.line, raised.value.column) == (3, 17)
    assert cli("check", path, check_code=2).stderr == f"error: {raised.value}\n"


def test_bad_keys_in_code_name_the_key_by_its_path():
    with pytest.raises(keypose.InputError) as raised:
        keypose.Sequence("so101", [{"time": 0, "joints": {"nope": 1}}])
    assert raised.value.file == "<keys>"
    assert raised.value.path == "$.keyframes[0].joints.nope"


def test_bad_arguments_are_input_errors():
    sequence = keypose.load(repo(WAVE))
    for rate in (0, -1, float("nan"), 1e9):
        with pytest.raises(keypose.InputError, match="rate"):
            sequence.sample(rate=rate)
    with pytest.raises(keypose.InputError, match="interpolation"):
        keypose.load(repo(WAVE), interpolation="spline")
    with pytest.raises(keypose.InputError, match="unknown robot|no built-in"):
        keypose.load(repo(WAVE), robot="nonesuch")


def test_a_sequence_of_two_arms_samples_as_the_command_line_does():
    path = repo("sequences/bimanual_wave.json")
    sequence = keypose.load(path)
    assert all("/" in joint for joint in sequence.joints)
    t, q = sequence.sample(rate=50)
    rows = np.array(json.loads(cli("sample", path, "--rate", 50, "--format", "json", check_code=0).stdout)["rows"])
    assert np.array_equal(t, rows[:, 0]) and np.array_equal(q, rows[:, 1:])
    # One tool per arm: the pose of "the" tool is refused, naming the arms.
    with pytest.raises(keypose.InputError, match="several arms"):
        sequence.robot.tool(q[0])


def test_a_sequence_built_on_a_robot_file_finds_it_again_once_saved_elsewhere(tmp_path, monkeypatch):
    # The robot file named relative to the working directory; the sequence saved in another
    # folder, where a relative name would be read relative to the sequence.
    (tmp_path / "arm.json").write_text(repo("robots/so101.json").read_text())
    monkeypatch.chdir(tmp_path)
    robot = keypose.Robot("arm.json")
    sequence = keypose.Sequence(robot, [{"time": 0, "joints": {"elbow_flex": 0}}, {"time": 1, "joints": {"elbow_flex": 20}}])
    (tmp_path / "saved").mkdir()
    sequence.save(tmp_path / "saved" / "seq.json")
    again = keypose.load(tmp_path / "saved" / "seq.json")
    assert again.robot.joints == robot.joints
    assert np.array_equal(again.sample()[1], sequence.sample()[1])


def test_a_payload_the_5_v_shoulder_cannot_brake_fails_on_5_v_and_passes_on_12_v(tmp_path):
    # The shoulder swings out to reach forward in 1.3 s carrying 50 g: braking at the end asks
    # the 5 V servo for more than its 1.35 N·m stall torque, the 12 V one (2.94 N·m) has room.
    path = write_sequence(
        tmp_path / "swing.json",
        "so101",
        [
            {"name": "low", "time": 0, "joints": {"shoulder_lift": 0, "elbow_flex": -90}},
            {"name": "high", "time": 1.3, "joints": {"shoulder_lift": 90, "elbow_flex": -90}},
        ],
        interpolation="cubic",
    )
    five = keypose.load(path, payload=0.05).check()
    assert not five.passed and five.violations == []
    torque = five.torque
    assert torque["build"] == "sts3215 c001 @ 5 V; 0.050 kg payload"
    found = json.loads(cli("check", path, "--payload", "0.05", "--format", "json", check_code=1).stdout)
    assert torque == found["torque"]
    (overload,) = [o for o in torque["overloads"] if o["joint"] == "shoulder_lift"]
    assert abs(overload["torque"]) > overload["available"]
    twelve = keypose.load(path, payload=0.05, robot_variant="12v").check()
    assert twelve.passed and twelve.torque["build"].startswith("sts3215 c047 @ 12 V")
    with pytest.raises(keypose.InputError, match="payload"):
        keypose.load(path, payload=-1)


def test_keys_take_numpy_numbers_and_arrays_as_lerobot_data_is():
    # LeRobot's frames are float32 arrays; an int64 time is what numpy's arange gives.
    keys = [
        {"time": np.int64(0), "joints": {"elbow_flex": np.float32(0.0)}},
        {"time": np.float64(1.5), "joints": {"elbow_flex": np.float32(30.0), "wrist_flex": np.float32(-12.5)}},
    ]
    sequence = keypose.Sequence("so101", keys)
    _, q = sequence.sample(rate=2.0)
    elbow = sequence.joints.index("elbow_flex")
    assert q[-1][elbow] == pytest.approx(30.0)


def test_a_keys_joints_may_be_a_list_in_the_robots_joint_order():
    values = np.array([0.0, -20.0, 30.0, 10.0, 0.0, 5.0], dtype=np.float32)
    sequence = keypose.Sequence(
        "so101", [{"time": 0, "joints": [0.0] * 6}, {"time": 2, "joints": values}]
    )
    _, q = sequence.sample(rate=1.0)
    assert list(q[-1]) == pytest.approx(values.tolist())
    with pytest.raises(keypose.InputError) as error:
        keypose.Sequence("so101", [{"time": 0, "joints": [0.0, 1.0]}])
    assert error.value.path == "$.keyframes[0].joints"
    assert "a list of 6 values in the robot's joint order (shoulder_pan, " in str(error.value)


def test_a_nan_in_a_key_names_the_key_and_the_joint():
    with pytest.raises(keypose.InputError) as error:
        keypose.Sequence("so101", [{"time": 0, "joints": {"elbow_flex": 0}}, {"time": 1, "joints": {"elbow_flex": float("nan")}}])
    assert error.value.path == "$.keyframes[1].joints.elbow_flex"
    assert "expected a finite number, found NaN" in str(error.value)
