#!/usr/bin/env python3
"""keypose's reader of LeRobotDataset v3.0 parquet files, through pyarrow.

keypose (src/interop/lerobot/) reads meta/info.json itself and asks this process only for what
is inside parquet files, in JSON lines (harness_io). Ready line:

    {"ready": true, "pyarrow": "26.0.1", "python": ..., "executable": ...,
     "packages": {"pyarrow": "26.0.1"}}

Request:

    {"op": "episode", "root": DIR, "episode": N, "field": "action",
     "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"}

finds episode N in meta/episodes/chunk-*/file-*.parquet (its dataset_from_index,
dataset_to_index and data/chunk_index, data/file_index), reads that data file's rows whose
global "index" is in [from, to), ordered by "index", and replies

    {"ok": true, "file": "data/chunk-000/file-000.parquet", "from": A, "to": B,
     "column_type": "list<element: float>", "timestamps": [...] | null, "values": [[...], ...],
     "episodes": [every episode index found]}

Errors: kind "dataset" (the files do not hold what the layout says), "request", "internal".
"""

import glob
import json
import math
import os
import sys

from harness_io import (
    RequestError,
    distribution_version,
    emit,
    handle_line,
    ignore_sigint,
    integer_in,
    is_integer,
    interpreter,
    member,
    not_ready,
    serve,
    take_stdout,
)

EPISODE_COLUMNS = ("episode_index", "data/chunk_index", "data/file_index", "dataset_from_index", "dataset_to_index")


def dataset_error(message, **fields):
    return RequestError("dataset", message, **fields)


def text_member(req, name):
    value = member(req, name)
    if not isinstance(value, str):
        raise RequestError("request", f"{name!r} must be a string, not {json.dumps(value)}")
    return value


class Reader:
    def __init__(self, pa, pq):
        self.pa = pa
        self.pq = pq

    def handle_line(self, line):
        return handle_line(line, self.dispatch)

    def dispatch(self, req):
        if req.get("op") == "episode":
            return self.episode(req)
        raise RequestError("request", f"unknown op {req.get('op')!r}; expected \"episode\"")

    def episode(self, req):
        root = text_member(req, "root")
        field = text_member(req, "field")
        template = text_member(req, "data_path")
        number = integer_in("episode", member(req, "episode"), 0, 2**62)
        row, known = self.find_episode(root, number)
        try:
            relative = template.format(chunk_index=row["data/chunk_index"], file_index=row["data/file_index"])
        except (KeyError, IndexError, ValueError, TypeError) as e:
            raise dataset_error(f"meta/info.json: data_path {template!r} cannot be filled in: {e}")
        first, last = row["dataset_from_index"], row["dataset_to_index"]
        table = self.read(os.path.join(root, relative), relative)
        column_type, timestamps, values = self.rows(table, relative, field, first, last)
        return {
            "file": relative,
            "from": first,
            "to": last,
            "column_type": column_type,
            "timestamps": timestamps,
            "values": values,
            "episodes": known,
        }

    def find_episode(self, root, number):
        """The meta/episodes row of episode `number`, and every episode index seen."""
        files = sorted(glob.glob(os.path.join(root, "meta", "episodes", "chunk-*", "file-*.parquet")))
        if not files:
            raise dataset_error("no meta/episodes/chunk-*/file-*.parquet: not a LeRobotDataset v3.0 layout")
        known = []
        found = None
        for path in files:
            relative = os.path.relpath(path, root)
            table = self.read(path, relative)
            missing = [c for c in EPISODE_COLUMNS if c not in table.column_names]
            if missing:
                raise dataset_error(f"{relative}: lacks column(s) {', '.join(missing)}; expected {', '.join(EPISODE_COLUMNS)}")
            columns = {c: table.column(c).to_pylist() for c in EPISODE_COLUMNS}
            for i, index in enumerate(columns["episode_index"]):
                if is_integer(index):
                    known.append(index)
                if index == number and found is None:
                    found = {c: columns[c][i] for c in EPISODE_COLUMNS}
        if found is None:
            raise dataset_error(f"episode {number} is not in meta/episodes", episodes=sorted(known))
        bad = [c for c in EPISODE_COLUMNS if not is_integer(found[c]) or found[c] < 0]
        if bad or found["dataset_to_index"] < found["dataset_from_index"]:
            raise dataset_error(
                f"meta/episodes: episode {number} has {', '.join(f'{c} = {found[c]!r}' for c in EPISODE_COLUMNS)}; "
                "expected whole numbers from 0, dataset_to_index at least dataset_from_index"
            )
        return found, sorted(known)

    def read(self, path, relative):
        try:
            return self.pq.read_table(path)
        except FileNotFoundError:
            raise dataset_error(f"{relative}: no such file")
        except (OSError, self.pa.ArrowException) as e:
            raise dataset_error(f"{relative}: not a readable parquet file: {e}")

    def rows(self, table, relative, field, first, last):
        names = table.column_names
        for needed in (field, "index"):
            if needed not in names:
                raise dataset_error(f"{relative}: no column {needed!r}; columns: {', '.join(names)}")
        kind = table.schema.field(field).type
        if not (self.pa.types.is_list(kind) or self.pa.types.is_large_list(kind) or self.pa.types.is_fixed_size_list(kind)):
            raise dataset_error(f"{relative}: column {field!r} is {kind}, expected a list of numbers per row")
        if not (self.pa.types.is_floating(kind.value_type) or self.pa.types.is_integer(kind.value_type)):
            raise dataset_error(f"{relative}: column {field!r} holds {kind.value_type}, expected numbers")
        index = table.column("index").to_pylist()
        chosen = sorted((g, k) for k, g in enumerate(index) if first <= g < last)
        if len(chosen) != last - first:
            raise dataset_error(
                f"{relative}: {len(chosen)} rows with index in [{first}, {last}) for the episode, "
                f"meta/episodes says {last - first}"
            )
        order = [k for _, k in chosen]
        values = table.column(field).take(order).to_pylist()
        for k, row in enumerate(values):
            if row is None or any(v is None or not math.isfinite(v) for v in row):
                raise dataset_error(f"{relative}: column {field!r}, row of index {first + k}: not all values are finite numbers")
        timestamps = None
        if "timestamp" in names:
            timestamps = table.column("timestamp").take(order).to_pylist()
        return str(kind), timestamps, values


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
    serve(Reader(pyarrow, pyarrow.parquet))
    return 0


if __name__ == "__main__":
    sys.exit(main())
