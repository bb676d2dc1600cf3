#!/usr/bin/env python3
"""keypose's MuJoCo harness: kinematics, simulated runs of keyframe sequences, and renders.

keypose (Rust) runs one of these processes and speaks JSON lines with it: one request object
per line on stdin, one reply object per line on stdout, flushed after each reply. The protocol
is sim/PROTOCOL.md; in short:

    ready line   {"ready": true, "mujoco": V, "numpy": V, "python": V, "gl": "egl", ...}
                 or {"ready": false, "error": TEXT, "missing": MODULE}
    ping         {"op": "ping"} -> {"ok": true}
    load         {"op": "load", "mjcf": PATH}
                 or a cell's scene: {"op": "load", "arms": [{"name", "mjcf", "pos", "quat"}, ...]}
    kinematics   {"op": "kinematics", "qpos": {JOINT: VALUE}, "sites": [SITE, ...]}
    contacts     {"op": "contacts", "qpos": {JOINT: VALUE}}  (one pose, no dynamics)
    run          {"op": "run", "joints": [...], "control_hz": HZ, "initial": [...], "commands": [[...]]}
    servos_start {"op": "servos_start", "joints": [...], "qpos": [...]}  (emulated servos' arm)
    servos_step  {"op": "servos_step", "until": T, "drives": [{on, goal, kp, force, damping, ...}]}
    render       {"op": "render", "frames": [[...]], "joints": [...], "labels": [...], "path": P,
                  "width": W, "height": H, "fps": F, "columns": C}

A "seq" member is echoed in the reply. Errors are {"ok": false, "kind": K, "error": TEXT} with K
one of "request" (malformed or invalid request, including an output file that cannot be
written), "state" (no model loaded), "model" (the MJCF does not load), "render" (no GL context:
the reply also carries "gl" and "packages", the Debian packages that provide that backend) or
"internal"; the process goes on after any of them.

MUJOCO_GL=disable starts a harness for physics only: MuJoCo imports none of its rendering, and
a render request is a "render" error.

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

This file is the request loop; the work is done apart, each module knowing nothing of the
others' concerns: sim_model (the loaded model, kinematics), sim_scene (a cell's arms in one
scene), sim_run (runs), sim_render and
sim_images (renders), sim_requests (checks of request members), harness_io (the line protocol,
shared with sdk_bridge.py). keypose writes them all beside this file.
"""

import json
import os
import sys

from harness_io import describe_exception, distribution_version, emit, handle_line, ignore_sigint, interpreter, not_ready, serve, take_stdout
from sim_model import load_model
from sim_render import PHYSICS_ONLY, Renderer, choose_gl
from sim_requests import SimError, reject_constant, request_error
from sim_run import Simulator
from sim_servos import BusPhysics


class Harness:
    """The request loop's state: the loaded model, the simulator and the renderer."""

    def __init__(self, mujoco, np, gl, gl_problem):
        self.mujoco = mujoco
        self.np = np
        self.model = None
        # The arm behind emulated servos (sim_servos), once servos_start made it.
        self.bus = None
        self.sim = Simulator(mujoco, np)
        self.renderer = Renderer(mujoco, np, gl, gl_problem)

    def handle_line(self, line):
        return handle_line(
            line,
            self.dispatch,
            # NaN and Infinity are not JSON: refused here rather than simulated.
            parse=lambda text: json.loads(text, parse_constant=reject_constant),
            shown=lambda req: json.dumps(req)[:200],
            describe=self._describe_exception,
        )

    def _describe_exception(self, e):
        if isinstance(e, self.mujoco.FatalError):
            return f"MuJoCo: {e}"
        return describe_exception(e)

    def dispatch(self, req):
        op = req.get("op")
        if op == "ping":
            return {}
        if op == "load":
            return self.load(req)
        if op in ("kinematics", "contacts", "distances", "inverse", "drive", "run", "render", "servos_start", "servos_step"):
            if self.model is None:
                raise SimError("state", f"{op}: no model loaded (send 'load' first)")
            if op == "kinematics":
                return self.model.kinematics(req)
            if op == "contacts":
                return self.sim.pose_contacts(self.model, req)
            if op == "distances":
                return self.sim.pose_distances(self.model, req)
            if op == "inverse":
                return self.sim.pose_inverse(self.model, req)
            if op == "drive":
                return self.model.set_drives(req)
            if op == "run":
                return self.sim.run(self.model, req)
            if op == "servos_start":
                self.bus = BusPhysics(self.mujoco, self.np, self.model, req)
                self.sim.can_continue = False
                return {"time": 0.0}
            if op == "servos_step":
                if self.bus is None:
                    raise SimError("state", "servos_step: no emulated servos (send 'servos_start' after 'load')")
                return self.bus.step(req)
            return self.renderer.render(self.model, req)
        raise request_error(f"unknown op {json.dumps(op)} (known: ping, load, kinematics, contacts, distances, inverse, drive, run, render, servos_start, servos_step)")

    def load(self, req):
        warnings = self.sim.warnings
        del warnings[:]
        self.model = load_model(self.mujoco, self.np, req)
        self.bus = None
        self.sim.can_continue = False
        reply = self.model.describe()
        if warnings:
            reply["warnings"] = list(warnings)
        return reply


def main():
    take_stdout()
    ignore_sigint()
    gl, gl_problem = choose_gl()
    # The harness does no sizeable linear algebra: one BLAS thread, so that importing numpy
    # starts no pool of threads (a tenth of the import on a 2-core machine, more on larger
    # ones). A value the user set is kept.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    try:
        import numpy
        import mujoco

        if gl != PHYSICS_ONLY:
            # Checked now so that a broken environment is reported at start, not at a render.
            import PIL  # noqa: F401
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
    status = main()
    # Every reply is written and flushed: end without the interpreter's teardown of numpy and
    # MuJoCo, which takes a tenth of a second or more that keypose would wait for.
    sys.stderr.flush()
    os._exit(status)
