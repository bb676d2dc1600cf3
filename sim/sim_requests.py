"""The checks of the MuJoCo harness's request members: finite numbers, bounded integers,
lists of names, and rows of joint values, each failing with a "request" error that says what
is wrong.

It knows nothing about MuJoCo: numpy is passed in where rows are checked in bulk.
"""

import json
import math

from harness_io import RequestError, integer_in, member


class SimError(RequestError):
    pass


def request_error(message):
    return SimError("request", message)


def reject_constant(name):
    """For json.loads: NaN and Infinity are not JSON, and a run must not take them for numbers."""
    raise ValueError(f"{name} is not a number JSON allows")


def is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def number(req, name, default=None, positive=False):
    value = member(req, name, default, required=default is None)
    if not is_number(value):
        raise request_error(f"{name!r} must be a finite number, not {json.dumps(value)}")
    if positive and value <= 0:
        raise request_error(f"{name!r} must be positive, not {value}")
    return float(value)


def integer(req, name, default, lo, hi):
    return integer_in(repr(name), member(req, name, default, required=default is None), lo, hi)


def string_list(req, name, required=True, nonempty=True):
    value = member(req, name, None, required)
    if value is None:
        return None
    if not isinstance(value, list) or not all(isinstance(item, str) for item in value):
        raise request_error(f"{name!r} must be a list of strings, not {json.dumps(value)[:200]}")
    if nonempty and not value:
        raise request_error(f"{name!r} is empty")
    seen = set()
    for item in value:
        if item in seen:
            raise request_error(f"{item!r} appears twice in {name!r}")
        seen.add(item)
    return value


def vector(value, length, what):
    if not isinstance(value, list) or len(value) != length:
        got = f"{len(value)} values" if isinstance(value, list) else json.dumps(value)[:200]
        raise request_error(f"{what} must be a list of {length} numbers (one per joint), not {got}")
    for item in value:
        if not is_number(item):
            raise request_error(f"{what} holds {json.dumps(item)}, which is not a finite number")
    return value


def matrix(np, req, name, length, nonempty):
    """The rows as a (rows, length) float array, every value a finite number."""
    rows = member(req, name)
    if not isinstance(rows, list):
        raise request_error(f"{name!r} must be a list of rows, not {json.dumps(rows)[:200]}")
    if nonempty and not rows:
        raise request_error(f"{name!r} is empty")
    # A minute of commands is tens of thousands of values: numpy checks them in one go, and
    # the row-by-row check runs only to say what is wrong.
    try:
        values = np.array(rows, dtype=float).reshape(len(rows), length)
        good = bool(np.isfinite(values).all()) and not any(type(x) is bool for row in rows for x in row)
    except (ValueError, TypeError):
        good = False
    if not good:
        for index, row in enumerate(rows):
            vector(row, length, f"{name}[{index}]")
        raise request_error(f"{name!r} must be rows of {length} finite numbers")
    return values
