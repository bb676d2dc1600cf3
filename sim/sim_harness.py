#!/usr/bin/env python3
"""keypose's MuJoCo harness: kinematics, simulated runs of keyframe sequences, and renders.

keypose (Rust) runs one of these processes and speaks JSON lines with it: one request object
per line on stdin, one reply object per line on stdout, flushed after each reply. The protocol
is sim/PROTOCOL.md; in short:

    ready line   {"ready": true, "mujoco": V, "numpy": V, "python": V, "gl": "egl", ...}
                 or {"ready": false, "error": TEXT, "missing": MODULE}
    ping         {"op": "ping"} -> {"ok": true}
    load         {"op": "load", "mjcf": PATH}
    kinematics   {"op": "kinematics", "qpos": {JOINT: VALUE}, "sites": [SITE, ...]}
    run          {"op": "run", "joints": [...], "control_hz": HZ, "initial": [...], "commands": [[...]]}
    render       {"op": "render", "frames": [[...]], "joints": [...], "labels": [...], "path": P,
                  "width": W, "height": H, "fps": F, "columns": C}

A "seq" member is echoed in the reply. Errors are {"ok": false, "kind": K, "error": TEXT} with K
one of "request" (malformed or invalid request, including an output file that cannot be
written), "state" (no model loaded), "model" (the MJCF does not load), "render" (no GL context:
the reply also carries "gl" and "packages", the Debian packages that provide that backend) or
"internal"; the process goes on after any of them.

What PROTOCOL.md leaves open, decided here:
- A run may carry "reset": false (default true) to continue from where the previous run of
  the same model ended, its state and controls kept and "initial" ignored; "time" is then the
  simulation clock, which goes on from the previous run's. Without a previous run to continue
  (none, a new model, or one that diverged) the reply is a "state" error.
- Joints not given to kinematics, and joints not listed in a run, sit at the model's qpos0
  (0 for hinge and slide joints unless the MJCF gives them a `ref`), as after mj_resetData.
  A run's unlisted position actuators hold their joints there.
- A run records, after each row, qpos and qvel at the end of the row; force, limit flags and
  contacts are what MuJoCo computed in the row's last step, i.e. one physics timestep earlier.
- MuJoCo's automatic reset on a bad state is switched off, so that a diverging run keeps its
  trace up to the divergence instead of jumping back to qpos0. The row during which the run
  diverged is not in the trace (its values are not finite); "divergence" gives its time.
  Warnings that do not make the state bad (contact or constraint buffer full) are listed in
  "divergence" with "fatal": false and the run goes on.
- A render's contact sheet has min(columns, frames) columns, each tile exactly width x height
  with its label drawn inside; the reply gives the image's size.
"""

import json
import math
import os
import re
import sys
import time

from harness_io import RequestError, distribution_version, emit, ignore_sigint, interpreter, not_ready, serve, take_stdout

# The backends' libraries, and the Debian/Ubuntu packages that provide them.
GL_LIBRARIES = {"egl": "EGL", "osmesa": "OSMesa"}
GL_PACKAGES = {
    "egl": "libegl1 libgl1-mesa-dri",
    "osmesa": "libosmesa6",
    "glx": "libgl1 libglx-mesa0 (and an X display)",
    "glfw": "libglfw3 libgl1 (and a display)",
}

# Formats a render can write, by file extension.
RENDER_FORMATS = (".png", ".gif", ".mp4")

MAX_IMAGE_SIDE = 8192

# Decimals kept in a run's trace.
TRACE_DECIMALS = 9


def choose_gl():
    """The MUJOCO_GL backend to use and, if its library cannot be loaded, why.

    MuJoCo reads MUJOCO_GL when it is imported, and when the backend's library is missing the
    import itself fails (PyOpenGL calls into a library it could not load), which would take
    physics down with rendering. So the library is tried first; without it rendering is
    disabled for this process and render requests say which package is missing.
    """
    gl = os.environ.get("MUJOCO_GL", "").strip().lower()
    if not gl:
        gl = "egl"
    os.environ["MUJOCO_GL"] = gl
    if gl not in GL_PACKAGES:
        # MuJoCo's import raises on a value it does not know, physics included.
        os.environ["MUJOCO_GL"] = "disable"
        return gl, f"MUJOCO_GL={gl} is not a backend keypose renders with (egl, osmesa, glx, glfw)"
    library = GL_LIBRARIES.get(gl)
    if library is None or not sys.platform.startswith("linux"):
        return gl, None
    import ctypes
    import ctypes.util

    found = ctypes.util.find_library(library)
    if found is None:
        problem = f"the {library} library (lib{library}.so) is not installed"
    else:
        try:
            ctypes.CDLL(found)
            return gl, None
        except OSError as e:
            problem = f"the {library} library {found} cannot be loaded: {e}"
    os.environ["MUJOCO_GL"] = "disable"
    return gl, problem


class SimError(RequestError):
    pass


def request_error(message):
    return SimError("request", message)


def field(req, name, default=None, required=True):
    if name in req:
        return req[name]
    if required:
        raise request_error(f"request {req.get('op')!r} lacks {name!r}")
    return default


def is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def number(req, name, default=None, positive=False):
    value = field(req, name, default, required=default is None)
    if not is_number(value):
        raise request_error(f"{name!r} must be a finite number, not {json.dumps(value)}")
    if positive and value <= 0:
        raise request_error(f"{name!r} must be positive, not {value}")
    return float(value)


def integer(req, name, default, lo, hi):
    value = field(req, name, default, required=default is None)
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise request_error(f"{name!r} must be an integer in {lo}..{hi}, not {json.dumps(value)}")
    return value


def string_list(req, name, required=True, nonempty=True):
    value = field(req, name, None, required)
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
    rows = field(req, name)
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


class Model:
    """A loaded MJCF model with the lookups the requests need, computed once."""

    def __init__(self, mujoco, np, path, model):
        self.mujoco = mujoco
        self.np = np
        self.path = path
        self.m = m = model
        # Autoreset would make a diverging trace jump back to qpos0 without a trace of why.
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        self.data = mujoco.MjData(m)
        self.scratch = mujoco.MjData(m)

        def name(obj, index, fallback):
            found = mujoco.mj_id2name(m, obj, index)
            return found if found else f"{fallback}#{index}"

        hinge = int(mujoco.mjtJoint.mjJNT_HINGE)
        slide = int(mujoco.mjtJoint.mjJNT_SLIDE)
        self.joint_names = []
        self.joint_ids = {}
        for j in range(m.njnt):
            kind = int(m.jnt_type[j])
            joint_name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
            # Unnamed joints cannot be addressed in a request; free and ball joints are not scalar.
            if joint_name and kind in (hinge, slide):
                self.joint_ids[joint_name] = j
                self.joint_names.append(joint_name)
        self.joint_type = {j: ("hinge" if int(m.jnt_type[j]) == hinge else "slide") for j in self.joint_ids.values()}
        self.body_names = [name(mujoco.mjtObj.mjOBJ_BODY, b, "body") for b in range(m.nbody)]
        self.site_ids = {}
        for s in range(m.nsite):
            site_name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, s)
            if site_name:
                self.site_ids[site_name] = s

        # Position servos on joints: gain kp, bias -kp*length (and possibly -kv*velocity).
        self.actuators = []
        self.joint_actuators = {}
        for a in range(m.nactuator):
            if not self._is_position_servo(a):
                continue
            j = int(m.actuator_trnid[a, 0])
            if j not in self.joint_type:
                continue
            info = {
                "id": a,
                "joint": j,
                "ctrl": int(m.actuator_ctrladr[a]),
                "out": int(m.actuator_outadr[a]),
                "gear": float(m.actuator_gear[m.actuator_outadr[a], 0]),
            }
            self.actuators.append(info)
            self.joint_actuators.setdefault(j, []).append(info)
        self.actuator_reply = [
            {
                "name": name(mujoco.mjtObj.mjOBJ_ACTUATOR, info["id"], "actuator"),
                "joint": mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, info["joint"]),
                "kp": float(m.actuator_gainprm[info["id"], 0]),
                "kv": float(-m.actuator_biasprm[info["id"], 2]),
                "gear": info["gear"],
                "forcerange": [float(v) for v in m.actuator_forcerange[info["id"]]],
                "forcelimited": bool(m.actuator_forcelimited[info["id"]]),
            }
            for info in self.actuators
        ]

        # Contact classification. The robot is the kinematic trees its actuated joints are in
        # (or every tree that moves, in a model without actuators); everything else attached
        # to the world is environment.
        plane = int(mujoco.mjtGeom.mjGEOM_PLANE)
        self.geom_floor = np.array(
            [int(m.geom_type[g]) == plane or mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) == "floor" for g in range(m.ngeom)],
            dtype=bool,
        )
        roots = {int(m.body_rootid[m.jnt_bodyid[info["joint"]]]) for info in self.actuators}
        if not roots:
            roots = {int(m.body_rootid[m.jnt_bodyid[j]]) for j in range(m.njnt)}
        roots.discard(0)
        self.body_robot = np.array([b != 0 and int(m.body_rootid[b]) in roots for b in range(m.nbody)], dtype=bool)

    def _is_position_servo(self, a):
        m, mujoco = self.m, self.mujoco
        if int(m.actuator_trntype[a]) != int(mujoco.mjtTrn.mjTRN_JOINT):
            return False
        if int(m.actuator_ctrlnum[a]) != 1 or int(m.actuator_outnum[a]) != 1:
            return False
        if int(m.actuator_gaintype[a]) != int(mujoco.mjtGain.mjGAIN_FIXED):
            return False
        if int(m.actuator_biastype[a]) != int(mujoco.mjtBias.mjBIAS_AFFINE):
            return False
        kp = float(m.actuator_gainprm[a, 0])
        bias = m.actuator_biasprm[a]
        return kp > 0 and float(bias[0]) == 0.0 and math.isclose(float(bias[1]), -kp, rel_tol=1e-9)

    def joint(self, joint_name, what="joint"):
        j = self.joint_ids.get(joint_name)
        if j is None:
            known = ", ".join(self.joint_names) or "none"
            raise request_error(f"{what} {joint_name!r} is not a hinge or slide joint of {self.path} (its joints: {known})")
        return j

    def set_joints(self, data, joint_ids, values):
        m = self.m
        data.qpos[:] = m.qpos0
        for j, value in zip(joint_ids, values):
            data.qpos[m.jnt_qposadr[j]] = value

    def describe(self):
        m = self.m
        joints = []
        for joint_name in self.joint_names:
            j = self.joint_ids[joint_name]
            joints.append(
                {
                    "name": joint_name,
                    "type": self.joint_type[j],
                    "range": [float(v) for v in m.jnt_range[j]],
                    "limited": bool(m.jnt_limited[j]),
                }
            )
        return {
            "timestep": float(m.opt.timestep),
            "joints": joints,
            "actuators": self.actuator_reply,
            "bodies": self.body_names,
            "sites": list(self.site_ids),
        }


class Harness:
    def __init__(self, mujoco, np, gl, gl_problem):
        self.mujoco = mujoco
        self.np = np
        self.gl = gl
        self.gl_problem = gl_problem
        self.model = None
        self.can_continue = False
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

    def handle_line(self, line):
        try:
            req = json.loads(line, parse_constant=_reject_constant)
        except ValueError as e:
            return SimError("request", f"malformed request (not JSON): {e}").reply()
        seq = req.get("seq") if isinstance(req, dict) else None
        try:
            if not isinstance(req, dict):
                raise request_error(f"a request must be a JSON object, not {json.dumps(req)[:200]}")
            reply = {"ok": True}
            reply.update(self.dispatch(req))
        except SimError as e:
            reply = e.reply()
        except self.mujoco.FatalError as e:
            reply = SimError("internal", f"MuJoCo: {e}").reply()
        except Exception as e:  # an unforeseen input or a bug must not end the harness
            reply = SimError("internal", f"{type(e).__name__}: {e}").reply()
        if seq is not None:
            reply["seq"] = seq
        return reply

    def dispatch(self, req):
        op = req.get("op")
        if op == "ping":
            return {}
        if op == "load":
            return self.load(req)
        if op in ("kinematics", "run", "render"):
            if self.model is None:
                raise SimError("state", f"{op}: no model loaded (send 'load' first)")
            return getattr(self, op)(req)
        raise request_error(f"unknown op {json.dumps(op)} (known: ping, load, kinematics, run, render)")

    def load(self, req):
        path = field(req, "mjcf")
        if not isinstance(path, str) or not path:
            raise request_error(f"'mjcf' must be a path, not {json.dumps(path)}")
        del self.warnings[:]
        try:
            model = self.mujoco.MjModel.from_xml_path(path)
        except Exception as e:  # MuJoCo raises ValueError for XML and compile errors
            raise SimError("model", f"cannot load {path}: {e}".rstrip())
        self.model = Model(self.mujoco, self.np, path, model)
        self.can_continue = False
        reply = self.model.describe()
        if self.warnings:
            reply["warnings"] = list(self.warnings)
        return reply

    def kinematics(self, req):
        model = self.model
        mujoco, m, data = self.mujoco, model.m, model.scratch
        qpos = field(req, "qpos")
        if not isinstance(qpos, dict):
            raise request_error(f"'qpos' must be an object of joint: value, not {json.dumps(qpos)[:200]}")
        ids, values = [], []
        for joint_name, value in qpos.items():
            ids.append(model.joint(joint_name))
            if not is_number(value):
                raise request_error(f"qpos of {joint_name!r} must be a finite number, not {json.dumps(value)}")
            values.append(float(value))
        sites = string_list(req, "sites", required=False, nonempty=False)
        if sites is None:
            sites = list(model.site_ids)
        site_ids = []
        for site in sites:
            s = model.site_ids.get(site)
            if s is None:
                known = ", ".join(model.site_ids) or "none"
                raise request_error(f"site {site!r} is not in {model.path} (its sites: {known})")
            site_ids.append(s)
        model.set_joints(data, ids, values)
        mujoco.mj_kinematics(m, data)
        anchors, axes = {}, {}
        for joint_name in model.joint_names:
            j = model.joint_ids[joint_name]
            anchors[joint_name] = data.xanchor[j].tolist()
            axes[joint_name] = data.xaxis[j].tolist()
        return {
            "anchors": anchors,
            "axes": axes,
            "sites": {site: data.site_xpos[s].tolist() for site, s in zip(sites, site_ids)},
        }

    def run(self, req):
        model = self.model
        mujoco, np, m, d = self.mujoco, self.np, model.m, model.data
        names = string_list(req, "joints")
        joints = [model.joint(n) for n in names]
        for joint_name, j in zip(names, joints):
            if j not in model.joint_actuators:
                raise request_error(f"joint {joint_name!r} has no position actuator in {model.path}: a run can only command joints that have one")
        hz = number(req, "control_hz", positive=True)
        steps_per_row = int(round(1.0 / (hz * m.opt.timestep)))
        if steps_per_row < 1:
            raise request_error(f"control_hz {hz:g} is faster than the physics ({1.0 / m.opt.timestep:g} Hz, timestep {m.opt.timestep:g} s)")
        reset = field(req, "reset", True, required=False)
        if not isinstance(reset, bool):
            raise request_error(f"'reset' must be true or false, not {json.dumps(reset)}")
        if not reset and not self.can_continue:
            raise SimError("state", "run with reset false: there is no run to continue (none yet, the model was reloaded, or the last one diverged)")
        if reset or "initial" in req:
            initial = np.array(vector(field(req, "initial"), len(joints), "'initial'"), dtype=float)
        commands = matrix(np, req, "commands", len(joints), nonempty=False)
        rows = commands.shape[0]
        nj = len(joints)

        # Every position actuator of a listed joint gets that joint's target (times its gear:
        # the servo's length is gear * q); the others hold their joint at qpos0, or keep their
        # control when a run continues.
        column = {j: c for c, j in enumerate(joints)}
        driven = [info for info in model.actuators if info["joint"] in column]
        held = [info for info in model.actuators if info["joint"] not in column]
        ctrl_idx = np.array([info["ctrl"] for info in driven], dtype=np.intp)
        gears = np.array([info["gear"] for info in driven])
        driven_columns = [column[info["joint"]] for info in driven]
        force_map = np.zeros((d.actuator_force.shape[0], nj))
        for info in driven:
            force_map[info["out"], column[info["joint"]]] = 1.0
        qadr = np.array([m.jnt_qposadr[j] for j in joints], dtype=np.intp)
        vadr = np.array([m.jnt_dofadr[j] for j in joints], dtype=np.intp)
        joint_column = np.full(m.njnt, -1, dtype=np.intp)
        joint_column[joints] = np.arange(nj)
        limit_type = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)

        del self.warnings[:]
        if reset:
            mujoco.mj_resetData(m, d)
            d.qpos[qadr] = initial
            d.qvel[:] = 0.0
            for info in held:
                d.ctrl[info["ctrl"]] = info["gear"] * d.qpos[m.jnt_qposadr[info["joint"]]]
            d.ctrl[ctrl_idx] = initial[driven_columns] * gears
            mujoco.mj_forward(m, d)
        # Only a run that ends in a state worth continuing may be continued.
        self.can_continue = False

        # Whole control vectors per row, so that the loop sets ctrl with one slice copy.
        ctrl_rows = np.tile(d.ctrl, (rows, 1))
        ctrl_rows[:, ctrl_idx] = commands[:, driven_columns] * gears
        # The loop copies whole state vectors (one C-level copy each) and picks the joints'
        # columns once at the end.
        t_all = np.zeros(rows)
        q_all = np.zeros((rows, m.nq))
        v_all = np.zeros((rows, m.nv))
        f_all = np.zeros((rows, d.actuator_force.shape[0]))
        lim_out = np.zeros((rows, nj), dtype=np.int8)
        contacts = []
        divergence = []
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
        for r in range(rows):
            ctrl[:] = ctrl_rows[r]
            mj_step(m, d, steps_per_row)
            steps += steps_per_row
            now = d.time
            # MuJoCo checks qpos, qvel and qacc for NaN and huge values in every step and
            # warns: a diverging state always shows up here first.
            if len(warnings) != warnings_seen:
                stop = self._warnings(d, now, warnings_seen, warning_counts, divergence)
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
                self._contacts(d, now, contacts)
        wall = time.perf_counter() - started
        # Belt and braces for a non-finite state MuJoCo did not warn about.
        finite = np.isfinite(q_all[:recorded]).all(axis=1) & np.isfinite(v_all[:recorded]).all(axis=1)
        if not finite.all():
            bad = int(np.argmin(finite))
            divergence.append({"time": round(float(t_all[bad]), TRACE_DECIMALS), "message": self._not_finite(q_all[bad], v_all[bad]), "fatal": True})
            contacts = [c for c in contacts if c["time"] < round(float(t_all[bad]), TRACE_DECIMALS)]
            recorded = bad
        self.can_continue = recorded == rows

        def listed(values):
            # Nine decimals (nanoradians, nanometres, nanonewtons) are far below what any
            # verdict looks at, and make the numbers short: the reply halves, and so does the
            # time spent writing and parsing it.
            return np.round(values, TRACE_DECIMALS).tolist()

        return {
            "steps": steps,
            "steps_per_row": steps_per_row,
            "wall_seconds": wall,
            "trace": {
                "time": listed(t_all[:recorded]),
                "qpos": listed(q_all[:recorded][:, qadr]),
                "qvel": listed(v_all[:recorded][:, vadr]),
                "force": listed(f_all[:recorded] @ force_map),
                "limit": lim_out[:recorded].tolist(),
            },
            "contacts": contacts,
            "divergence": divergence,
        }

    def _warnings(self, d, now, seen, counts, divergence):
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
                        "message": self.mujoco.mju_warningText(k, info) + self._where(k, info),
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

    def _where(self, kind, info):
        m, mujoco = self.model.m, self.mujoco
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

    def _not_finite(self, qpos, qvel):
        m, np = self.model.m, self.np
        for j in range(m.njnt):
            q, v = m.jnt_qposadr[j], m.jnt_dofadr[j]
            nq = {0: 7, 1: 4}.get(int(m.jnt_type[j]), 1)
            nv = {0: 6, 1: 3}.get(int(m.jnt_type[j]), 1)
            if not (np.isfinite(qpos[q : q + nq]).all() and np.isfinite(qvel[v : v + nv]).all()):
                joint_name = self.mujoco.mj_id2name(m, self.mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint#{j}"
                return f"qpos or qvel of joint {joint_name!r} is not finite: the simulation diverged"
        return "qpos or qvel is not finite: the simulation diverged"

    def _contacts(self, d, now, out):
        model, np = self.model, self.np
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
                    kind = "self"
                else:
                    kind = "environment"
            self.mujoco.mj_contactForce(m, d, int(i), wrench)
            out.append(
                {
                    "time": round(now, TRACE_DECIMALS),
                    "body1": model.body_names[b1] if b1 >= 0 else "flex",
                    "body2": model.body_names[b2] if b2 >= 0 else "flex",
                    "kind": kind,
                    "depth": float(-dist[i]),
                    "force": float(wrench[0]),
                }
            )

    def render(self, req):
        model, np = self.model, self.np
        mujoco, m, data = self.mujoco, model.m, model.scratch
        names = string_list(req, "joints")
        joints = [model.joint(n) for n in names]
        frames = matrix(np, req, "frames", len(joints), nonempty=True)
        labels = field(req, "labels", None, required=False)
        if labels is not None:
            if not isinstance(labels, list) or not all(isinstance(x, str) for x in labels) or len(labels) != len(frames):
                raise request_error(f"'labels' must be a list of {len(frames)} strings (one per frame)")
        path = field(req, "path")
        if not isinstance(path, str) or not path:
            raise request_error(f"'path' must be a file path, not {json.dumps(path)}")
        ext = os.path.splitext(path)[1].lower()
        if ext not in RENDER_FORMATS:
            raise request_error(f"'path' {path!r} must end in .png (contact sheet), .gif or .mp4 (animation)")
        width = integer(req, "width", 320, 16, MAX_IMAGE_SIDE)
        height = integer(req, "height", 240, 16, MAX_IMAGE_SIDE)
        fps = number(req, "fps", 25, positive=True)
        columns = integer(req, "columns", 4, 1, 1000)
        if ext == ".mp4" and (width % 2 or height % 2):
            raise request_error(f"an MP4 (H.264, yuv420p) needs an even width and height, not {width}x{height}")
        directory = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(directory):
            raise request_error(f"cannot write {path}: the directory {directory} does not exist")
        if self.gl_problem is not None:
            raise self._gl_error(self.gl_problem)

        # The offscreen buffer bounds the image size; it only matters for rendering.
        m.vis.global_.offwidth = max(int(m.vis.global_.offwidth), width)
        m.vis.global_.offheight = max(int(m.vis.global_.offheight), height)
        try:
            renderer = mujoco.Renderer(m, height, width)
        except Exception as e:
            raise self._gl_error(f"{type(e).__name__}: {e}")
        try:
            poses = []
            for row in frames:
                model.set_joints(data, joints, row)
                mujoco.mj_forward(m, data)
                poses.append(data.qpos.copy())
            camera = self._camera(poses, width, height)
            images = []
            for qpos in poses:
                data.qpos[:] = qpos
                mujoco.mj_forward(m, data)
                renderer.update_scene(data, camera)
                images.append(renderer.render().copy())
        finally:
            renderer.close()
        if labels is not None:
            images = [_labelled(image, label) for image, label in zip(images, labels)]
        out = {"path": os.path.abspath(path), "frames": len(images), "gl": self.gl, "width": width, "height": height}
        try:
            if ext == ".png":
                out.update(_write_sheet(images, columns, path))
            elif ext == ".gif":
                _write_gif(images, fps, path)
            else:
                _write_mp4(images, fps, path)
        except OSError as e:
            raise request_error(f"cannot write {path}: {e}")
        return out

    def _camera(self, poses, width, height):
        """A fixed free camera, from the front-left and above, that sees every frame whole."""
        mujoco, np, model = self.mujoco, self.np, self.model
        m, data = model.m, model.scratch
        # Planes are infinite and would make the bounding box so; they are the floor anyway.
        solid = np.flatnonzero(m.geom_type != int(mujoco.mjtGeom.mjGEOM_PLANE))
        lo = np.full(3, np.inf)
        hi = np.full(3, -np.inf)
        for qpos in poses:
            data.qpos[:] = qpos
            mujoco.mj_kinematics(m, data)
            if solid.size:
                centers = data.geom_xpos[solid]
                radius = m.geom_rbound[solid][:, None]
                lo = np.minimum(lo, (centers - radius).min(axis=0))
                hi = np.maximum(hi, (centers + radius).max(axis=0))
        camera = mujoco.MjvCamera()
        camera.type = int(mujoco.mjtCamera.mjCAMERA_FREE)
        if np.isfinite(lo).all() and np.isfinite(hi).all():
            center = (lo + hi) / 2.0
            radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 1e-3)
        else:
            center = np.array(m.stat.center)
            radius = max(float(m.stat.extent), 1e-3)
        fovy = math.radians(float(m.vis.global_.fovy))
        fovx = 2.0 * math.atan(math.tan(fovy / 2.0) * width / height)
        camera.lookat[:] = center
        camera.distance = 1.1 * radius / math.sin(min(fovx, fovy) / 2.0)
        camera.azimuth = 135.0
        camera.elevation = -20.0
        return camera

    def _gl_error(self, detail):
        packages = GL_PACKAGES.get(self.gl, "")
        hint = f" (Debian/Ubuntu: apt install {packages})" if packages else ""
        return SimError(
            "render",
            f"no OpenGL context with MUJOCO_GL={self.gl}: {detail}{hint}",
            gl=self.gl,
            packages=packages,
        )


def _reject_constant(name):
    raise ValueError(f"{name} is not a number JSON allows")


def _labelled(image, label):
    from PIL import Image, ImageDraw, ImageFont

    picture = Image.fromarray(image)
    if not label:
        return picture
    draw = ImageDraw.Draw(picture, "RGBA")
    size = max(10, picture.height // 16)
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1 has only the fixed bitmap font
        font = ImageFont.load_default()
    left, top, right, bottom = draw.textbbox((4, 3), label, font=font)
    draw.rectangle((0, 0, right + 4, bottom + 3), fill=(0, 0, 0, 160))
    draw.text((4, 3), label, fill=(255, 255, 255, 255), font=font)
    return picture


def _pictures(images):
    from PIL import Image

    return [image if isinstance(image, Image.Image) else Image.fromarray(image) for image in images]


def _partial(path):
    # Written beside and renamed, so that nobody ever sees half a file under the real name.
    head, tail = os.path.split(os.path.abspath(path))
    return os.path.join(head, f".{tail}.{os.getpid()}.partial{os.path.splitext(tail)[1]}")


def _finish(partial, path):
    try:
        os.replace(partial, path)
    except OSError:
        _remove(partial)
        raise


def _remove(path):
    try:
        os.remove(path)
    except OSError:
        pass


def _write_sheet(images, columns, path):
    from PIL import Image

    pictures = _pictures(images)
    width, height = pictures[0].size
    columns = min(columns, len(pictures))
    rows = (len(pictures) + columns - 1) // columns
    sheet = Image.new("RGB", (columns * width, rows * height), (32, 32, 32))
    for index, picture in enumerate(pictures):
        sheet.paste(picture, ((index % columns) * width, (index // columns) * height))
    partial = _partial(path)
    try:
        sheet.save(partial, format="PNG")
    except Exception:
        _remove(partial)
        raise
    _finish(partial, path)
    return {"columns": columns, "rows": rows, "width": sheet.width, "height": sheet.height}


def _write_gif(images, fps, path):
    pictures = _pictures(images)
    partial = _partial(path)
    try:
        pictures[0].save(
            partial,
            format="GIF",
            save_all=True,
            append_images=pictures[1:],
            duration=max(10, int(round(1000.0 / fps))),
            loop=0,
        )
    except Exception:
        _remove(partial)
        raise
    _finish(partial, path)


def _write_mp4(images, fps, path):
    import imageio_ffmpeg

    np = sys.modules["numpy"]
    height, width = np.asarray(images[0]).shape[:2]
    partial = _partial(path)
    try:
        writer = imageio_ffmpeg.write_frames(
            partial,
            (width, height),
            fps=fps,
            codec="libx264",
            pix_fmt_in="rgb24",
            pix_fmt_out="yuv420p",
            macro_block_size=1,
            ffmpeg_log_level="error",
        )
        writer.send(None)
        for image in images:
            writer.send(np.ascontiguousarray(np.asarray(image), dtype=np.uint8))
        writer.close()
    except Exception:
        _remove(partial)
        raise
    _finish(partial, path)


def main():
    take_stdout()
    ignore_sigint()
    gl, gl_problem = choose_gl()
    try:
        import numpy
        import mujoco
        import PIL  # noqa: F401 (checked now so that a broken environment is reported at start)
        import imageio_ffmpeg  # noqa: F401
    except ImportError as e:
        return not_ready(f"missing Python package: {e}", missing=getattr(e, "name", None))
    except Exception as e:  # a package that is there but does not import (a broken library)
        return not_ready(
            f"importing MuJoCo failed with MUJOCO_GL={os.environ.get('MUJOCO_GL')}: {type(e).__name__}: {e}"
        )
    packages = {
        name: distribution_version(name)
        for name in ("mujoco", "mujoco-core", "numpy", "pyopengl", "pillow", "imageio-ffmpeg")
    }
    ready = {
        "ready": True,
        "mujoco": mujoco.__version__,
        "numpy": numpy.__version__,
        **interpreter(),
        "gl": gl,
        "packages": packages,
    }
    if gl_problem is not None:
        ready["gl_error"] = gl_problem
    harness = Harness(mujoco, numpy, gl, gl_problem)
    emit(ready)
    serve(harness)
    return 0


if __name__ == "__main__":
    sys.exit(main())
