"""Writes a LeRobotDataset v3.0 folder from a JSON description on stdin, with pyarrow, the way
LeRobot lays one out (meta/info.json, meta/episodes/chunk-000/file-000.parquet,
data/chunk-000/file-NNN.parquet; docs/interop.md §1). For tests/commands/lerobot_import.rs.

{"root": DIR, "version": "v3.0", "robot_type": "so101_follower", "fps": 30,
 "names": ["shoulder_pan.pos", ...], "column": "list" | "fixed",
 "episodes": [{"file_index": 0, "values": [[...], ...]}, ...]}

What a test of bad data changes (all optional):
- "names" may be an object of lists, LeRobot's older form ({"motors": [...]});
- "info": members put into meta/info.json over the ones written (a "data_path", an "fps");
- an episode's "values" (rows of numbers, or the strings "nan", "inf", "-inf") may instead be
  {"row": [...], "count": N}, N copies of one row; its "timestamps" replace frame / fps; its
  "meta" members replace those of its meta/episodes row.
"""

import json
import os
import sys

import pyarrow as pa
import pyarrow.parquet as pq


def column(rows, width, kind):
    if kind == "fixed":
        return pa.array(rows, type=pa.list_(pa.float32(), width))
    return pa.array(rows, type=pa.list_(pa.float32()))


def as_float(v):
    return float(v) if isinstance(v, str) else v


def rows_of(values):
    if isinstance(values, dict):
        return [values["row"]] * values["count"]
    return [[as_float(v) for v in row] for row in values]


def main():
    spec = json.load(sys.stdin)
    root, fps, names = spec["root"], spec["fps"], spec["names"]
    width = sum(len(group) for group in names.values()) if isinstance(names, dict) else len(names)
    files = {}
    episodes = {k: [] for k in ("episode_index", "length", "data/chunk_index", "data/file_index",
                                "dataset_from_index", "dataset_to_index")}
    index = 0
    for number, episode in enumerate(spec["episodes"]):
        rows = rows_of(episode["values"])
        timestamps = [as_float(t) for t in episode.get("timestamps", [k / fps for k in range(len(rows))])]
        data = files.setdefault(episode["file_index"], {"index": [], "episode_index": [], "frame_index": [],
                                                        "timestamp": [], "values": []})
        for frame, row in enumerate(rows):
            data["index"].append(index + frame)
            data["episode_index"].append(number)
            data["frame_index"].append(frame)
            data["timestamp"].append(timestamps[frame])
            data["values"].append(row)
        meta = {"episode_index": number, "length": len(rows), "data/chunk_index": 0,
                "data/file_index": episode["file_index"], "dataset_from_index": index,
                "dataset_to_index": index + len(rows)}
        meta.update(episode.get("meta", {}))
        for key, value in meta.items():
            episodes[key].append(value)
        index += len(rows)
    for file_index, data in files.items():
        table = pa.table({
            "action": column(data["values"], width, spec["column"]),
            "observation.state": column(data["values"], width, spec["column"]),
            "timestamp": pa.array(data["timestamp"], type=pa.float32()),
            "frame_index": pa.array(data["frame_index"], type=pa.int64()),
            "episode_index": pa.array(data["episode_index"], type=pa.int64()),
            "index": pa.array(data["index"], type=pa.int64()),
            "task_index": pa.array([0] * len(data["index"]), type=pa.int64()),
        })
        path = os.path.join(root, "data", "chunk-000", f"file-{file_index:03d}.parquet")
        os.makedirs(os.path.dirname(path), exist_ok=True)
        pq.write_table(table, path)
    meta = os.path.join(root, "meta", "episodes", "chunk-000")
    os.makedirs(meta, exist_ok=True)
    pq.write_table(pa.table(episodes), os.path.join(meta, "file-000.parquet"))
    feature = {"dtype": "float32", "shape": [width], "names": names}
    info = {
        "codebase_version": spec["version"],
        "robot_type": spec["robot_type"],
        "total_episodes": len(spec["episodes"]),
        "total_frames": index,
        "fps": fps,
        "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
        "features": {"action": feature, "observation.state": feature,
                     "timestamp": {"dtype": "float32", "shape": [1], "names": None}},
    }
    info.update(spec.get("info", {}))
    with open(os.path.join(root, "meta", "info.json"), "w") as f:
        json.dump(info, f, indent=2)


if __name__ == "__main__":
    main()
