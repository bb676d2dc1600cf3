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

A stretch may also carry "torque": each servo's torque-speed line, with the arm's own MuJoCo
model to weigh it ({"arms": [{"mjcf", "joints", "columns", "gravity"}], "transmission",
"stall", "no_load", "revolute"}). The torques come from MuJoCo's mj_inverse (damping, friction
and constraints off, as keypose leaves them out), not from keypose: at each gridpoint the servo
torque is a·u + b·x + c (u the path acceleration, x the squared path speed), with c = ID(q, 0, 0),
a = ID(q, 0, q') - c and b = ID(q, q', q'') - c, times the joint's transmission. The line bounds
the torque driving the motion by stall·(1 - |q'|·sqrt(x)/(n·w0)), braking by the stall torque.
toppra's constraints are linear in (u, x), so sqrt(x) is replaced by its tangent at x0, an upper
bound, exact at x0: the problem is solved again with x0 the previous solution until the time
settles, from the side of the true constraint (every solution is feasible for it).
"""

import json
import sys
from importlib import metadata

import numpy as np
import toppra
import toppra.algorithm as algo
import toppra.constraint as constraint
from toppra.constraint.linear_constraint import canlinear_colloc_to_interpolate
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


# Linearised-line rounds, and the relative change of the time at which they stop.
LINE_ROUNDS = 12
LINE_SETTLED = 1e-5


class ServoLines(constraint.LinearConstraint):
    """The servos' torque-speed lines at each gridpoint, linearised at squared speeds x0:
    F·(a·u + b·x + c) <= g with F the identity, two rows per servo (driving and braking)."""

    def __init__(self, rows, x0):
        super().__init__()
        a, b, c, k, sign, stall = rows
        root = np.sqrt(np.maximum(x0, 1e-12))[:, None]
        # Driving: sign·tau + k·(x + x0)/(2·sqrt(x0)) <= stall.
        self.a = np.concatenate([sign * a, -sign * a], axis=1)
        self.b = np.concatenate([sign * b + k / (2 * root), -sign * b], axis=1)
        self.c = np.concatenate([sign * c, -sign * c], axis=1)
        self.g = np.concatenate([stall - k * root / 2, stall], axis=1)
        points, m = self.a.shape
        self.F = np.broadcast_to(np.eye(m), (points, m, m)).copy()
        self.dof = m
        # The same discretisation as toppra's own joint constraints: each step's rows at both
        # of its gridpoints.
        self.discretization_type = constraint.DiscretizationType.Interpolation

    def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
        return canlinear_colloc_to_interpolate(
            self.a, self.b, self.c, self.F, self.g, None, None, gridpoints, identical=False
        )


def inverse_dynamics(mujoco, arm):
    """mj_inverse of one arm's model, damping, friction and constraints off: a function of
    (q, qd, qdd) in the model's units for the arm's joints, giving their forces (a joint an
    equality ties to another is moved with it and its force added to that one's)."""
    m = mujoco.MjModel.from_xml_path(arm["mjcf"])
    d = mujoco.MjData(m)
    m.dof_damping[:] = 0
    m.dof_frictionloss[:] = 0
    m.jnt_stiffness[:] = 0
    m.opt.disableflags = int(m.opt.disableflags) | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    m.opt.gravity[:] = arm["gravity"]
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in arm["joints"]]
    ties = []
    for e in range(m.neq):
        if int(m.eq_type[e]) == int(mujoco.mjtEq.mjEQ_JOINT) and m.eq_obj2id[e] in ids:
            ties.append((int(m.eq_obj1id[e]), ids.index(int(m.eq_obj2id[e])), float(m.eq_data[e][0]), float(m.eq_data[e][1])))

    def forces(q, qd, qdd):
        d.qpos[:] = m.qpos0
        d.qvel[:] = 0
        d.qacc[:] = 0
        for j, x, v, a in zip(ids, q, qd, qdd):
            d.qpos[m.jnt_qposadr[j]], d.qvel[m.jnt_dofadr[j]], d.qacc[m.jnt_dofadr[j]] = x, v, a
        for follower, master, offset, scale in ties:
            d.qpos[m.jnt_qposadr[follower]] = offset + scale * q[master]
            d.qvel[m.jnt_dofadr[follower]] = scale * qd[master]
            d.qacc[m.jnt_dofadr[follower]] = scale * qdd[master]
        mujoco.mj_inverse(m, d)
        out = np.array([d.qfrc_inverse[m.jnt_dofadr[j]] for j in ids])
        for follower, master, _, scale in ties:
            out[master] += scale * d.qfrc_inverse[m.jnt_dofadr[follower]]
        return out

    return forces


def line_rows(stretch):
    """Per gridpoint and servo: a, b, c of the servo torque, the line's speed slope k, the
    direction the path drives each servo, and the stall torque."""
    import mujoco

    torque = stretch["torque"]
    q, qd, qdd = (np.asarray(stretch[k], dtype=float) for k in ("q", "qd", "qdd"))
    si = np.where(np.asarray(torque["revolute"]), np.pi / 180, 1.0)
    q, qd, qdd = q * si, qd * si, qdd * si
    n = np.asarray(torque["transmission"], dtype=float)
    stall = np.asarray(torque["stall"], dtype=float)
    no_load = np.asarray(torque["no_load"], dtype=float)
    a, b, c = (np.zeros_like(q) for _ in range(3))
    for arm in torque["arms"]:
        cols = arm["columns"]
        forces = inverse_dynamics(mujoco, arm)
        zero = np.zeros(len(cols))
        for i in range(q.shape[0]):
            g = forces(q[i, cols], zero, zero)
            a[i, cols] = forces(q[i, cols], zero, qd[i, cols]) - g
            b[i, cols] = forces(q[i, cols], qd[i, cols], qdd[i, cols]) - g
            c[i, cols] = g
    a, b, c = a * n, b * n, c * n
    k = stall * np.abs(qd) / (n * no_load)
    sign = np.sign(qd)
    # A servo the path does not turn brakes and drives alike: both rows at the stall torque.
    return a, b, c, k, np.where(sign == 0, 1.0, sign), np.broadcast_to(stall, q.shape)


def solve(path, ss, constraints, sd_ends):
    instance = algo.TOPPRA(constraints, path, gridpoints=ss, parametrizer="ParametrizeConstAccel")
    result = instance.compute_parameterization(*sd_ends)
    sd = result[1]
    if sd is None or not np.all(np.isfinite(sd)):
        raise SystemExit("toppra found no parameterization")
    sd = np.asarray(sd, dtype=float)
    mean = 0.5 * (sd[1:] + sd[:-1])
    return float(np.sum(np.diff(ss) / mean)), sd


def duration(stretch):
    ss = np.asarray(stretch["ss"], dtype=float)
    path = SampledPath(ss, stretch["q"], stretch["qd"], stretch["qdd"])
    vlim = np.array([[-v, v] for v in stretch["vlim"]])
    alim = np.array([[-a, a] for a in stretch["alim"]])
    kinematic = [
        constraint.JointVelocityConstraint(vlim),
        constraint.JointAccelerationConstraint(alim),
    ]
    sd_ends = stretch.get("sd", [0.0, 0.0])
    seconds, sd = solve(path, ss, kinematic, sd_ends)
    if "torque" not in stretch:
        return seconds
    rows = line_rows(stretch)
    for _ in range(LINE_ROUNDS):
        before = seconds
        seconds, sd = solve(path, ss, kinematic + [ServoLines(rows, sd * sd)], sd_ends)
        if abs(seconds - before) <= LINE_SETTLED * seconds:
            break
    return seconds


def main():
    request = json.load(sys.stdin)
    durations = [duration(s) for s in request["stretches"]]
    json.dump({"durations": durations, "toppra": metadata.version("toppra")}, sys.stdout)


if __name__ == "__main__":
    main()
