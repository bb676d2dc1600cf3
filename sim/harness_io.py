"""What keypose's Python harnesses share: the JSON-lines protocol on stdout, one request line
to one reply (parsing, the "seq" echo, errors as replies), the checks of request members, the
ready line's facts, and leaving Ctrl-C to keypose.

It knows nothing about servos or physics: each harness passes its own dispatch.

keypose writes this file beside the harness scripts (src/python/scripts.rs), so
`import harness_io` finds it in the script's own directory.
"""

import json
import os
import platform
import signal
import sys

_protocol_out = None


class RequestError(Exception):
    """A request that fails: the reply says which kind of failure, why, and any further fields."""

    def __init__(self, kind, message, **fields):
        super().__init__(message)
        self.kind = kind
        self.message = message
        self.fields = fields

    def reply(self):
        return {"ok": False, "kind": self.kind, "error": self.message, **self.fields}


def member(req, name, default=None, required=True):
    """`req[name]`; without it `default`, or a request error when the member is required."""
    if name in req:
        return req[name]
    if required:
        raise RequestError("request", f"request {req.get('op')!r} lacks {name!r}")
    return default


def is_integer(value):
    # bool is an int in Python; a true/false where a number belongs is a malformed request.
    return isinstance(value, int) and not isinstance(value, bool)


def integer_in(what, value, lo, hi):
    """`value` if it is an integer in lo..hi; `what` names it in the error."""
    if not is_integer(value) or value < lo or value > hi:
        raise RequestError("request", f"{what} must be an integer in {lo}..{hi}, not {json.dumps(value)}")
    return value


def describe_exception(e):
    return f"{type(e).__name__}: {e}"


def handle_line(line, dispatch, parse=json.loads, shown=json.dumps, describe=describe_exception):
    """The reply to one request line; the harness goes on after every kind of failure.

    The line must hold a JSON object (`parse` reads it; `shown` writes a request that is not an
    object into the error); `dispatch(req)` returns the reply's members or raises a
    RequestError, and any other exception is an "internal" error that `describe` puts into
    words. A request's "seq" is echoed, so that keypose can match a late reply.
    """
    try:
        req = parse(line)
    except ValueError as e:
        return RequestError("request", f"malformed request (not JSON): {e}").reply()
    seq = req.get("seq") if isinstance(req, dict) else None
    try:
        if not isinstance(req, dict):
            raise RequestError("request", f"a request must be a JSON object, not {shown(req)}")
        reply = {"ok": True}
        reply.update(dispatch(req))
    except RequestError as e:
        reply = e.reply()
    except Exception as e:  # an unforeseen input or a bug must not end the harness
        reply = RequestError("internal", describe(e)).reply()
    if seq is not None:
        reply["seq"] = seq
    return reply


def take_stdout():
    """Keeps the real stdout for the protocol and points everything else at stderr.

    Vendor SDKs print, and MuJoCo, Mesa and ffmpeg are C code that may write to file
    descriptor 1 directly, below Python's sys.stdout: any such line would corrupt the protocol.
    """
    global _protocol_out
    fd = os.dup(1)
    os.dup2(2, 1)
    _protocol_out = os.fdopen(fd, "w", encoding="utf-8", newline="\n")
    sys.stdout = sys.stderr


def emit(obj):
    """Writes one reply line; a reply whose "payload" member holds bytes says their length
    there instead, and the bytes follow the line as they are (sim/PROTOCOL.md, "Binary
    payloads")."""
    payload = obj.get("payload") if isinstance(obj, dict) else None
    if isinstance(payload, (bytes, bytearray)):
        obj = {**obj, "payload": len(payload)}
    else:
        payload = None
    try:
        line = json.dumps(obj, allow_nan=False)
    except ValueError as e:
        # JSON has no NaN: a reply that carries one is a bug here, not a reason to send bad JSON.
        fallback = {"ok": False, "kind": "internal", "error": f"reply not encodable as JSON: {e}"}
        if isinstance(obj, dict) and "seq" in obj:
            fallback["seq"] = obj["seq"]
        line = json.dumps(fallback)
        payload = None
    _protocol_out.write(line + "\n")
    _protocol_out.flush()
    if payload is not None:
        _protocol_out.buffer.write(payload)
        _protocol_out.buffer.flush()


def ignore_sigint():
    """Ctrl-C in a terminal reaches the whole process group; keypose decides how to stop (it
    may still need the harness, to hold or release the arm) and closes our stdin when done."""
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except (ValueError, OSError):
        pass


def distribution_version(name):
    """The installed version of a distribution, by its name in requirements.txt."""
    from importlib import metadata

    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        # The module imports but was not installed by pip (copied onto sys.path, say).
        return None


def interpreter():
    """The facts about this Python that every ready line carries."""
    return {"python": platform.python_version(), "executable": sys.executable}


def not_ready(error, **fields):
    """Says why the harness cannot serve; returns the exit status."""
    emit({"ready": False, "error": error, **fields, **interpreter()})
    return 2


def serve(handler):
    """Answers request lines until stdin closes."""
    for line in sys.stdin:
        if line.strip():
            emit(handler.handle_line(line))
