"""TOPP-RA (the `toppra` package) on paths keypose samples: the time-optimal oracle for
`keypose retime --fastest` (benches/fastest.rs, tests/commands/fastest.rs).

Reads JSON on stdin: {"stretches": [{"ss": [...], "q": [[...], ...], "qd": [...], "qdd": [...],
"vlim": [...], "alim": [...], "sd": [start, end]}, ...]}, one stretch per path the arm runs
(from rest, sd 0, or at the pace of what is beside it, sd 1, at each end):
path positions ss (keypose's path time), and at each the joints' positions and first and second
derivatives along the path, with each joint's velocity and acceleration limit. Writes JSON on
stdout: {"durations": [...]} (seconds, one per stretch) and the toppra version.

The path is given to toppra by its exact derivatives at the grid points (a geometric path that
answers at those points), so toppra and keypose optimise the same curve under the same limits;
toppra's gridpoints are the samples themselves.
"""

import json
import sys
from importlib import metadata

import numpy as np
import toppra
import toppra.algorithm as algo
import toppra.constraint as constraint
from toppra.interpolator import AbstractGeometricPath


class SampledPath(AbstractGeometricPath):
    """A path known by its values and derivatives at grid points (linear in between, which
    toppra never asks for: it evaluates the path at the gridpoints it is given)."""

    def __init__(self, ss, q, qd, qdd):
        self.ss = np.asarray(ss, dtype=float)
        self.table = [np.asarray(t, dtype=float) for t in (q, qd, qdd)]

    def __call__(self, path_positions, order=0):
        s = np.atleast_1d(np.asarray(path_positions, dtype=float))
        table = self.table[order]
        out = np.stack([np.interp(s, self.ss, table[:, j]) for j in range(table.shape[1])], axis=1)
        return out if np.ndim(path_positions) else out[0]

    @property
    def dof(self):
        return self.table[0].shape[1]

    @property
    def path_interval(self):
        return np.array([self.ss[0], self.ss[-1]])


def duration(stretch):
    ss = np.asarray(stretch["ss"], dtype=float)
    path = SampledPath(ss, stretch["q"], stretch["qd"], stretch["qdd"])
    vlim = np.array([[-v, v] for v in stretch["vlim"]])
    alim = np.array([[-a, a] for a in stretch["alim"]])
    constraints = [
        constraint.JointVelocityConstraint(vlim),
        constraint.JointAccelerationConstraint(alim),
    ]
    instance = algo.TOPPRA(constraints, path, gridpoints=ss, parametrizer="ParametrizeConstAccel")
    sd_start, sd_end = stretch.get("sd", [0.0, 0.0])
    result = instance.compute_parameterization(sd_start, sd_end)
    sd = np.asarray(result[1], dtype=float)
    if sd is None or not np.all(np.isfinite(sd)):
        raise SystemExit("toppra found no parameterization")
    mean = 0.5 * (sd[1:] + sd[:-1])
    return float(np.sum(np.diff(ss) / mean))


def main():
    request = json.load(sys.stdin)
    durations = [duration(s) for s in request["stretches"]]
    json.dump({"durations": durations, "toppra": metadata.version("toppra")}, sys.stdout)


if __name__ == "__main__":
    main()
