"""Step timings of MuJoCo on our reference models, next to ours from criterion.

Run by `make bench` after `cargo bench --bench step`: times MuJoCo's mj_step on
the same MJCF files with contacts disabled (our engine has no contact yet),
reads criterion's estimates for our step, and writes the ratio table to
reports/bench-step.md. MuJoCo is timed with mj_step(..., nstep=N), a loop in C,
so no Python call overhead enters its figure.
"""
import json
import pathlib
import time

import mujoco
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
MODELS = ["cartpole", "half_cheetah"]


def mujoco_step_seconds(name, nstep=20000, repeats=7):
    model = mujoco.MjModel.from_xml_path(str(ROOT / "reference_models" / f"{name}.xml"))
    # Contacts off: the comparison is of contact-free articulated dynamics.
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    data = mujoco.MjData(model)
    times = []
    for _ in range(repeats):
        mujoco.mj_resetData(model, data)
        start = time.perf_counter()
        mujoco.mj_step(model, data, nstep=nstep)
        times.append((time.perf_counter() - start) / nstep)
    return float(np.median(times))


def ours_seconds(name):
    path = ROOT / "target" / "criterion" / f"step_{name}" / "new" / "estimates.json"
    if not path.exists():
        raise SystemExit(f"{path} missing: run `cargo bench --bench step` first")
    return json.loads(path.read_text())["median"]["point_estimate"] * 1e-9


def main():
    rows = []
    for name in MODELS:
        theirs, ours = mujoco_step_seconds(name), ours_seconds(name)
        rows.append(f"| {name} | {ours * 1e6:.3f} | {theirs * 1e6:.3f} | {theirs / ours:.2f}x |")
    table = "\n".join(
        [
            "| model (contacts off) | diffosi step (µs) | MuJoCo mj_step (µs) | MuJoCo time / ours |",
            "|---|---|---|---|",
            *rows,
        ]
    )
    out = ROOT / "reports" / "bench-step.md"
    out.parent.mkdir(exist_ok=True)
    out.write_text(f"# Step speed, measured in one run\n\n{table}\n\nmujoco {mujoco.__version__}; medians.\n")
    print(table)


if __name__ == "__main__":
    main()
