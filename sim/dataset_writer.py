#!/usr/bin/env python3
"""keypose's writer of a LeRobotDataset v3.0 episode's parquet files, through pyarrow.

keypose (src/interop/lerobot/export.rs) decides every value, name and statistic and writes
meta/info.json and meta/stats.json itself; this process only lays the columns it is given into
parquet files with the types LeRobot's own writer gives them, in JSON lines (harness_io).
Ready line:

    {"ready": true, "pyarrow": "26.0.1", "python": ..., "executable": ..., "packages": {...}}

Request:

    {"op": "write", "root": DIR, "width": N, "action": [[...], ...],
     "observation.state": [[...], ...], "timestamp": [...], "episode": {COLUMN: VALUE, ...},
     "task": "wave"}

writes, under DIR,
- data/chunk-000/file-000.parquet: action and observation.state as fixed_size_list<float>[N],
  timestamp float, frame_index, episode_index, index, task_index int64, and the Hugging Face
  `datasets` features in the schema's metadata, as LeRobot's `save_episode` does;
- meta/episodes/chunk-000/file-000.parquet: the one row `episode` (lists of floats as
  list<double>, of integers as list<int64>, the tasks as list<string>);
- meta/tasks.parquet: the task as the index of a one-row table of task_index 0, with the pandas
  metadata that makes `pandas.read_parquet` give it back as the index (LeRobot's `load_tasks`);

and replies {"ok": true}. Errors: kind "request", "internal".
"""

import json
import os
import sys

from harness_io import (
    RequestError,
    distribution_version,
    emit,
    handle_line,
    ignore_sigint,
    integer_in,
    interpreter,
    member,
    not_ready,
    serve,
    take_stdout,
)

INTEGER_COLUMNS = ("frame_index", "episode_index", "index", "task_index")


class Writer:
    def __init__(self, pa, pq):
        self.pa = pa
        self.pq = pq

    def handle_line(self, line):
        return handle_line(line, self.dispatch)

    def dispatch(self, req):
        if req.get("op") != "write":
            raise RequestError("request", f"unknown op {req.get('op')!r}; expected \"write\"")
        root = member(req, "root")
        if not isinstance(root, str) or not os.path.isdir(root):
            raise RequestError("request", f"'root' must be an existing folder, not {json.dumps(root)}")
        width = integer_in("width", member(req, "width"), 1, 4096)
        self.data(root, width, req)
        self.episodes(root, member(req, "episode"))
        self.tasks(root, member(req, "task"))
        return {}

    def write(self, table, root, relative):
        path = os.path.join(root, relative)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        self.pq.write_table(table, path)

    def data(self, root, width, req):
        pa = self.pa
        action = member(req, "action")
        frames = len(action)
        vector = pa.list_(pa.float32(), width)
        columns = {
            "action": pa.array(action, type=vector),
            "observation.state": pa.array(member(req, "observation.state"), type=vector),
            "timestamp": pa.array(member(req, "timestamp"), type=pa.float32()),
            "frame_index": pa.array(range(frames), type=pa.int64()),
            "episode_index": pa.array([0] * frames, type=pa.int64()),
            "index": pa.array(range(frames), type=pa.int64()),
            "task_index": pa.array([0] * frames, type=pa.int64()),
        }
        # The `datasets` library's description of the columns, which LeRobot's writer leaves
        # in the schema (Hugging Face's loaders read the features from it).
        value = lambda dtype: {"dtype": dtype, "_type": "Value"}  # noqa: E731
        listed = {"feature": value("float32"), "length": width, "_type": "List"}
        features = {"action": listed, "observation.state": listed, "timestamp": value("float32")}
        features.update({name: value("int64") for name in INTEGER_COLUMNS})
        table = pa.table(columns).replace_schema_metadata(
            {"huggingface": json.dumps({"info": {"features": features}})}
        )
        self.write(table, root, "data/chunk-000/file-000.parquet")

    def episodes(self, root, episode):
        pa = self.pa
        if not isinstance(episode, dict):
            raise RequestError("request", "'episode' must be an object of columns")
        columns = {}
        for name, value in episode.items():
            if name == "tasks":
                columns[name] = pa.array([value], type=pa.list_(pa.string()))
            elif isinstance(value, list):
                integers = all(isinstance(v, int) and not isinstance(v, bool) for v in value)
                columns[name] = pa.array([value], type=pa.list_(pa.int64() if integers else pa.float64()))
            else:
                columns[name] = pa.array([value], type=pa.int64())
        self.write(pa.table(columns), root, "meta/episodes/chunk-000/file-000.parquet")

    def tasks(self, root, task):
        pa = self.pa
        if not isinstance(task, str):
            raise RequestError("request", f"'task' must be a string, not {json.dumps(task)}")
        index = "__index_level_0__"
        pandas = {
            "index_columns": [index],
            "column_indexes": [],
            "columns": [
                {"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
                 "numpy_type": "int64", "metadata": None},
                {"name": None, "field_name": index, "pandas_type": "unicode",
                 "numpy_type": "object", "metadata": None},
            ],
            "creator": {"library": "pyarrow", "version": pa.__version__},
        }
        table = pa.table({
            "task_index": pa.array([0], type=pa.int64()),
            index: pa.array([task], type=pa.large_string()),
        }).replace_schema_metadata({"pandas": json.dumps(pandas)})
        self.write(table, root, "meta/tasks.parquet")


def main():
    take_stdout()
    ignore_sigint()
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError as e:
        return not_ready(f"missing Python package: {e}", missing=getattr(e, "name", None))
    packages = {"pyarrow": distribution_version("pyarrow")}
    emit({"ready": True, "pyarrow": packages["pyarrow"], **interpreter(), "packages": packages})
    serve(Writer(pyarrow, pyarrow.parquet))
    return 0


if __name__ == "__main__":
    sys.exit(main())
