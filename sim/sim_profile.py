"""The servos' own motion profile (keypose play --servo-profile): each position servo follows
its goal no faster than its acceleration limit allows, and no faster than its velocity limit
when it has one, as an STS3215 with its Acceleration register or a Dynamixel X with
Profile_Acceleration and Profile_Velocity does between the goals it is sent.

The profile is advanced every physics step: towards the goal at the highest speed from which
it can still stop at the goal within the acceleration limit (sqrt(2·a·distance)), capped by
the velocity limit, changing its velocity by at most a·dt a step. The position actuator is
given the profile's position instead of the raw goal.
"""

from sim_requests import request_error, vector


class ServoProfile:
    def __init__(self, np, acceleration, velocity, position):
        self.np = np
        self.a = np.asarray(acceleration, dtype=float)
        self.vmax = np.asarray(velocity, dtype=float)
        self.p = np.array(position, dtype=float)
        self.v = np.zeros_like(self.p)

    def step(self, goal, dt):
        """Advances the profile by dt towards `goal` and returns its position."""
        np = self.np
        error = goal - self.p
        stopping = np.sign(error) * np.sqrt(2.0 * self.a * np.abs(error))
        wanted = np.clip(stopping, -self.vmax, self.vmax)
        self.v += np.clip(wanted - self.v, -self.a * dt, self.a * dt)
        step = self.v * dt
        # Never step past the goal: arriving, the profile stops there.
        past = np.abs(step) >= np.abs(error)
        self.p = np.where(past, goal, self.p + step)
        self.v = np.where(past, 0.0, self.v)
        return self.p


def profile_limits(np, req, joints):
    """The request's optional "profile": per joint, "acceleration" (> 0) and "velocity" (> 0 or
    null for none), in the model's units (rad or m, per second); None when absent."""
    spec = req.get("profile")
    if spec is None:
        return None
    if not isinstance(spec, dict):
        raise request_error("'profile' must be an object with 'acceleration' and 'velocity' lists")
    acceleration = vector(spec.get("acceleration"), joints, "'profile.acceleration'")
    raw_velocity = spec.get("velocity", [None] * joints)
    if not isinstance(raw_velocity, list) or len(raw_velocity) != joints:
        raise request_error(f"'profile.velocity' must list {joints} values (numbers or null)")
    # Checked as numbers with the nulls standing in as 1, then the nulls become no limit.
    vector([1.0 if v is None else v for v in raw_velocity], joints, "'profile.velocity'")
    velocity = [float("inf") if v is None else v for v in raw_velocity]
    if any(not a > 0 for a in acceleration) or any(not v > 0 for v in velocity):
        raise request_error("'profile' limits must be positive")
    return np.asarray(acceleration, dtype=float), np.asarray(velocity, dtype=float)
