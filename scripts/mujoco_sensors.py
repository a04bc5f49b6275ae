#!/usr/bin/env python3
"""Write MuJoCo's sensor readings (sensordata after mj_forward) as JSON, the truth
for our sensors.

Usage (from the repository root, with the project venv):

    .venv/bin/python scripts/mujoco_sensors.py

For tests/data/sensor_chain.xml and tests/data/sensor_box.xml, at the states
listed below (tau is qfrc_applied, ctrl = 0), writes
reference_models/golden/sensors/<name>.json: sensor_adr, sensor_dim and, per
state, q, v, tau and sensordata. tests/sensors.rs loads the same XML and
compares. Every number is a float written with repr(), so it reads back exactly.
"""

import json
import pathlib

import mujoco
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "reference_models" / "golden" / "sensors"


def chain_states(m):
    rng = np.random.default_rng(36)
    yield m.qpos0.copy(), np.zeros(m.nv), np.zeros(m.nv)
    for _ in range(2):
        q = m.qpos0 + 0.5 * rng.standard_normal(m.nq)
        yield q, 0.5 * rng.standard_normal(m.nv), rng.standard_normal(m.nv)


def box_states(m):
    # At rest slightly sunk into the floor, then tilted and sliding.
    yield np.array([0, 0, 0.099, 1, 0, 0, 0.0]), np.zeros(6), np.zeros(6)
    quat = np.array([0.999, 0.01, 0.02, 0.005])
    q = np.concatenate([[0.1, 0.2, 0.0995], quat / np.linalg.norm(quat)])
    yield q, np.array([0.1, -0.05, 0.0, 0.2, 0.1, -0.3]), np.array([1.0, 0, 0, 0, 0, 0.5])


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    for name, states in [("sensor_chain", chain_states), ("sensor_box", box_states)]:
        m = mujoco.MjModel.from_xml_path(str(ROOT / "tests" / "data" / f"{name}.xml"))
        d = mujoco.MjData(m)
        out = {"sensor_adr": m.sensor_adr.tolist(), "sensor_dim": m.sensor_dim.tolist(),
               "states": []}
        for q, v, tau in states(m):
            d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, v, tau
            mujoco.mj_forward(m, d)
            out["states"].append({"q": q.tolist(), "v": v.tolist(), "tau": tau.tolist(),
                                  "ncon": int(d.ncon), "sensordata": d.sensordata.tolist()})
        path = OUT / f"{name}.json"
        path.write_text(json.dumps(out, indent=1) + "\n")
        print(f"wrote {path.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
