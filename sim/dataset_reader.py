#!/usr/bin/env python3
"""keypose's reader of LeRobotDataset v3.0 parquet files, through pyarrow.

keypose (src/interop/lerobot/) reads meta/info.json itself, decides which files may be read
(inside the dataset folder) and judges every value; this process only gets columns out of
parquet files, in JSON lines (harness_io). Ready line:

    {"ready": true, "pyarrow": "26.0.1", "python": ..., "executable": ...,
     "packages": {"pyarrow": "26.0.1"}}

Requests:

    {"op": "episode", "root": DIR, "files": ["meta/episodes/chunk-000/file-000.parquet", ...],
     "episode": N}

reads those meta/episodes files and replies with every row whose episode_index is N, as read,
and every episode index seen:

    {"ok": true, "rows": [{"file": F, "row": R, "episode_index": N, "data/chunk_index": ...,
     "data/file_index": ..., "dataset_from_index": ..., "dataset_to_index": ..., "length": ...}],
     "episodes": [...]}

    {"op": "rows", "root": DIR, "file": "data/chunk-000/file-000.parquet", "field": "action",
     "episode": N, "from": A, "to": B, "limit": L}

reads the data file in batches, keeps the rows whose global "index" is in [A, B) in file order
(at most L of them), counts the rows whose episode_index is N in the whole file, and replies

    {"ok": true, "column_type": "list<element: float>", "index": [...], "episode_index": [...],
     "timestamp": [...] | null, "lengths": [values per row, null for a missing row],
     "values": [every row's values, one after the other], "episode_rows": COUNT}

Numbers go out as read: a float that is not finite as the string "nan", "inf" or "-inf" (JSON
has no such numbers), a missing value as null. keypose judges them.

Errors: kind "dataset" (a file cannot be read, or lacks a column or has one of the wrong type),
"request", "internal".
"""

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
    interpreter,
    member,
    not_ready,
    serve,
    take_stdout,
)

EPISODE_COLUMNS = ("episode_index", "data/chunk_index", "data/file_index", "dataset_from_index", "dataset_to_index")
# Rows decoded at a time: memory stays bounded however large the data file is.
BATCH_ROWS = 65536


def dataset_error(message, **fields):
    return RequestError("dataset", message, **fields)


def text_member(req, name):
    value = member(req, name)
    if not isinstance(value, str):
        raise RequestError("request", f"{name!r} must be a string, not {json.dumps(value)}")
    return value


def plain(value):
    """A value read from parquet as JSON can carry it: non-finite floats as text."""
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return str(value)


def plain_list(values):
    if any(isinstance(v, float) and not math.isfinite(v) for v in values):
        return [plain(v) for v in values]
    return values


class Reader:
    def __init__(self, pa, pq, pc):
        self.pa = pa
        self.pq = pq
        self.pc = pc

    def handle_line(self, line):
        return handle_line(line, self.dispatch)

    def dispatch(self, req):
        op = req.get("op")
        if op == "episode":
            return self.episode(req)
        if op == "rows":
            return self.rows(req)
        raise RequestError("request", f"unknown op {op!r}; expected \"episode\" or \"rows\"")

    def episode(self, req):
        root = text_member(req, "root")
        number = integer_in("episode", member(req, "episode"), 0, 2**62)
        files = member(req, "files")
        if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
            raise RequestError("request", "'files' must be a list of paths")
        if not files:
            raise dataset_error("no meta/episodes/chunk-*/file-*.parquet: not a LeRobotDataset v3.0 layout")
        known = set()
        rows = []
        for relative in files:
            parquet = self.open(root, relative)
            names = parquet.schema_arrow.names
            missing = [c for c in EPISODE_COLUMNS if c not in names]
            if missing:
                raise dataset_error(f"{relative}: lacks column(s) {', '.join(missing)}; expected {', '.join(EPISODE_COLUMNS)}")
            wanted = list(EPISODE_COLUMNS) + (["length"] if "length" in names else [])
            table = self.read(parquet, relative, wanted)
            columns = {c: table.column(c).to_pylist() for c in wanted}
            for i, index in enumerate(columns["episode_index"]):
                if isinstance(index, int) and not isinstance(index, bool):
                    known.add(index)
                if index == number:
                    row = {c: plain(columns[c][i]) for c in wanted}
                    rows.append({"file": relative, "row": i, **row})
        return {"rows": rows, "episodes": sorted(known)}

    def open(self, root, relative):
        try:
            return self.pq.ParquetFile(os.path.join(root, relative))
        except FileNotFoundError:
            raise dataset_error(f"{relative}: no such file")
        except (OSError, self.pa.ArrowException) as e:
            raise dataset_error(f"{relative}: not a readable parquet file: {e}")

    def read(self, parquet, relative, columns):
        try:
            return parquet.read(columns=columns)
        except (OSError, self.pa.ArrowException) as e:
            raise dataset_error(f"{relative}: not a readable parquet file: {e}")

    def rows(self, req):
        root = text_member(req, "root")
        relative = text_member(req, "file")
        field = text_member(req, "field")
        number = integer_in("episode", member(req, "episode"), 0, 2**62)
        first = integer_in("from", member(req, "from"), 0, 2**62)
        last = integer_in("to", member(req, "to"), first, 2**62)
        limit = integer_in("limit", member(req, "limit"), 0, 2**62)
        parquet = self.open(root, relative)
        schema = parquet.schema_arrow
        kind = self.check_columns(schema, relative, field)
        columns = ["index", "episode_index", field] + (["timestamp"] if "timestamp" in schema.names else [])
        picked = {c: [] for c in columns}
        kept = 0
        episode_rows = 0
        try:
            for batch in parquet.iter_batches(batch_size=BATCH_ROWS, columns=columns):
                episode = batch.column("episode_index")
                episode_rows += self.pc.sum(self.pc.equal(episode, number)).as_py() or 0
                if kept >= limit:
                    continue
                index = batch.column("index")
                inside = self.pc.and_(self.pc.greater_equal(index, first), self.pc.less(index, last))
                chosen = batch.filter(inside).slice(0, limit - kept)
                kept += chosen.num_rows
                for c in columns:
                    picked[c].extend(chosen.column(c).to_pylist())
        except (OSError, self.pa.ArrowException) as e:
            raise dataset_error(f"{relative}: not a readable parquet file: {e}")
        rows = picked[field]
        values = []
        for row in rows:
            if row is not None:
                values.extend(row)
        return {
            "column_type": str(kind),
            "index": picked["index"],
            "episode_index": picked["episode_index"],
            "timestamp": plain_list(picked["timestamp"]) if "timestamp" in picked else None,
            "lengths": [None if row is None else len(row) for row in rows],
            "values": plain_list(values),
            "episode_rows": episode_rows,
        }

    def check_columns(self, schema, relative, field):
        """The field's Arrow type, once every column read is there with a type keypose reads."""
        types = self.pa.types
        names = schema.names
        for needed in ("index", "episode_index", field):
            if needed not in names:
                raise dataset_error(f"{relative}: no column {needed!r}; columns: {', '.join(names)}")
        for whole in ("index", "episode_index"):
            kind = schema.field(whole).type
            if not types.is_integer(kind):
                raise dataset_error(f"{relative}: column {whole!r} is {kind}, expected whole numbers")
        if "timestamp" in names:
            kind = schema.field("timestamp").type
            if not (types.is_floating(kind) or types.is_integer(kind)):
                raise dataset_error(f"{relative}: column 'timestamp' is {kind}, expected seconds")
        kind = schema.field(field).type
        if not (types.is_list(kind) or types.is_large_list(kind) or types.is_fixed_size_list(kind)):
            raise dataset_error(f"{relative}: column {field!r} is {kind}, expected a list of numbers per row")
        if not (types.is_floating(kind.value_type) or types.is_integer(kind.value_type)):
            raise dataset_error(f"{relative}: column {field!r} holds {kind.value_type}, expected numbers")
        return kind


def main():
    take_stdout()
    ignore_sigint()
    try:
        import pyarrow
        import pyarrow.compute
        import pyarrow.parquet
    except ImportError as e:
        return not_ready(f"missing Python package: {e}", missing=getattr(e, "name", None))
    packages = {"pyarrow": distribution_version("pyarrow")}
    emit({"ready": True, "pyarrow": packages["pyarrow"], **interpreter(), "packages": packages})
    serve(Reader(pyarrow, pyarrow.parquet, pyarrow.compute))
    return 0


if __name__ == "__main__":
    sys.exit(main())
