#!/usr/bin/env python3
"""Bare MuJoCo, the peer of `cargo bench --bench sim`: the same model and the same commands as
`keypose sim`, stepped by MuJoCo alone, timed by this script.

    python bare_mujoco.py COMMANDS.json

COMMANDS.json (written by benches/sim.rs):
    {"mjcf": PATH, "joints": [NAME, ...], "control_hz": HZ,
     "initial": [RAD, ...], "commands": [[RAD, ...], ...]}

Each joint's position actuator (named as the joint, gear 1 in the vendored models) gets the
row's value; MuJoCo steps one control period per row (the model's timestep: 2 ms, so 5 steps at
100 Hz), as sim/sim_run.py does, but nothing is recorded and nothing is checked: this is the
cost of the physics and of a Python loop around it, nothing of keypose's.

Prints one JSON line: {"import_s", "input_s", "load_s", "run_s", "rows", "simulated_s"}, each
time measured from the previous point (the first from the script's start, after the
interpreter's own start-up, which only the caller's wall clock sees).
"""

import json
import sys
import time

started = time.perf_counter()

import mujoco  # noqa: E402 (timed)
import numpy as np  # noqa: E402

imported = time.perf_counter()


def main():
    with open(sys.argv[1]) as f:
        request = json.load(f)
    commands = np.array(request["commands"], dtype=float)
    initial = np.array(request["initial"], dtype=float)
    read = time.perf_counter()

    model = mujoco.MjModel.from_xml_path(request["mjcf"])
    data = mujoco.MjData(model)
    qadr = [model.jnt_qposadr[model.joint(name).id] for name in request["joints"]]
    ctrl = [model.actuator(name).id for name in request["joints"]]
    for a in ctrl:
        if model.actuator_gear[a][0] != 1.0:
            raise SystemExit(f"actuator {model.actuator(a).name} has gear {model.actuator_gear[a][0]}, expected 1")
    steps = int(round(1.0 / (request["control_hz"] * model.opt.timestep)))
    mujoco.mj_resetData(model, data)
    data.qpos[qadr] = initial
    data.ctrl[ctrl] = initial
    mujoco.mj_forward(model, data)
    loaded = time.perf_counter()

    step = mujoco.mj_step
    for row in commands:
        data.ctrl[ctrl] = row
        step(model, data, steps)
    ran = time.perf_counter()

    print(
        json.dumps(
            {
                "import_s": imported - started,
                "input_s": read - imported,
                "load_s": loaded - read,
                "run_s": ran - loaded,
                "rows": len(commands),
                "simulated_s": data.time,
            }
        )
    )


if __name__ == "__main__":
    main()
