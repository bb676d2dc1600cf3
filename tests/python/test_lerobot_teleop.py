"""KeyposeTeleop: found by LeRobot's own plugin discovery (the installed
lerobot_teleoperator_keypose distribution), made by its own factory, and recording a dataset
with ``lerobot-record`` on LeRobot's SO101Follower over the emulated servos, with a camera.

The oracles: LeRobot's registry and factory, LeRobotDataset reading what lerobot-record wrote,
the frames `keypose export lerobot` writes for the same sequence (read back by LeRobot), and
the keys' values by hand at their frames.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import keypose
from conftest import SO101_JOINTS, repo, write_sequence
from lerobot_arms import MIDDLE, spans, virtual_bus

from lerobot.datasets.lerobot_dataset import LeRobotDataset
from lerobot.teleoperators import TeleoperatorConfig
from lerobot.teleoperators.utils import make_teleoperator_from_config
from lerobot.utils.import_utils import register_third_party_plugins

HERE = Path(__file__).resolve().parent


def raise_and_lower(tmp_path: Path) -> Path:
    """elbow_flex 0 → 30 → 0 over 3 s from the arm's rest (all joints at 0)."""
    return write_sequence(
        tmp_path / "raise.json",
        "so101",
        [
            {"time": 0, "joints": {"elbow_flex": 0}},
            {"time": 1.5, "joints": {"elbow_flex": 30}},
            {"time": 3, "joints": {"elbow_flex": 0}},
        ],
        interpolation="monotone",
    )


def follower_calibration(folder: Path) -> Path:
    """A follower calibration as LeRobot's calibrate() leaves one on the emulated arm at rest:
    homing offsets 0 (the servos rest at the middle), each recorded span around 2047."""
    ids = dict(zip(SO101_JOINTS, range(1, 7)))
    calibration = {
        name: {"id": ids[name], "drive_mode": 0, "homing_offset": 0,
               "range_min": MIDDLE - span // 2, "range_max": MIDDLE + span // 2}
        for name, span in spans(repo("tests/data/lerobot_so101_follower.json")).items()
    }
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "follower.json"
    path.write_text(json.dumps(calibration, indent=4))
    return path


def teleop_config(tmp_path, sequence, **more):
    config_class = TeleoperatorConfig.get_choice_class("keypose")
    return config_class(sequence=sequence, calibration_dir=tmp_path / "teleop", **more)


def test_lerobot_discovers_and_makes_the_teleoperator(tmp_path):
    # What lerobot-record and lerobot-teleoperate do first: import every installed
    # lerobot_teleoperator_* distribution.
    register_third_party_plugins()
    assert "keypose" in TeleoperatorConfig.get_known_choices()
    teleop = make_teleoperator_from_config(teleop_config(tmp_path, raise_and_lower(tmp_path)))
    assert type(teleop).__name__ == "KeyposeTeleop" and teleop.name == "keypose"
    assert teleop.action_features == {f"{j}.pos": float for j in SO101_JOINTS}


def test_each_action_is_the_next_frame_then_the_last_pose_holds(tmp_path):
    register_third_party_plugins()
    calibration = follower_calibration(tmp_path / "robot")
    sequence = raise_and_lower(tmp_path)
    teleop = make_teleoperator_from_config(teleop_config(tmp_path, sequence, robot_calibration=calibration))
    teleop.connect()
    actions = [teleop.get_action() for _ in range(100)]
    teleop.disconnect()
    elbow = [a["elbow_flex.pos"] for a in actions]
    # 3 s at 30 fps: 91 frames; the keys at frames 0, 45, 90, by hand.
    assert (elbow[0], elbow[45], elbow[90]) == (0, 30, 0)
    assert all(a == actions[90] for a in actions[91:])
    # The same frames `keypose export lerobot` writes, as LeRobot reads them.
    out = tmp_path / "exported"
    env = {**os.environ, "KEYPOSE_PYTHON": sys.executable}
    subprocess.run([str(Path(sys.executable).parent / "keypose"), "export", "lerobot", str(sequence), "-o", str(out),
                    "--calibration", str(calibration)], check=True, env=env, capture_output=True)
    exported = LeRobotDataset("local/exported", root=out)
    assert exported.num_frames == 91
    for k in range(91):
        assert np.array_equal(exported[k]["action"].numpy(), np.array([actions[k][f"{j}.pos"] for j in SO101_JOINTS], dtype=np.float32))


def test_a_sequence_that_breaks_the_limits_is_refused_at_connect(tmp_path):
    register_third_party_plugins()
    fast = write_sequence(tmp_path / "fast.json", "so101", [
        {"time": 0, "joints": {"shoulder_pan": 0}}, {"time": 0.2, "joints": {"shoulder_pan": 90}}],
        interpolation="linear")
    teleop = make_teleoperator_from_config(teleop_config(tmp_path, fast))
    with pytest.raises(keypose.LimitError, match="refusing to play"):
        teleop.connect()
    assert not teleop.is_connected


def test_lerobot_record_records_a_scripted_demonstration_with_a_camera(tmp_path):
    calibration = follower_calibration(tmp_path / "robot")
    sequence = raise_and_lower(tmp_path)
    root = tmp_path / "demo"
    with virtual_bus("so101") as port:
        done = subprocess.run(
            [sys.executable, str(HERE / "run_lerobot_record.py"),
             "--robot.type=so101_follower", f"--robot.port={port}", "--robot.id=follower",
             f"--robot.calibration_dir={calibration.parent}",
             "--robot.cameras={front: {type: pattern, width: 64, height: 48, fps: 30}}",
             "--teleop.type=keypose", f"--teleop.sequence={sequence}",
             f"--teleop.robot_calibration={calibration}", f"--teleop.calibration_dir={tmp_path / 'teleop'}",
             "--dataset.repo_id=local/demo", f"--dataset.root={root}", "--dataset.fps=30",
             "--dataset.num_episodes=1", "--dataset.episode_time_s=3.5", "--dataset.reset_time_s=0",
             "--dataset.single_task=raise and lower the forearm", "--dataset.push_to_hub=false",
             "--display_data=false", "--play_sounds=false"],
            # The follower's calibration file differs from what the fresh servos hold: LeRobot
            # asks whether to write it to them (ENTER: yes).
            input="\n", capture_output=True, text=True, timeout=900, cwd=HERE,
            env={**os.environ, "PYTHONPATH": str(HERE)},
        )
    assert done.returncode == 0, done.stderr[-4000:]
    # Video frames decoded with PyAV (its wheel carries FFmpeg), not torchcodec, which needs the
    # system's FFmpeg libraries.
    dataset = LeRobotDataset("local/demo", root=root, video_backend="pyav")
    assert dataset.num_episodes == 1 and dataset.fps == 30
    assert dataset.meta.tasks.index[0] == "raise and lower the forearm"
    assert "observation.images.front" in dataset.meta.video_keys
    n = dataset.num_frames
    assert n > 0
    # Each recorded action is the teleoperator's next frame (however many frames the loop got
    # through on this machine): elbow_flex by hand at the keys' frames, rising then falling.
    action = np.stack([dataset[k]["action"].numpy() for k in range(n)])
    elbow = action[:, SO101_JOINTS.index("elbow_flex")]
    assert elbow[0] == 0 and (n <= 45 or elbow[45] == 30) and (n <= 90 or elbow[90] == 0)
    assert np.all(np.diff(elbow[:min(n, 46)]) >= 0)
    others = np.delete(action, SO101_JOINTS.index("elbow_flex"), axis=1)
    assert np.all(others[:, :4] == 0)
    # The camera's frames went through LeRobot's video encoding and back: one per frame.
    image = dataset[0]["observation.images.front"]
    assert tuple(image.shape) == (3, 48, 64)
    # The follower measured its own pose: it rested at 0 when the recording began.
    state = dataset[0]["observation.state"].numpy()
    assert np.allclose(state[:5], 0, atol=0.1)


def test_bad_config_values_are_input_errors_naming_the_field(tmp_path):
    register_third_party_plugins()
    sequence = raise_and_lower(tmp_path)
    for fps in (-30, 0, 1.5, True, 10**30):
        with pytest.raises(keypose.InputError, match="fps: expected a whole number"):
            teleop_config(tmp_path, sequence, fps=fps)
    # A command line's spellings of a boolean are read as meant, not as truthy text.
    assert teleop_config(tmp_path, sequence, use_degrees="no").use_degrees is False
    assert teleop_config(tmp_path, sequence, use_degrees="True").use_degrees is True
    with pytest.raises(keypose.InputError, match="use_degrees: expected true or false"):
        teleop_config(tmp_path, sequence, use_degrees="maybe")


def test_a_sequence_for_another_arm_than_the_follower_is_refused(tmp_path, monkeypatch):
    register_third_party_plugins()
    from keypose.teleop import KeyposeTeleop

    koch = repo("sequences/koch_wave.json")
    # The SO-101's and the Koch's motors share names: only the follower's type tells them apart.
    with pytest.raises(keypose.InputError, match="a sequence for koch, but the follower is so101_follower"):
        KeyposeTeleop(teleop_config(tmp_path, koch, robot_type="so101_follower"))
    # lerobot-record's own --robot.type, when the teleoperator's config does not say; LeRobot's
    # factory hands the refusal on inside its ValueError, which lerobot-record prints.
    monkeypatch.setattr(sys, "argv", ["lerobot-record", "--robot.type=so101_follower", f"--teleop.sequence={koch}"])
    with pytest.raises(ValueError, match="the follower is so101_follower"):
        make_teleoperator_from_config(teleop_config(tmp_path, koch))
    monkeypatch.setattr(sys, "argv", ["lerobot-record", "--robot.type", "koch_follower"])
    assert make_teleoperator_from_config(teleop_config(tmp_path, koch)).action_features
    # An unknown follower type is named with what keypose knows.
    with pytest.raises(keypose.InputError, match="unknown robot"):
        KeyposeTeleop(teleop_config(tmp_path, koch, robot_type="bi_koch_follower"))
