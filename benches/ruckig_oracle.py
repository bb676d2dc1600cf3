"""Ruckig (the `ruckig` package): time-optimal jerk-limited motion, the oracle for keypose's
S-curve moves (src/plan/scurve.rs, `retime --fastest` on a robot with jerk limits;
benches/scurve.rs, tests/motion/jerk.rs).

Reads JSON on stdin: {"moves": [{"from": [...], "to": [...], "vlim": [...], "alim": [...],
"jlim": [...], "sync": "time" | "phase"}, ...]}: point-to-point moves from rest to rest, one
value per joint, with each joint's velocity, acceleration and jerk limit. "time" is Ruckig's
default: every joint its own profile, all ending together. "phase" keeps the joints on the
straight line between the two poses, as keypose's linear segment does. Writes JSON on stdout:
{"durations": [...]} (seconds, one per move) and the ruckig version. With "repeat": N it also
times Ruckig's solve, each move's `calculate` N times: "seconds_per_solve", the mean (the
C++ solve behind the Python call; building the input is left out).
"""

import json
import sys
import time
from importlib import metadata

from ruckig import InputParameter, Result, Ruckig, Synchronization, Trajectory


def request(move):
    n = len(move["from"])
    inp = InputParameter(n)
    inp.current_position = move["from"]
    inp.current_velocity = [0.0] * n
    inp.current_acceleration = [0.0] * n
    inp.target_position = move["to"]
    inp.target_velocity = [0.0] * n
    inp.target_acceleration = [0.0] * n
    inp.max_velocity = move["vlim"]
    inp.max_acceleration = move["alim"]
    inp.max_jerk = move["jlim"]
    inp.synchronization = {"time": Synchronization.Time, "phase": Synchronization.Phase}[
        move["sync"]
    ]
    return inp


def duration(move):
    inp = request(move)
    n = len(move["from"])
    trajectory = Trajectory(n)
    result = Ruckig(n).calculate(inp, trajectory)
    if result not in (Result.Working, Result.Finished):
        raise SystemExit(f"ruckig found no trajectory: {result}")
    return trajectory.duration


def seconds_per_solve(moves, repeat):
    total, count = 0.0, 0
    for move in moves:
        inp = request(move)
        n = len(move["from"])
        solver, trajectory = Ruckig(n), Trajectory(n)
        for _ in range(repeat):
            start = time.perf_counter()
            solver.calculate(inp, trajectory)
            total += time.perf_counter() - start
            count += 1
    return total / count


def main():
    asked = json.load(sys.stdin)
    reply = {
        "durations": [duration(m) for m in asked["moves"]],
        "ruckig": metadata.version("ruckig"),
    }
    if asked.get("repeat"):
        reply["seconds_per_solve"] = seconds_per_solve(asked["moves"], int(asked["repeat"]))
    json.dump(reply, sys.stdout)


if __name__ == "__main__":
    main()
