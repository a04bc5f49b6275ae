"""Timings of the reference engines on our models, next to ours from criterion.

Run by `make bench` right after `cargo bench` (same machine, same run). Writes
reports/bench.md with ratios (reference time / our time; > 1 means we are
faster):

- step: MuJoCo mj_step(..., nstep=N), a loop in C, contacts off (our engine
  has no contact yet);
- step Jacobian d(x')/d(x, u): MuJoCo's forward finite differences
  (mjd_transitionFD), and Pinocchio's analytic ABA derivatives
  (computeABADerivatives, which excludes the step itself), both called from
  Python, so each includes ~0.3-1 us of call overhead;
- one-parameter Jacobian: ours only; the paper's engine (NimblePhysics) needed
  52 us (cartpole) and 395 us (half cheetah) for a Gauss-Newton update per
  transition on this machine class (shared/notes/reference-engines.md).

Then an OSI table (benches/osi.rs): one DiffOSI identification (LM from the
prior until a tolerance stops it), the warm-started online update, and one
evaluation of the
window's residuals and exact Jacobian (the work of one Gauss-Newton step), at
windows W = 1, 2, 5, 10, 50, per update and per transition, next to
NimblePhysics' Gauss-Newton step (the same notes) where measured. Ratio =
Nimble / ours; the goal is >= 30x.
"""
import json
import pathlib
import time

import mujoco
import numpy as np
import pinocchio

ROOT = pathlib.Path(__file__).resolve().parent.parent
MODELS = ["cartpole", "half_cheetah"]


def median_seconds(call, inner, repeats=7):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append((time.perf_counter() - start) / inner)
    return float(np.median(times))


def mujoco_model(name):
    model = mujoco.MjModel.from_xml_path(str(ROOT / "reference_models" / f"{name}.xml"))
    # Contacts off: the comparison is of contact-free articulated dynamics.
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    return model, mujoco.MjData(model)


def mujoco_step(name, nstep=20000):
    model, data = mujoco_model(name)
    return median_seconds(lambda: mujoco.mj_step(model, data, nstep=nstep), nstep)


def mujoco_transition_fd(name, calls=2000):
    model, data = mujoco_model(name)
    n = 2 * model.nv + model.na
    a = np.zeros((n, n))
    b = np.zeros((n, model.nu))

    def run():
        for _ in range(calls):
            mujoco.mjd_transitionFD(model, data, 1e-6, False, a, b, None, None)

    return median_seconds(run, calls)


def pinocchio_aba_derivatives(name, calls=20000):
    model = pinocchio.buildModelFromUrdf(str(ROOT / "reference_models" / f"{name}.urdf"))
    data = model.createData()
    q = pinocchio.neutral(model)
    v = np.linspace(-0.5, 0.5, model.nv)
    tau = np.linspace(-1.0, 1.0, model.nv)

    def run():
        for _ in range(calls):
            pinocchio.computeABADerivatives(model, data, q, v, tau)

    return median_seconds(run, calls)


def ours(bench):
    path = ROOT / "target" / "criterion" / bench / "new" / "estimates.json"
    if not path.exists():
        raise SystemExit(f"{path} missing: run `cargo bench` first")
    return json.loads(path.read_text())["median"]["point_estimate"] * 1e-9


def row(what, name, ours_s, theirs):
    cells = [f"{what}", name, f"{ours_s * 1e6:.2f}"]
    for seconds in theirs:
        cells.append("—" if seconds is None else f"{seconds * 1e6:.2f} ({seconds / ours_s:.1f}x)")
    return "| " + " | ".join(cells) + " |"


# NimblePhysics Gauss-Newton DiffOSI step, thread-CPU seconds per update
# (shared/notes/reference-engines.md): (model, W) -> seconds.
NIMBLE_GN_STEP = {
    ("cartpole", 1): 52e-6,
    ("cartpole", 10): 523e-6,
    ("cartpole", 50): 2.7e-3,
    ("half_cheetah", 1): 395e-6,
}
OSI_WINDOWS = [1, 2, 5, 10, 50]


def osi_table():
    def us(seconds):
        return f"{seconds * 1e6:.1f}"

    lines = [
        "| model | W | identification, cold (µs) | per transition (µs) | warm update (µs) | per transition (µs) "
        "| one GN step (µs) | per transition (µs) | Nimble GN step (µs) "
        "| ratio Nimble step / our cold identification | ratio Nimble step / our warm update "
        "| ratio Nimble step / our step |",
        "|---" * 12 + "|",
    ]
    for name in MODELS:
        for w in OSI_WINDOWS:
            update = ours(f"osi_lm_{name}_W{w}")
            warm = ours(f"osi_lm_warm_{name}_W{w}")
            step = ours(f"osi_fit_{name}_W{w}")
            nimble = NIMBLE_GN_STEP.get((name, w))
            cells = [name, str(w)] + [us(x) for x in [update, update / w, warm, warm / w, step, step / w]]
            if nimble is None:
                cells += ["—"] * 4
            else:
                cells += [us(nimble)] + [f"{nimble / x:.1f}x" for x in [update, warm, step]]
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main():
    lines = [
        "| what | model | diffosi (µs) | MuJoCo (µs, ratio) | Pinocchio (µs, ratio) |",
        "|---|---|---|---|---|",
    ]
    for name in MODELS:
        lines.append(row("step", name, ours(f"step_{name}"), [mujoco_step(name), None]))
        lines.append(
            row(
                "step + Jacobian d(x')/d(x,u)",
                name,
                ours(f"jacobian_full_{name}"),
                [mujoco_transition_fd(name), pinocchio_aba_derivatives(name)],
            )
        )
        lines.append(row("step + 1-parameter Jacobian", name, ours(f"jacobian_param_{name}"), [None, None]))
        lines.append(row("finite differences of our step", name, ours(f"jacobian_fd_{name}"), [None, None]))
    table = "\n".join(lines)
    versions = f"mujoco {mujoco.__version__}, pinocchio {pinocchio.__version__}; medians"
    osi = osi_table()
    osi_note = (
        "Identification, cold: LM from the prior to convergence; warm update: from the previous "
        "window's estimate, the parameter unchanged (cartpole pole COM offset, true 0.3 from 0; "
        "half cheetah torso mass, true 7.0 from 4.9; noise-free, contact-free, seeded random states "
        "and forces). One GN step: residuals and exact parameter Jacobian of the whole window. "
        "Nimble: its Gauss-Newton step (forward + parameter Jacobian + solve), thread-CPU time. "
        "Evaluations to tolerance, LM vs Adam: `cargo run --release --example osi_evals`."
    )
    out = ROOT / "reports" / "bench.md"
    out.parent.mkdir(exist_ok=True)
    out.write_text(
        f"# Speed, measured in one run\n\n{table}\n\n{versions}. Ratio = their time / ours.\n"
        f"\n## Online system identification (DiffOSI)\n\n{osi}\n\n{osi_note}\n"
    )
    print(table)
    print(osi)


if __name__ == "__main__":
    main()
