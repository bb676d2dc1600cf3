"""The arm behind emulated servos (keypose virtual-bus --physics): the loaded model stepped in
time with the bus, each joint driven by its servo's motor as the servo's firmware commands it.

keypose's emulated servos keep their registers and their firmware's rules; what they ask of
their motors arrives here with each `servos_step` request: per joint whether the motor is
driven, the goal, the firmware's profile bounds and the drive (stiffness, force bound, the
torque-speed line's slope as damping). The motor is the same one `run` uses (a position loop
of stiffness kp bounded by +-force, minus the line's slope times the speed): a saturated servo
runs along its torque-speed line. A limp motor drives nothing and brakes nothing (its windings
are open): its joint keeps only its gear train's friction and the rotor's inertia, so a limp
arm falls under gravity as a real one does.

Between the goals the firmware's profile generator moves each setpoint (sim_profile), stepped
with the physics. The reply gives each joint's position, velocity, the loop's output (the
motor's drive, as a share of its full supply it is what a servo's load register reports) and
the torque the motor gives at its shaft, so that keypose can fill the present registers and
run the servo's protection. Nothing here knows about vendors or registers.
"""

import time

from harness_io import member
from sim_profile import ServoProfile
from sim_requests import SimError, is_number, request_error, string_list, vector

# Bounds standing in for "none" in the profile generator: finite, so that it never computes
# inf - inf.
UNBOUNDED = 1e12
# A hand holding a link (`virtual-bus --hand`): a critically damped spring towards where the hand
# goes, of this bandwidth (rad/s) on each joint's own inertia, its effort bounded as a person's
# grip is (N·m, or N on a slide joint). A firm grip, not a measured one: UNVERIFIED.
HAND_BANDWIDTH = 40.0
HAND_MOST = 3.0
DRIVE_KEYS = ("kp", "force", "damping")


class BusPhysics:
    """The joints of one emulated bus, their motors and their profile generator."""

    def __init__(self, mujoco, np, model, req):
        self.mujoco, self.np, self.model = mujoco, np, model
        m = model.m
        names = string_list(req, "joints")
        self.joints = [model.joint(n) for n in names]
        for joint_name, j in zip(names, self.joints):
            if j not in model.joint_actuators:
                raise request_error(f"joint {joint_name!r} has no position actuator in {model.path}: an emulated servo drives a joint through one")
        self.names = names
        self.qadr = np.array([m.jnt_qposadr[j] for j in self.joints], dtype=np.intp)
        self.vadr = np.array([m.jnt_dofadr[j] for j in self.joints], dtype=np.intp)
        self.actuators = [model.joint_actuators[j] for j in self.joints]
        initial = np.array(vector(member(req, "qpos"), len(self.joints), "'qpos'"), dtype=float)
        # The joints' own damping and friction from the model: what a limp joint keeps of
        # them is its friction.
        self.steps = 0
        self.wall = 0.0
        d = model.data
        mujoco.mj_resetData(m, d)
        d.qpos[self.qadr] = initial
        d.qvel[:] = 0.0
        self.profile = ServoProfile(np, np.full(len(self.joints), UNBOUNDED), np.full(len(self.joints), UNBOUNDED), initial)
        self._hold_others()
        mujoco.mj_forward(m, d)
        self._settle(req)

    def _settle(self, req):
        """With "settle": S, the limp arm first falls for S seconds to where it comes to rest,
        as an arm lies when it is switched on; the clock then starts at 0 there."""
        settle = req.get("settle", 0.0)
        if not is_number(settle) or settle < 0:
            raise request_error(f"'settle' must be a number of seconds of at least 0, not {settle!r}")
        if settle == 0:
            return
        m, d = self.model.m, self.model.data
        self._apply([{"on": False, "goal": 0.0, "kp": 0.0, "force": 0.0, "damping": 0.0} for _ in self.joints])
        self.mujoco.mj_step(m, d, int(round(settle / m.opt.timestep)))
        d.time = 0.0
        d.qvel[:] = 0.0
        self.profile.p = d.qpos[self.qadr].copy()

    def _hold_others(self):
        """Position actuators of joints no servo of the bus drives hold them where they are."""
        m, d = self.model.m, self.model.data
        ours = set(self.joints)
        for info in self.model.actuators:
            if info["joint"] not in ours:
                d.ctrl[info["ctrl"]] = info["gear"] * d.qpos[m.jnt_qposadr[info["joint"]]]

    def step(self, req):
        """Steps until the simulation clock reaches `until`, with the motors as `drives` say."""
        np, m, d = self.np, self.model.m, self.model.data
        until = member(req, "until")
        if not is_number(until):
            raise request_error(f"'until' must be a number of seconds, not {until!r}")
        drives = member(req, "drives")
        if not isinstance(drives, list) or len(drives) != len(self.joints):
            raise request_error(f"'drives' must list {len(self.joints)} drives, one per joint of the bus")
        goals, acceleration, velocity, driven = self._apply(drives)
        hand = self._hand(drives)
        self.profile.a, self.profile.vmax = acceleration, velocity
        dt = m.opt.timestep
        started = time.process_time()
        steps = 0
        ctrl = d.ctrl
        # Driven joints' setpoints go to each of their position actuators (times its gear).
        targets = [(c, info["ctrl"], info["gear"]) for c, infos in enumerate(self.actuators) for info in infos]
        applied = d.qfrc_applied
        while d.time + 0.5 * dt < until:
            setpoint = self.profile.step(goals, dt)
            for column, index, gear in targets:
                ctrl[index] = gear * setpoint[column]
            if hand is not None:
                held, target, stiffness, damping = hand
                pull = stiffness * (target - d.qpos[self.qadr]) - damping * d.qvel[self.vadr]
                applied[self.vadr] = np.where(held, np.clip(pull, -HAND_MOST, HAND_MOST), 0.0)
            self.mujoco.mj_step(m, d)
            steps += 1
            if not np.all(np.isfinite(d.qpos[self.qadr])):
                raise SimError("internal", f"the physics diverged at t = {d.time:.4f} s")
        # A limp joint's setpoint follows its shaft, so that torque back on holds there.
        position = d.qpos[self.qadr].copy()
        self.profile.p = np.where(driven, self.profile.p, position)
        self.profile.v = np.where(driven, self.profile.v, 0.0)
        self.steps += steps
        self.wall += time.process_time() - started
        return self._state(steps, position)

    def _hand(self, drives):
        """The hand's hold on each joint (None: no hand anywhere): which joints it holds, where
        it pulls them, and each joint's spring and damper for HAND_BANDWIDTH on its inertia."""
        np, m = self.np, self.model.m
        targets = [drive.get("hand") for drive in drives]
        if all(t is None for t in targets):
            self.model.data.qfrc_applied[self.vadr] = 0.0
            return None
        for c, t in enumerate(targets):
            if t is not None and not is_number(t):
                raise request_error(f"drives[{c}] ({self.names[c]}).hand must be a number or null, not {t!r}")
        held = np.array([t is not None for t in targets])
        target = np.array([0.0 if t is None else float(t) for t in targets])
        # dof_invweight0: the inverse of each joint's inertia at qpos0, as MuJoCo computes it.
        inertia = 1.0 / np.maximum(m.dof_invweight0[self.vadr], 1e-9)
        return held, target, inertia * HAND_BANDWIDTH**2, 2.0 * inertia * HAND_BANDWIDTH

    def _apply(self, drives):
        """Sets each joint's motor from its drive; returns the goals, the profile bounds and
        which joints are driven."""
        np, m = self.np, self.model.m
        n = len(self.joints)
        goals, acceleration, velocity = np.zeros(n), np.full(n, UNBOUNDED), np.full(n, UNBOUNDED)
        driven = np.zeros(n, dtype=bool)
        self.damping = np.zeros(n)
        for c, (drive, j) in enumerate(zip(drives, self.joints)):
            where = f"drives[{c}] ({self.names[c]})"
            if not isinstance(drive, dict):
                raise request_error(f"{where} must be an object")
            on = drive.get("on")
            if not isinstance(on, bool):
                raise request_error(f"{where}.on must be true or false")
            values = {}
            for key in DRIVE_KEYS:
                value = drive.get(key)
                if not is_number(value) or value < 0:
                    raise request_error(f"{where}.{key} must be a number of at least 0, not {value!r}")
                values[key] = float(value)
            goal = drive.get("goal")
            if not is_number(goal):
                raise request_error(f"{where}.goal must be a number, not {goal!r}")
            goals[c] = goal
            for key, out in (("acceleration", acceleration), ("velocity", velocity)):
                bound = drive.get(key)
                if bound is not None:
                    if not is_number(bound) or bound <= 0:
                        raise request_error(f"{where}.{key} must be a positive number or null, not {bound!r}")
                    out[c] = float(bound)
            driven[c] = on
            kp = values["kp"] if on else 0.0
            force = values["force"] if on else 0.0
            for info in self.actuators[c]:
                a = info["id"]
                m.actuator_gainprm[a, 0] = kp
                m.actuator_biasprm[a, 1] = -kp
                m.actuator_forcelimited[a] = 1
                m.actuator_forcerange[a] = [-force, force]
            # The torque-speed line is the driven motor's back-EMF: open windings have none.
            self.damping[c] = values["damping"] if on else 0.0
            m.dof_damping[m.jnt_dofadr[j]] = self.damping[c]
        return goals, acceleration, velocity, driven

    def _state(self, steps, position):
        np, d = self.np, self.model.data
        velocity = d.qvel[self.vadr]
        loop = np.zeros(len(self.joints))
        for c, infos in enumerate(self.actuators):
            loop[c] = sum(float(d.actuator_force[info["out"]]) * info["gear"] for info in infos)
        return {
            "time": float(d.time),
            "q": [float(v) for v in position],
            "v": [float(v) for v in velocity],
            "loop": [float(v) for v in loop],
            "torque": [float(v) for v in loop - self.damping * velocity],
            "steps": steps,
            # Processor seconds the stepping took so far, and the seconds it simulated.
            "wall": self.wall,
            "simulated": self.steps * self.model.m.opt.timestep,
        }
