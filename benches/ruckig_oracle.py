"""Ruckig (the `ruckig` package): time-optimal jerk-limited motion, the oracle for keypose's
S-curve moves (src/plan/scurve.rs, `retime --fastest` on a robot with jerk limits;
benches/scurve.rs, tests/motion/jerk.rs).

Reads JSON on stdin: {"moves": [{"from": [...], "to": [...], "vlim": [...], "alim": [...],
"jlim": [...], "sync": "time" | "phase"}, ...]}: point-to-point moves from rest to rest, one
value per joint, with each joint's velocity, acceleration and jerk limit. "time" is Ruckig's
default: every joint its own profile, all ending together. "phase" keeps the joints on the
straight line between the two poses, as keypose's linear segment does. Writes JSON on stdout:
{"durations": [...]} (seconds, one per move) and the ruckig version.
"""

import json
import sys
from importlib import metadata

from ruckig import InputParameter, Result, Ruckig, Synchronization, Trajectory


def duration(move):
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
    trajectory = Trajectory(n)
    result = Ruckig(n).calculate(inp, trajectory)
    if result not in (Result.Working, Result.Finished):
        raise SystemExit(f"ruckig found no trajectory: {result}")
    return trajectory.duration


def main():
    request = json.load(sys.stdin)
    durations = [duration(m) for m in request["moves"]]
    json.dump({"durations": durations, "ruckig": metadata.version("ruckig")}, sys.stdout)


if __name__ == "__main__":
    main()
