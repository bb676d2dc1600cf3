"""Simulated runs: a commanded trajectory played row by row through a model's position servos,
recorded with its forces, joint-limit hits, contacts and MuJoCo's warnings.

It knows nothing about rendering or the request loop; thresholds and verdicts are keypose's.
"""

import json
import re
import struct
import time
from types import SimpleNamespace

from harness_io import member
from sim_profile import ServoProfile, profile_limits
from sim_requests import SimError, is_number, matrix, number, request_error, string_list, vector

# Decimals kept in a run's trace.
TRACE_DECIMALS = 9

# The binary trace (sim/PROTOCOL.md, run): magic, format version, rows, joints, then the
# columns as little-endian f64.
TRACE_MAGIC = b"KPTR"
TRACE_VERSION = 1
TRACE_FORMATS = ("json", "binary")


class Simulator:
    """Runs on the loaded model, the warnings MuJoCo raises, and whether a run may continue."""

    def __init__(self, mujoco, np):
        self.mujoco = mujoco
        self.np = np
        self.can_continue = False
        # The servo-side profile of the last run (--servo-profile), carried on by a continued run.
        self.profile = None
        self.warnings = []
        # Without a handler MuJoCo writes MUJOCO_LOG.TXT into the current directory, which is
        # the user's; the warnings are reported in replies instead.
        mujoco.set_mju_user_warning(self.warnings.append)
        warning = mujoco.mjtWarning
        self.fatal_warnings = {
            int(warning.mjWARN_BADQACC),
            int(warning.mjWARN_BADQPOS),
            int(warning.mjWARN_BADQVEL),
        }
        self.warning_names = {int(getattr(warning, n)): n for n in dir(warning) if n.startswith("mjWARN_")}
        # Each kind's text up to its first number: what its handler messages start with.
        self.warning_prefixes = tuple(
            re.split(r"\d", mujoco.mju_warningText(k, 0), maxsplit=1)[0] for k in self.warning_names
        )
        self._wrench = np.zeros(6)

    def run(self, model, req):
        args = self._run_request(model, req)
        wiring = self._wiring(model, args.joints)
        del self.warnings[:]
        if args.reset:
            self._reset(model, wiring, args.initial)
        profile = self._profile(model, wiring, args)
        # Only a run that ends in a state worth continuing may be continued.
        self.can_continue = False
        rec = self._record(model, wiring, args.commands, args.steps_per_row, profile)
        self._cut_at_non_finite(model, rec)
        self.can_continue = rec.recorded == args.commands.shape[0]
        return self._run_reply(rec, wiring, args.steps_per_row, args.trace_format)

    def pose_contacts(self, model, req):
        """The contacts of one pose, with no dynamics: qpos set, velocities zero, mj_forward.

        mj_forward runs collision detection and the constraint solver once, so penetrations and
        their forces are what the first physics step would meet; nothing moves. The scratch data
        is used, so a run in progress can still be continued.
        """
        d = model.scratch
        model.set_request_qpos(d, req)
        d.qvel[:] = 0
        d.ctrl[:] = 0
        self.mujoco.mj_forward(model.m, d)
        found = []
        self._contacts(model, d, 0.0, found)
        for contact in found:
            del contact["time"]
        return {"contacts": found}

    def pose_distances(self, model, req):
        """The distance of each asked pair of bodies at one pose, with no dynamics: for
        [body1, body2] the least mj_geomDistance over their shapes, for [body, null] over the
        body's shapes and the floor; null where it is `distmax` or more.

        Shapes are the geoms keypose's own collision model reads (boxes, capsules, spheres; not
        planes or meshes), so that the two measure the same solids: this is the oracle of
        keypose's distances. Signed: negative is a penetration that deep.
        """
        mujoco, m, d = self.mujoco, model.m, model.scratch
        model.set_request_qpos(d, req)
        d.qvel[:] = 0
        mujoco.mj_kinematics(m, d)
        distmax = number(req, "distmax", positive=True)
        solid = {int(mujoco.mjtGeom.mjGEOM_BOX), int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_SPHERE)}
        floor = [g for g in range(m.ngeom) if model.geom_floor[g]]

        def shapes(name):
            if not isinstance(name, str):
                raise request_error(f"a pair names bodies by their names, not {json.dumps(name)[:200]}")
            b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
            if b < 0:
                raise request_error(f"body {name!r} is not in {model.path}")
            return [g for g in range(m.ngeom) if int(m.geom_bodyid[g]) == b and int(m.geom_type[g]) in solid]

        pairs = member(req, "pairs")
        if not isinstance(pairs, list) or not all(isinstance(p, list) and len(p) == 2 for p in pairs):
            raise request_error("'pairs' must be a list of [body1, body2 or null]")
        out = []
        for first, second in pairs:
            others = floor if second is None else shapes(second)
            least = distmax
            for g1 in shapes(first):
                for g2 in others:
                    least = min(least, float(mujoco.mj_geomDistance(m, d, g1, g2, distmax, None)))
            out.append(None if least >= distmax else least)
        return {"distances": out}

    def pose_inverse(self, model, req):
        """The generalized force each joint needs for the asked motion: mj_inverse at the asked
        qpos, qvel and qacc (joint: value; others at qpos0 and at rest), reply per joint.

        Rigid-body dynamics with gravity and the joints' armature, nothing else: joint damping
        (the servo's back-EMF, which its torque-speed line covers), friction loss, springs and
        every constraint (limits, contacts, equalities) are switched off for the call and put
        back after. This is the oracle of keypose's own inverse dynamics; a joint an equality
        ties to another (the OMX's second finger) gets its own force, for the caller to add
        through the equality's coefficient.
        """
        mujoco, m, d = self.mujoco, model.m, model.scratch
        model.set_request_qpos(d, req)
        d.qvel[:] = 0
        d.qacc[:] = 0
        for field, target in (("qvel", d.qvel), ("qacc", d.qacc)):
            values = member(req, field)
            if not isinstance(values, dict):
                raise request_error(f"{field!r} must be an object of joint: value, not {json.dumps(values)[:200]}")
            for joint_name, value in values.items():
                if not is_number(value):
                    raise request_error(f"{field} of {joint_name!r} must be a finite number, not {json.dumps(value)}")
                target[m.jnt_dofadr[model.joint(joint_name)]] = float(value)
        kept = (m.dof_damping.copy(), m.dof_frictionloss.copy(), m.jnt_stiffness.copy(), int(m.opt.disableflags))
        try:
            m.dof_damping[:] = 0
            m.dof_frictionloss[:] = 0
            m.jnt_stiffness[:] = 0
            m.opt.disableflags = kept[3] | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
            mujoco.mj_inverse(m, d)
            force = {name: float(d.qfrc_inverse[m.jnt_dofadr[j]]) for name, j in model.joint_ids.items()}
        finally:
            m.dof_damping[:], m.dof_frictionloss[:], m.jnt_stiffness[:] = kept[0], kept[1], kept[2]
            m.opt.disableflags = kept[3]
        return {"force": force}

    def _run_request(self, model, req):
        """The run request's joints, rate, reset flag, initial values and commands, checked."""
        np, m = self.np, model.m
        names = string_list(req, "joints")
        joints = [model.joint(n) for n in names]
        for joint_name, j in zip(names, joints):
            if j not in model.joint_actuators:
                raise request_error(f"joint {joint_name!r} has no position actuator in {model.path}: a run can only command joints that have one")
        hz = number(req, "control_hz", positive=True)
        steps_per_row = int(round(1.0 / (hz * m.opt.timestep)))
        if steps_per_row < 1:
            raise request_error(f"control_hz {hz:g} is faster than the physics ({1.0 / m.opt.timestep:g} Hz, timestep {m.opt.timestep:g} s)")
        reset = member(req, "reset", True, required=False)
        if not isinstance(reset, bool):
            raise request_error(f"'reset' must be true or false, not {json.dumps(reset)}")
        if not reset and not self.can_continue:
            raise SimError("state", "run with reset false: there is no run to continue (none yet, the model was reloaded, or the last one diverged)")
        initial = None
        if reset or "initial" in req:
            initial = np.array(vector(member(req, "initial"), len(joints), "'initial'"), dtype=float)
        commands = matrix(np, req, "commands", len(joints), nonempty=False)
        limits = profile_limits(np, req, len(joints))
        trace_format = member(req, "trace", "json", required=False)
        if trace_format not in TRACE_FORMATS:
            raise request_error(f"'trace' must be one of {', '.join(TRACE_FORMATS)}, not {json.dumps(trace_format)}")
        return SimpleNamespace(joints=joints, steps_per_row=steps_per_row, reset=reset, initial=initial, commands=commands, profile_limits=limits, trace_format=trace_format)

    def _profile(self, model, wiring, args):
        """The servo-side profile of this run (None without one): started at rest where the
        joints are after a reset, carried on from the previous run's when continuing."""
        if args.profile_limits is None:
            self.profile = None
            return None
        if args.reset or self.profile is None:
            acceleration, velocity = args.profile_limits
            position = model.data.qpos[wiring.qadr]
            self.profile = ServoProfile(self.np, acceleration, velocity, position)
        return self.profile

    def _wiring(self, model, joints):
        """Where the listed joints' commands go and where their state and forces are read.

        Every position actuator of a listed joint gets that joint's target (times its gear:
        the servo's length is gear * q); the others hold their joint at qpos0, or keep their
        control when a run continues.
        """
        np, m, d = self.np, model.m, model.data
        nj = len(joints)
        column = {j: c for c, j in enumerate(joints)}
        driven = [info for info in model.actuators if info["joint"] in column]
        force_map = np.zeros((d.actuator_force.shape[0], nj))
        for info in driven:
            force_map[info["out"], column[info["joint"]]] = 1.0
        joint_column = np.full(m.njnt, -1, dtype=np.intp)
        joint_column[joints] = np.arange(nj)
        return SimpleNamespace(
            nj=nj,
            held=[info for info in model.actuators if info["joint"] not in column],
            ctrl_idx=np.array([info["ctrl"] for info in driven], dtype=np.intp),
            gears=np.array([info["gear"] for info in driven]),
            driven_columns=[column[info["joint"]] for info in driven],
            force_map=force_map,
            qadr=np.array([m.jnt_qposadr[j] for j in joints], dtype=np.intp),
            vadr=np.array([m.jnt_dofadr[j] for j in joints], dtype=np.intp),
            joint_column=joint_column,
        )

    def _reset(self, model, wiring, initial):
        """The listed joints at `initial`, at rest, every servo holding where its joint is."""
        mujoco, m, d = self.mujoco, model.m, model.data
        mujoco.mj_resetData(m, d)
        d.qpos[wiring.qadr] = initial
        d.qvel[:] = 0.0
        for info in wiring.held:
            d.ctrl[info["ctrl"]] = info["gear"] * d.qpos[m.jnt_qposadr[info["joint"]]]
        d.ctrl[wiring.ctrl_idx] = initial[wiring.driven_columns] * wiring.gears
        mujoco.mj_forward(m, d)

    def _record(self, model, wiring, commands, steps_per_row, profile=None):
        """Steps the physics row by row, recording each row's end state until the last row or
        a fatal warning."""
        mujoco, np, m, d = self.mujoco, self.np, model.m, model.data
        rows = commands.shape[0]
        # Whole control vectors per row, so that the loop sets ctrl with one slice copy.
        ctrl_rows = np.tile(d.ctrl, (rows, 1))
        ctrl_rows[:, wiring.ctrl_idx] = commands[:, wiring.driven_columns] * wiring.gears
        # The loop copies whole state vectors (one C-level copy each) and picks the joints'
        # columns once at the end.
        t_all = np.zeros(rows)
        q_all = np.zeros((rows, m.nq))
        v_all = np.zeros((rows, m.nv))
        f_all = np.zeros((rows, d.actuator_force.shape[0]))
        lim_out = np.zeros((rows, wiring.nj), dtype=np.int8)
        contacts = []
        divergence = []
        joint_column = wiring.joint_column
        limit_type = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)
        # Views into MjData: taken once, they stay valid (resetting does not reallocate).
        ctrl, qpos, qvel, act_force = d.ctrl, d.qpos, d.qvel, d.actuator_force
        mj_step = mujoco.mj_step
        warnings = self.warnings
        warnings_seen = 0
        # A continued run reports only the warnings it raises itself.
        warning_counts = [w.number for w in d.warning]
        recorded = rows
        steps = 0
        started = time.perf_counter()
        dt = m.opt.timestep
        ctrl_idx, columns, gears = wiring.ctrl_idx, wiring.driven_columns, wiring.gears
        for r in range(rows):
            ctrl[:] = ctrl_rows[r]
            if profile is None:
                mj_step(m, d, steps_per_row)
            else:
                # The servos' own profile between goals: a new actuator target every step.
                for _ in range(steps_per_row):
                    ctrl[ctrl_idx] = profile.step(commands[r], dt)[columns] * gears
                    mj_step(m, d, 1)
            steps += steps_per_row
            now = d.time
            # MuJoCo checks qpos, qvel and qacc for NaN and huge values in every step and
            # warns: a diverging state always shows up here first.
            if len(warnings) != warnings_seen:
                stop = self._warnings(model, d, now, warnings_seen, warning_counts, divergence)
                warnings_seen = len(warnings)
                if stop:
                    recorded = r
                    break
            t_all[r] = now
            q_all[r] = qpos
            v_all[r] = qvel
            f_all[r] = act_force
            nl = d.nl
            if nl:
                # Constraint rows come grouped: equality, friction, limits, contacts.
                first = d.ne + d.nf
                kinds = d.efc_type[first : first + nl]
                limited = d.efc_id[first : first + nl][kinds == limit_type]
                cols = joint_column[limited]
                lim_out[r, cols[cols >= 0]] = 1
            if d.ncon:
                self._contacts(model, d, now, contacts)
        wall = time.perf_counter() - started
        return SimpleNamespace(
            t=t_all, q=q_all, v=v_all, f=f_all, limits=lim_out, contacts=contacts,
            divergence=divergence, recorded=recorded, steps=steps, wall=wall,
        )

    def _cut_at_non_finite(self, model, rec):
        """Belt and braces for a non-finite state MuJoCo did not warn about: the trace ends
        before it, with a fatal divergence at its time."""
        np = self.np
        recorded = rec.recorded
        finite = np.isfinite(rec.q[:recorded]).all(axis=1) & np.isfinite(rec.v[:recorded]).all(axis=1)
        if not finite.all():
            bad = int(np.argmin(finite))
            rec.divergence.append({"time": round(float(rec.t[bad]), TRACE_DECIMALS), "message": self._not_finite(model, rec.q[bad], rec.v[bad]), "fatal": True})
            rec.contacts = [c for c in rec.contacts if c["time"] < round(float(rec.t[bad]), TRACE_DECIMALS)]
            rec.recorded = bad

    def _run_reply(self, rec, wiring, steps_per_row, trace_format):
        np = self.np
        recorded = rec.recorded
        # Nine decimals (nanoradians, nanometres, nanonewtons) are far below what any verdict
        # looks at; they make JSON numbers short, and keep both forms of the trace equal.
        time_column = np.round(rec.t[:recorded], TRACE_DECIMALS)
        matrices = [
            np.round(rec.q[:recorded][:, wiring.qadr], TRACE_DECIMALS),
            np.round(rec.v[:recorded][:, wiring.vadr], TRACE_DECIMALS),
            np.round(rec.f[:recorded] @ wiring.force_map, TRACE_DECIMALS),
            rec.limits[:recorded],
        ]
        reply = {
            "steps": rec.steps,
            "steps_per_row": steps_per_row,
            "wall_seconds": rec.wall,
            "contacts": rec.contacts,
            "divergence": rec.divergence,
        }
        if trace_format == "binary":
            reply["payload"] = self._trace_bytes(time_column, matrices, wiring.nj)
        else:
            names = ("qpos", "qvel", "force", "limit")
            reply["trace"] = {"time": time_column.tolist(), **{n: m.tolist() for n, m in zip(names, matrices)}}
        return reply

    def _trace_bytes(self, time_column, matrices, joints):
        """The trace as PROTOCOL.md's binary form: a 16-byte header, then time, qpos, qvel,
        force and limit (1.0 or 0.0), each row after row, as little-endian f64."""
        np = self.np
        header = struct.pack("<4sIII", TRACE_MAGIC, TRACE_VERSION, time_column.shape[0], joints)
        columns = [time_column] + [m.reshape(-1) for m in matrices]
        return header + np.concatenate(columns).astype("<f8").tobytes()

    def _warnings(self, model, d, now, seen, counts, divergence):
        """Lists the warnings MuJoCo raised since the last check; True if the state went bad.

        MuJoCo calls the warning handler only the first time each kind is raised after a reset,
        so the per-kind counters say which kinds are new, and the handler's messages that are
        not of a kind (a solver falling back, say) are listed as they are.
        """
        stop = False
        for k in range(len(counts)):
            number = d.warning[k].number
            if number and not counts[k]:
                info = d.warning[k].lastinfo
                fatal = k in self.fatal_warnings
                divergence.append(
                    {
                        "time": round(now, TRACE_DECIMALS),
                        "message": self.mujoco.mju_warningText(k, info) + self._where(model, k, info),
                        "warning": self.warning_names.get(k, str(k)),
                        "fatal": fatal,
                    }
                )
                stop = stop or fatal
            counts[k] = number
        for message in self.warnings[seen:]:
            if not message.startswith(self.warning_prefixes):
                divergence.append({"time": round(now, TRACE_DECIMALS), "message": message, "fatal": False})
        return stop

    def _where(self, model, kind, info):
        m, mujoco = model.m, self.mujoco
        warning = mujoco.mjtWarning
        if kind in (int(warning.mjWARN_BADQVEL), int(warning.mjWARN_BADQACC), int(warning.mjWARN_INERTIA)):
            joint = int(m.dof_jntid[info]) if 0 <= info < m.nv else -1
        elif kind == int(warning.mjWARN_BADQPOS):
            joint = max((j for j in range(m.njnt) if m.jnt_qposadr[j] <= info), default=-1, key=lambda j: m.jnt_qposadr[j])
        else:
            return ""
        if joint < 0:
            return ""
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, joint) or f"#{joint}"
        return f" (joint {name!r})"

    def _not_finite(self, model, qpos, qvel):
        m, np = model.m, self.np
        for j in range(m.njnt):
            q, v = m.jnt_qposadr[j], m.jnt_dofadr[j]
            nq = {0: 7, 1: 4}.get(int(m.jnt_type[j]), 1)
            nv = {0: 6, 1: 3}.get(int(m.jnt_type[j]), 1)
            if not (np.isfinite(qpos[q : q + nq]).all() and np.isfinite(qvel[v : v + nv]).all()):
                joint_name = self.mujoco.mj_id2name(m, self.mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint#{j}"
                return f"qpos or qvel of joint {joint_name!r} is not finite: the simulation diverged"
        return "qpos or qvel is not finite: the simulation diverged"

    def _contacts(self, model, d, now, out):
        np = self.np
        m = model.m
        con = d.contact
        # In-margin contacts (dist >= 0) touch nothing; excluded ones (efc_address < 0) carry no force.
        hits = np.flatnonzero((con.dist < 0) & (con.efc_address >= 0))
        if not hits.size:
            return
        geoms = con.geom
        dist = con.dist
        wrench = self._wrench
        for i in hits:
            g1, g2 = int(geoms[i, 0]), int(geoms[i, 1])
            if g1 < 0 or g2 < 0:
                # A flex vertex or element: no geom, so no body of the robot's.
                b1 = int(m.geom_bodyid[g1]) if g1 >= 0 else -1
                b2 = int(m.geom_bodyid[g2]) if g2 >= 0 else -1
                kind = "environment"
            else:
                b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
                if model.geom_floor[g1] or model.geom_floor[g2]:
                    kind = "floor"
                elif model.body_robot[b1] and model.body_robot[b2]:
                    # In a cell, two arms' bodies touching is a collision between the arms.
                    kind = "self" if model.body_arm[b1] == model.body_arm[b2] else "arms"
                    if kind == "arms" and model.arm_order[model.body_arm[b1]] > model.arm_order[model.body_arm[b2]]:
                        # Named in the cell's order of arms, whichever MuJoCo put first.
                        b1, b2 = b2, b1
                else:
                    kind = "environment"
            self.mujoco.mj_contactForce(m, d, int(i), wrench)
            contact = {
                "time": round(now, TRACE_DECIMALS),
                "body1": model.body_names[b1] if b1 >= 0 else "flex",
                "body2": model.body_names[b2] if b2 >= 0 else "flex",
                "kind": kind,
                "depth": float(-dist[i]),
                "force": float(wrench[0]),
            }
            if model.arm_roots is not None:
                contact["arm1"] = model.body_arm[b1] if b1 >= 0 else None
                contact["arm2"] = model.body_arm[b2] if b2 >= 0 else None
            out.append(contact)
