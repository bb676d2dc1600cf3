"""`keypose export lerobot` read back by LeRobot itself (LeRobotDataset), and laid out as
LeRobot's own writer lays out the same episode (LeRobotDataset.create … save_episode …
finalize): the same files, the same parquet schemas, the same info.json. Values against the
keys by hand, statistics against numpy.
"""

import json
import os
import sys
import subprocess

import numpy as np
import pyarrow.parquet as pq
import pytest

from conftest import SO101_JOINTS, keypose_command, repo, write_sequence

from lerobot.datasets.lerobot_dataset import LeRobotDataset

FILES = [
    "data/chunk-000/file-000.parquet",
    "meta/episodes/chunk-000/file-000.parquet",
    "meta/info.json",
    "meta/stats.json",
    "meta/tasks.parquet",
]
CALIBRATION = "tests/data/lerobot_so101_follower.json"


def export(*args, check_code=0):
    """`keypose export lerobot ARGS`, its parquet written with this environment's pyarrow (the
    one LeRobot reads with; KEYPOSE_PYTHON points keypose at this interpreter)."""
    env = {**os.environ, "KEYPOSE_PYTHON": sys.executable}
    done = subprocess.run(
        [str(keypose_command()), "export", "lerobot", *map(str, args)],
        capture_output=True, text=True, timeout=600, env=env,
    )
    assert done.returncode == check_code, f"exit {done.returncode}\nstdout: {done.stdout}\nstderr: {done.stderr}"
    return done


@pytest.fixture
def pan(tmp_path):
    """shoulder_pan 0 → 30 → 30 (monotone cubic), 4 s: at 30 fps 121 frames, the keys at
    frames 0, 60 and 120."""
    return write_sequence(
        tmp_path / "pan.json",
        "so101",
        [
            {"time": 0, "joints": {"shoulder_pan": 0, "gripper": 20}},
            {"time": 2, "joints": {"shoulder_pan": 30}},
            {"time": 4, "joints": {"shoulder_pan": 30}},
        ],
        interpolation="monotone",
    )


def files_of(root):
    return sorted(
        os.path.relpath(os.path.join(d, f), root) for d, _, fs in os.walk(root) for f in fs
    )


def test_lerobot_reads_the_episode_with_the_keys_values(pan, tmp_path):
    out = tmp_path / "pan_ds"
    export(pan, "-o", out, "--task", "pan right", "--calibration", repo(CALIBRATION))
    assert files_of(out) == FILES
    ds = LeRobotDataset("local/pan", root=out)
    assert (ds.num_episodes, ds.num_frames, ds.fps) == (1, 121, 30)
    assert ds.meta.robot_type == "so101_follower"
    assert ds.meta.features["action"]["names"] == [f"{j}.pos" for j in SO101_JOINTS]
    action = np.stack([ds[k]["action"].numpy() for k in range(121)])
    state = np.stack([ds[k]["observation.state"].numpy() for k in range(121)])
    assert ds[0]["task"] == "pan right"
    assert [float(ds[k]["timestamp"]) for k in (0, 60, 120)] == pytest.approx([0, 2, 4], abs=1e-6)
    # shoulder_pan at the keys' frames the keys' values (degrees: no conversion), rising
    # between them, then held.
    assert list(action[[0, 60, 120], 0]) == [0, 30, 30]
    assert np.all(np.diff(action[:61, 0]) > 0) and np.all(action[60:, 0] == 30)
    # The follower measured where the previous frame's action sent it.
    assert np.array_equal(state[1:], action[:-1]) and np.array_equal(state[0], action[0])
    # The gripper in 0…100 % of its calibrated range: keypose's 20° on the calibration's
    # range_min … range_max (hand: 20° is tick mid + 20·4096/360 from the range's middle).
    c = json.loads(repo(CALIBRATION).read_text())["gripper"]
    mid = (c["range_min"] + c["range_max"]) / 2
    percent = (mid + 20 * 4096 / 360 - c["range_min"]) / (c["range_max"] - c["range_min"]) * 100
    assert action[:, 5] == pytest.approx(np.full(121, percent), abs=1e-4)
    # Statistics against numpy over the frames LeRobot read.
    stats = ds.meta.stats["action"]
    assert np.allclose(stats["mean"], action.mean(axis=0), atol=1e-5)
    assert np.allclose(stats["std"], action.std(axis=0), atol=1e-5)
    assert np.allclose(stats["q10"], np.quantile(action, 0.10, axis=0), atol=1e-5)
    assert np.allclose(stats["max"], action.max(axis=0))
    assert int(stats["count"][0]) == 121


def test_the_layout_is_lerobots_own(pan, tmp_path):
    ours = tmp_path / "ours"
    export(pan, "-o", ours, "--task", "pan right")
    read = LeRobotDataset("local/ours", root=ours)
    # The same episode through LeRobot's own writer.
    theirs = tmp_path / "theirs"
    features = {k: read.meta.features[k] for k in ("action", "observation.state")}
    written = LeRobotDataset.create("local/theirs", 30, root=theirs, robot_type="so101_follower",
                                    features=features, use_videos=False)
    for k in range(read.num_frames):
        frame = read[k]
        written.add_frame({"action": frame["action"].numpy(), "observation.state": frame["observation.state"].numpy(),
                           "task": "pan right"})
    written.save_episode()
    written.finalize()
    assert files_of(ours) == files_of(theirs) == FILES
    for name in FILES:
        if name.endswith(".parquet"):
            # Same columns, same types (the metadata's fingerprint differs: it hashes the run).
            assert pq.read_schema(ours / name).remove_metadata() == pq.read_schema(theirs / name).remove_metadata(), name
    info = [json.loads((d / "meta/info.json").read_text()) for d in (ours, theirs)]
    # keypose's own word on the units, which LeRobot ignores (it read the dataset above), is
    # the one difference.
    assert info[0].pop("keypose") == {"units": "degrees"}
    assert info[0] == info[1]
    ours_rows = pq.read_table(ours / "data/chunk-000/file-000.parquet").to_pylist()
    theirs_rows = pq.read_table(theirs / "data/chunk-000/file-000.parquet").to_pylist()
    assert ours_rows == theirs_rows
    stats = [json.loads((d / "meta/stats.json").read_text()) for d in (ours, theirs)]
    assert stats[0].keys() == stats[1].keys()
    for feature in stats[0]:
        assert stats[0][feature].keys() == stats[1][feature].keys()
        for name in ("min", "max", "mean", "count"):
            assert np.allclose(stats[0][feature][name], stats[1][feature][name], atol=1e-5), (feature, name)
        # LeRobot's std comes from float32 sums of squares: a constant 30 % gripper gets 0.036
        # instead of 0 (ours is numpy's, checked above).
        assert np.allclose(stats[0][feature]["std"], stats[1][feature]["std"], atol=0.05), feature


def test_range_units_come_back_as_they_went_out(tmp_path):
    """Exported in LeRobot's −100…100 of the calibrated range, imported back with the same
    calibration and no --units: the values alone cannot tell range from degrees, the dataset's
    meta/info.json says what keypose wrote, and the keys come back within the import's
    tolerance (where read as degrees they were off by up to 40°)."""
    wave = repo("sequences/so101_wave.json")
    export(wave, "-o", tmp_path / "r", "--units", "range", "--calibration", repo(CALIBRATION))
    env = {**os.environ, "KEYPOSE_PYTHON": sys.executable}
    back = tmp_path / "back.json"
    done = subprocess.run(
        [str(keypose_command()), "import", "lerobot", str(tmp_path / "r"), "--episode", "0",
         "--calibration", str(repo(CALIBRATION)), "-o", str(back)],
        capture_output=True, text=True, timeout=600, env=env,
    )
    assert done.returncode == 0, done.stderr
    assert "range units, as" in done.stderr and "$.keypose.units" in done.stderr, done.stderr
    # Sampled at 30 fps, both: the import's keys against the exported sequence.
    rows = []
    for path in (wave, back):
        out = subprocess.run(
            [str(keypose_command()), "sample", str(path), "--rate", "30",
             "--calibration", str(repo(CALIBRATION))],
            capture_output=True, text=True, timeout=600, check=True,
        )
        rows.append([list(map(float, line.split(",")[1:])) for line in out.stdout.splitlines()[1:]])
    n = min(len(rows[0]), len(rows[1]))
    worst = max(abs(a - b) for r0, r1 in zip(rows[0][:n], rows[1][:n]) for a, b in zip(r0, r1))
    assert worst < 1.0, worst


def test_range_units_and_refusals(pan, tmp_path):
    # −100…100 of the calibrated range needs the calibration, and says so.
    done = export(pan, "-o", tmp_path / "r", "--units", "range", check_code=2)
    assert "calibration" in done.stderr and not (tmp_path / "r").exists()
    export(pan, "-o", tmp_path / "r", "--units", "range", "--calibration", repo(CALIBRATION))
    ds = LeRobotDataset("local/r", root=tmp_path / "r")
    c = json.loads(repo(CALIBRATION).read_text())["shoulder_pan"]
    mid = (c["range_min"] + c["range_max"]) / 2
    at_30 = (mid + 30 * 4096 / 360 - c["range_min"]) / (c["range_max"] - c["range_min"]) * 200 - 100
    assert float(ds[90]["action"][0]) == pytest.approx(at_30, abs=1e-4)
    # An existing folder is never written into.
    done = export(pan, "-o", tmp_path / "r", check_code=2)
    assert "exists already" in done.stderr
    # A sequence that breaks the limits is refused, nothing written.
    fast = write_sequence(tmp_path / "fast.json", "so101", [
        {"time": 0, "joints": {"shoulder_pan": 0}}, {"time": 0.1, "joints": {"shoulder_pan": 90}}],
        interpolation="linear")
    export(fast, "-o", tmp_path / "f", check_code=1)
    assert not (tmp_path / "f").exists()
