"""A loaded MJCF model: its joints, sites, position servos and contact classes, looked up once,
and the queries on it that need no simulation (describing it, forward kinematics).

It knows nothing about runs, rendering or the request loop.
"""

import json
import math

from harness_io import member
from sim_requests import SimError, is_number, request_error, string_list
from sim_scene import arm_requests, compose, with_objects


class Model:
    """A loaded MJCF model with the lookups the requests need, computed once."""

    def __init__(self, mujoco, np, path, model, arm_roots=None):
        self.mujoco = mujoco
        self.np = np
        self.path = path
        self.m = m = model
        # A cell's scene (sim_scene): each arm's root bodies by arm name; None for one model.
        self.arm_roots = arm_roots
        # Autoreset would make a diverging trace jump back to qpos0 without a trace of why.
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        self.data = mujoco.MjData(m)
        self.scratch = mujoco.MjData(m)
        self._index_names()
        self._index_servos()
        self._classify_contacts()

    def _name(self, obj, index, fallback):
        found = self.mujoco.mj_id2name(self.m, obj, index)
        return found if found else f"{fallback}#{index}"

    def _index_names(self):
        """The addressable joints (named hinges and slides), the bodies and the named sites."""
        m, mujoco = self.m, self.mujoco
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
        self.body_names = [self._name(mujoco.mjtObj.mjOBJ_BODY, b, "body") for b in range(m.nbody)]
        self.site_ids = {}
        for s in range(m.nsite):
            site_name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, s)
            if site_name:
                self.site_ids[site_name] = s

    def _index_servos(self):
        """Position servos on joints: gain kp, bias -kp*length (and possibly -kv*velocity)."""
        m, mujoco = self.m, self.mujoco
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
        self.actuator_reply = self.describe_actuators()

    def describe_actuators(self):
        """The position servos as the load reply lists them."""
        m, mujoco = self.m, self.mujoco
        return [
            {
                "name": self._name(mujoco.mjtObj.mjOBJ_ACTUATOR, info["id"], "actuator"),
                "joint": mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, info["joint"]),
                "kp": float(m.actuator_gainprm[info["id"], 0]),
                "kv": float(-m.actuator_biasprm[info["id"], 2]),
                "gear": info["gear"],
                "forcerange": [float(v) for v in m.actuator_forcerange[info["id"]]],
                "forcelimited": bool(m.actuator_forcelimited[info["id"]]),
            }
            for info in self.actuators
        ]

    def _classify_contacts(self):
        """Which geoms are floor and which bodies are the robot's.

        The robot is the kinematic trees its actuated joints are in (or every tree that moves,
        in a model without actuators); everything else attached to the world is environment.
        """
        m, mujoco, np = self.m, self.mujoco, self.np
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
        # In a cell, the arm each body belongs to (None: the world's); robot bodies of two
        # different arms touching is a collision between arms, not a self-collision.
        self.body_arm = [None] * m.nbody
        self.arm_order = {arm: index for index, arm in enumerate(self.arm_roots or {})}
        for arm, names in (self.arm_roots or {}).items():
            arm_root_ids = {mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name) for name in names}
            for b in range(m.nbody):
                if int(m.body_rootid[b]) in arm_root_ids:
                    self.body_arm[b] = arm

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

    def set_drives(self, req):
        """Makes named joints' position actuators and joint parameters the servos keypose's
        catalogue says they are ("joints": {joint: {kp, force, damping, armature,
        frictionloss}}, in the joint's units): the actuator a pure position loop of stiffness kp
        bounded by +-force, the joint's damping the slope of the torque-speed line. A joint
        without a position actuator is refused."""
        m = self.m
        joints = member(req, "joints")
        if not isinstance(joints, dict):
            raise request_error(f"'joints' must be an object of joint: drive, not {json.dumps(joints)[:200]}")
        for joint_name, drive in joints.items():
            j = self.joint(joint_name)
            if j not in self.joint_actuators:
                raise request_error(f"joint {joint_name!r} has no position actuator in {self.path}")
            values = {}
            for key in ("kp", "force", "damping", "armature", "frictionloss"):
                value = drive.get(key) if isinstance(drive, dict) else None
                if not is_number(value) or value < 0:
                    raise request_error(f"drive of {joint_name!r}: {key} must be a number of at least 0, not {json.dumps(value)}")
                values[key] = float(value)
            for info in self.joint_actuators[j]:
                a = info["id"]
                m.actuator_gainprm[a, 0] = values["kp"]
                m.actuator_biasprm[a, 1] = -values["kp"]
                m.actuator_biasprm[a, 2] = 0.0
                m.actuator_forcelimited[a] = 1
                m.actuator_forcerange[a] = [-values["force"], values["force"]]
            dof = m.jnt_dofadr[j]
            m.dof_damping[dof] = values["damping"]
            m.dof_armature[dof] = values["armature"]
            m.dof_frictionloss[dof] = values["frictionloss"]
        self.actuator_reply = self.describe_actuators()
        return {"actuators": self.actuator_reply}

    def set_request_qpos(self, data, req):
        """Sets `data`'s qpos from a request's "qpos" object (joint: value); others at qpos0."""
        qpos = member(req, "qpos")
        if not isinstance(qpos, dict):
            raise request_error(f"'qpos' must be an object of joint: value, not {json.dumps(qpos)[:200]}")
        ids, values = [], []
        for joint_name, value in qpos.items():
            ids.append(self.joint(joint_name))
            if not is_number(value):
                raise request_error(f"qpos of {joint_name!r} must be a finite number, not {json.dumps(value)}")
            values.append(float(value))
        self.set_joints(data, ids, values)

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
        reply = {
            "timestep": float(m.opt.timestep),
            "joints": joints,
            "actuators": self.actuator_reply,
            "bodies": self.body_names,
            "sites": list(self.site_ids),
        }
        if self.arm_roots is not None:
            reply["arms"] = {arm: [name for b, name in enumerate(self.body_names) if self.body_arm[b] == arm] for arm in self.arm_roots}
        return reply

    def kinematics(self, req):
        """Forward kinematics at the given joint values: joint anchors and axes, site positions."""
        model = self
        mujoco, m, data = self.mujoco, model.m, model.scratch
        model.set_request_qpos(data, req)
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


def load_model(mujoco, np, req):
    """The model of a load request's "mjcf" file, or the scene of its "arms" (a cell,
    sim_scene); a "model" error when MuJoCo refuses it."""
    objects = req.get("scene")
    if objects is not None and (not isinstance(objects, str) or not objects):
        raise request_error(f"'scene' must be the path of an MJCF file of objects, not {json.dumps(objects)}")
    if "arms" in req:
        arms = arm_requests(req)
        model, roots = compose(mujoco, arms, objects)
        return Model(mujoco, np, ", ".join(f"{a['name']}={a['mjcf']}" for a in arms), model, roots)
    path = member(req, "mjcf")
    if not isinstance(path, str) or not path:
        raise request_error(f"'mjcf' must be a path, not {json.dumps(path)}")
    if objects is not None:
        return Model(mujoco, np, path, with_objects(mujoco, path, objects))
    try:
        model = mujoco.MjModel.from_xml_path(path)
    except Exception as e:  # MuJoCo raises ValueError for XML and compile errors
        raise SimError("model", f"cannot load {path}: {e}".rstrip())
    return Model(mujoco, np, path, model)
