"""A cell's scene: several arms' MJCF models composed into one MuJoCo model with MjSpec, each
arm attached at its base frame under a name prefix ("left/"), so that its joints, bodies and
actuators are named "left/shoulder_pan" as keypose names a cell's joints.

The scene has one floor and one light of its own; the arms' own floors, lights and keyframes
are left out (each model brings them for being simulated alone). Each arm keeps its contact
exclusions, renamed with its prefix by MjSpec; nothing excludes one arm's bodies from
another's. The timestep is the smallest of the arms' models, the integrator and the headlight
the first arm's.

It knows nothing about runs, rendering or the request loop.
"""

import json

from sim_requests import SimError, is_number, request_error

# The floor every built-in model draws (sim/models/*.xml), drawn once for the whole cell.
FLOOR_RGB = ([0.32, 0.34, 0.36], [0.26, 0.28, 0.3])


def arm_requests(req):
    """The load request's "arms": [{"name", "mjcf", "pos": [x, y, z], "quat": [w, x, y, z]}],
    checked."""
    arms = req.get("arms")
    if not isinstance(arms, list) or not arms:
        raise request_error("'arms' must be a non-empty list of {name, mjcf, pos, quat}")
    names = set()
    for index, arm in enumerate(arms):
        where = f"arms[{index}]"
        if not isinstance(arm, dict):
            raise request_error(f"{where} must be an object, not {json.dumps(arm)[:200]}")
        name = arm.get("name")
        if not isinstance(name, str) or not name or "/" in name:
            raise request_error(f"{where}.name must be a non-empty name without '/', not {json.dumps(name)}")
        if name in names:
            raise request_error(f"{where}.name {name!r} appears twice: each arm once")
        names.add(name)
        if not isinstance(arm.get("mjcf"), str) or not arm["mjcf"]:
            raise request_error(f"{where}.mjcf must be a path, not {json.dumps(arm.get('mjcf'))}")
        for member, length in (("pos", 3), ("quat", 4)):
            value = arm.get(member)
            if not isinstance(value, list) or len(value) != length or not all(is_number(v) for v in value):
                raise request_error(f"{where}.{member} must be {length} finite numbers, not {json.dumps(value)[:200]}")
    return arms


def compose(mujoco, arms, objects=None):
    """The compiled scene of `arms` (as arm_requests checks them), with the bodies of the
    `objects` file when given (add_objects), and each arm's root bodies' names in it: {arm
    name: [body name, ...]}."""
    scene = mujoco.MjSpec()
    roots = {}
    for index, arm in enumerate(arms):
        child = _arm_spec(mujoco, arm)
        if index == 0:
            _take_settings(scene, child)
        # The finest timestep any arm's model asks for keeps every arm's physics stable.
        scene.option.timestep = min(scene.option.timestep, child.option.timestep)
        prefix = arm["name"] + "/"
        roots[arm["name"]] = [prefix + body.name for body in _root_bodies(child)]
        frame = scene.worldbody.add_frame(pos=arm["pos"], quat=arm["quat"])
        try:
            scene.attach(child, prefix=prefix, frame=frame)
        except Exception as e:  # MuJoCo raises ValueError when the arm cannot be attached
            raise SimError("model", f"cannot attach {arm['mjcf']} as arm {arm['name']}: {e}".rstrip())
    _add_floor(mujoco, scene)
    if objects is not None:
        add_objects(mujoco, scene, objects)
    try:
        model = scene.compile()
    except Exception as e:  # MuJoCo raises ValueError for compile errors
        raise SimError("model", f"cannot compose the arms {', '.join(a['name'] for a in arms)}: {e}".rstrip())
    return model, roots


def with_objects(mujoco, path, objects):
    """One model (`path`) with the bodies of the `objects` file, compiled."""
    try:
        spec = mujoco.MjSpec.from_file(path)
    except Exception as e:
        raise SimError("model", f"cannot load {path}: {e}".rstrip())
    add_objects(mujoco, spec, objects)
    try:
        return spec.compile()
    except Exception as e:  # MuJoCo raises ValueError for compile errors
        raise SimError("model", f"cannot add the objects of {objects} to {path}: {e}".rstrip())


def add_objects(mujoco, spec, objects):
    """Attaches the world body of the MJCF file `objects` (a block to pick, a fixture, a wall)
    to `spec`'s world under the prefix "scene/": its bodies are environment to the contact
    classes, as anything not of the arm is. Its own floors and lights are left out: the model
    has its floor."""
    try:
        child = mujoco.MjSpec.from_file(objects)
    except Exception as e:
        raise SimError("model", f"cannot load the scene {objects}: {e}".rstrip())
    _without_floor_and_lights(mujoco, child)
    frame = spec.worldbody.add_frame()
    try:
        spec.attach(child, prefix="scene/", frame=frame)
    except Exception as e:  # MuJoCo raises ValueError when the scene cannot be attached
        raise SimError("model", f"cannot attach the scene {objects}: {e}".rstrip())


def _without_floor_and_lights(mujoco, spec):
    """Deletes `spec`'s floors (planes, or geoms named floor) and lights: the scene has its own."""
    plane = mujoco.mjtGeom.mjGEOM_PLANE
    for geom in list(spec.worldbody.geoms):
        if geom.type == plane or geom.name == "floor":
            spec.delete(geom)
    for light in list(spec.worldbody.lights):
        spec.delete(light)


def _arm_spec(mujoco, arm):
    """The arm's model without what the scene has once: floors, lights and keyframes (whose
    qpos would be one arm's, not the scene's)."""
    path = arm["mjcf"]
    try:
        spec = mujoco.MjSpec.from_file(path)
    except Exception as e:
        raise SimError("model", f"cannot load {path} (arm {arm['name']}): {e}".rstrip())
    _without_floor_and_lights(mujoco, spec)
    for key in list(spec.keys):
        spec.delete(key)
    return spec


def _root_bodies(spec):
    """The bodies on the arm's world body, each given a name if it has none, so that the
    scene can tell which arm a body belongs to."""
    bodies = list(spec.worldbody.bodies)
    for index, body in enumerate(bodies):
        if not body.name:
            body.name = f"root{index}"
    return bodies


def _take_settings(scene, first):
    """The physics and the look of the first arm's model."""
    scene.option.timestep = first.option.timestep
    scene.option.integrator = first.option.integrator
    scene.visual.headlight.ambient = first.visual.headlight.ambient
    scene.visual.headlight.diffuse = first.visual.headlight.diffuse
    scene.visual.headlight.specular = first.visual.headlight.specular


def _add_floor(mujoco, scene):
    scene.add_texture(
        name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=FLOOR_RGB[0], rgb2=FLOOR_RGB[1], width=256, height=256,
        mark=mujoco.mjtMark.mjMARK_EDGE, markrgb=[0.4, 0.42, 0.44],
    )
    material = scene.add_material(name="grid", texrepeat=[8, 8], texuniform=True, reflectance=0.1)
    material.textures[int(mujoco.mjtTextureRole.mjTEXROLE_RGB)] = "grid"
    scene.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], material="grid")
    scene.worldbody.add_light(name="top", pos=[0, 0, 1.2], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, diffuse=[0.5, 0.5, 0.5])
