"""Identification under realistic data: noise, actuator delay, outliers, no excitation, bounds.

Two problems, each identified from one window of W transitions that MuJoCo generated
(harness/engines/mujoco.py: mj_step, generalized forces through qfrc_applied, contacts
and limits off, the true parameters written into the MjModel):

- cartpole: the paper's mu (pole COM at (mu, 0, 0.5 + 0.2 mu) m in the pole frame), in
  the task's range [-0.6, 0.6], by diffosi.OnlineOsi(Task("cartpole"), window=W): the W
  transitions are pushed one by one, each push an update warm-started from the last;
  the estimate after the last push (on all W) is scored.
- double_pendulum: both link masses (kg) and both hinge dampings (N m s/rad) in
  [0.1, 5] x [0.1, 5] x [0, 1] x [0, 1], by one diffosi.DiffOsi.identify on the window,
  from the model file's values.

Cases (the data; every case is identified with the squared and with the Huber loss):

- clean: a trajectory of W steps from a random state under random generalized forces
  (harness/engines/sampling.py), as MuJoCo ran it.
- noise-<s>: the clean trajectory's observed states with Gaussian noise of standard
  deviation s times each state component's range over the trajectory (max - min of that
  q or v), independent per sample; a transition's next state is the next one's state,
  as a sensor would give them. The identifier is told the noise: scale = sqrt(2) sigma
  per component (a residual differences two noisy samples).
- delay: MuJoCo applies the previous step's forces (zero before the first); the
  identifier is told the forces commanded at each step (one-step actuator delay).
- outliers: Gaussian noise as in noise-0.0001 (scale told as there), and one transition in 20
  corrupted: its next state replaced by the state plus uniform noise of one range per
  component (a sensor glitch).
- rest: W steps at rest at the true model's equilibrium (found by Newton's method on our
  step), zero velocity and zero force: nothing moves.
- at-bound / beyond-bound: the clean case's data with true parameters on a bound, and
  beyond one (which no estimate in the box can reach).

Columns: error = max |estimate - truth| over the components (kg and N m s/rad mixed for
the double pendulum), z = max |estimate - truth| / std (the reported standard error's
honesty; > 3 means the std understates the error), loss / dof = the final loss over
(2 nv W - nmu) (about 1 or below when the residuals are at the scale's level), flags as
the identifier raised them (z is left out where the error is rounding), wall ms = the
identification's wall-clock time from Python (cartpole: all W online updates; double
pendulum: one identify). Scale is the default (1e-3 on v, timestep x 1e-3 on q) except
in the noise and outlier cases. The run asserts that no number in it is NaN or infinite.
"""

from __future__ import annotations

import importlib.metadata
import os
import platform
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness import engines
from harness.engines.numpy_step import step_error
from harness.engines.sampling import sample_rollout, tau_scale
from harness.gym_env import pole_com
from harness.report import REPORTS, jsonable, markdown_table, write_json, write_markdown

CHECK_TOL = 1e-12  # our step reproduces MuJoCo's on these contact-free models to this
NOISE_LEVELS = (1e-4, 1e-3, 1e-2)
OUTLIER_EVERY = 20
OUTLIER_NOISE = 1e-4  # the outlier case's sensor noise besides its glitches
LOSSES = ("squared", "huber")
NOISELESS = 1e-9  # an error below this is rounding: z (error / std) says nothing there


@dataclass(frozen=True)
class Problem:
    """One model's identification: named parameters (mu is their values in order; the
    cartpole's mu is the task's one number), bounds, the truth of every case but the
    bound cases, and the truths on and beyond a bound."""

    params: list
    lower: list
    upper: list
    truth: list
    at_bound: list
    beyond_bound: list

    def physical(self, mu) -> dict:
        """{parameter name: value} that mu sets in MuJoCo."""
        if self.params == ["mu"]:
            return {"body/pole/com": pole_com(mu[0])}
        return dict(zip(self.params, mu))


PROBLEMS = {
    "cartpole": Problem(params=["mu"], lower=[-0.6], upper=[0.6], truth=[0.3], at_bound=[0.6],
                        beyond_bound=[0.8]),
    "double_pendulum": Problem(
        params=["body/link1/mass", "body/link2/mass", "joint/hinge1/damping", "joint/hinge2/damping"],
        lower=[0.1, 0.1, 0.0, 0.0], upper=[5.0, 5.0, 1.0, 1.0], truth=[1.3, 0.7, 0.12, 0.03],
        at_bound=[1.3, 5.0, 0.12, 0.0], beyond_bound=[1.3, 6.5, 0.12, 0.03]),
}
CASES = ("clean", *(f"noise-{s:g}" for s in NOISE_LEVELS), "delay", "outliers", "rest", "at-bound",
         "beyond-bound")
# The flags each case must raise (asserted by the tests; the report shows them all).
EXPECTED_FLAGS = {("double_pendulum", "rest"): {"unexcited"},
                  ("cartpole", "beyond-bound"): {"at_bound", "misfit"},
                  ("double_pendulum", "beyond-bound"): {"at_bound"},  # the other masses make up for it
                  ("cartpole", "delay"): {"misfit"}, ("double_pendulum", "delay"): {"misfit"}}


@dataclass
class Window:
    """W observed transitions (rows of q, v, tau, q_next, v_next), the truth behind them
    and the residual scale the identifier is told (None: its default)."""

    truth: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    q_next: np.ndarray
    v_next: np.ndarray
    scale: np.ndarray | None = None

    def arrays(self) -> tuple:
        return self.q, self.v, self.tau, self.q_next, self.v_next


def truth_of(problem: Problem, case: str) -> np.ndarray:
    return np.array({"at-bound": problem.at_bound, "beyond-bound": problem.beyond_bound}.get(case, problem.truth))


def equilibrium(model, q0) -> np.ndarray:
    """A q where the model at rest under zero force stays at rest: Newton's method on
    v1(q) = step(q, 0, 0).v, least squares where dv1/dq is singular (the cart's x)."""
    q, zero = np.array(q0, dtype=float), np.zeros(model.nv)
    for _ in range(50):
        v1 = model.step(q, zero, zero)[1]
        if np.abs(v1).max() < 1e-14:
            break
        q -= np.linalg.lstsq(model.step_jacobians(q, zero, zero)["dv_dq"], v1, rcond=None)[0]
    return q


def simulate(name: str, problem: Problem, truth, case: str, w: int, rng) -> tuple:
    """MuJoCo's trajectory of w steps for the case: (Q (w+1, nq), V (w+1, nv), commanded taus (w, nv))
    and the largest one-step gap between our step (true parameters) and MuJoCo's."""
    with engines.load("mujoco", name) as e:
        for pname, value in problem.physical(truth).items():
            e.set_param(pname, value)
        ours = e.ours()
        q0, v0, taus = sample_rollout(e, rng, tau_scale(e), w)
        if case == "rest":
            q0 = equilibrium(ours, [0.0, np.pi] if name == "cartpole" else np.zeros(len(q0)))
            v0, taus = np.zeros_like(v0), np.zeros_like(taus)
        applied = np.vstack([np.zeros_like(taus[:1]), taus[:-1]]) if case == "delay" else taus
        Q, V = e.rollout(q0, v0, applied)
    gap = max(step_error(*ours.step(Q[t], V[t], applied[t]), Q[t + 1], V[t + 1]) for t in range(len(taus)))
    return Q, V, taus, gap


def noise_level(case: str) -> float:
    """The case's state noise, as a fraction of each state component's range (0: none)."""
    if case == "outliers":
        return OUTLIER_NOISE
    return float(case.removeprefix("noise-")) if case.startswith("noise-") else 0.0


def make_window(name: str, case: str, w: int, seed: int) -> tuple[Window, float]:
    """The case's window of w transitions (seeded by (seed, problem, case): both losses see the same data)
    and our engine's gap to MuJoCo on the clean trajectory."""
    problem = PROBLEMS[name]
    rng = np.random.default_rng([seed, list(PROBLEMS).index(name), CASES.index(case)])
    truth = truth_of(problem, case)
    Q, V, taus, gap = simulate(name, problem, truth, case, w, rng)
    scale, noise = None, noise_level(case)
    if noise:
        sigma_q, sigma_v = noise * np.ptp(Q, axis=0), noise * np.ptp(V, axis=0)
        Q = Q + rng.normal(size=Q.shape) * sigma_q
        V = V + rng.normal(size=V.shape) * sigma_v
        scale = np.sqrt(2.0) * np.concatenate([sigma_q, sigma_v])
    q_next, v_next = Q[1:].copy(), V[1:].copy()
    if case == "outliers":
        span_q, span_v = np.ptp(Q, axis=0), np.ptp(V, axis=0)
        for t in range(OUTLIER_EVERY - 1, len(taus), OUTLIER_EVERY):
            q_next[t] = Q[t] + rng.uniform(-1.0, 1.0, len(span_q)) * span_q
            v_next[t] = V[t] + rng.uniform(-1.0, 1.0, len(span_v)) * span_v
    return Window(truth, Q[:-1], V[:-1], taus, q_next, v_next, scale), gap


def identify(name: str, window: Window, loss: str, seed: int) -> dict:
    """One identification of the window: the estimate, its standard errors, final loss,
    work, flags and wall seconds."""
    import diffosi

    problem, w = PROBLEMS[name], len(window.tau)
    if name == "cartpole":
        osi = diffosi.OnlineOsi(diffosi.Task("cartpole"), window=w, seed=seed, scale=window.scale, loss=loss)
        start = time.perf_counter()
        for row in zip(*window.arrays()):
            est = osi.push(*row)
        seconds = time.perf_counter() - start
        mu = est["mu"]
    else:
        with engines.load("mujoco", name) as e:
            model = e.ours()
        osi = diffosi.DiffOsi(model, params=problem.params, lower=problem.lower, upper=problem.upper,
                              scale=window.scale, loss=loss)
        start = time.perf_counter()
        est = osi.identify(*window.arrays())
        seconds = time.perf_counter() - start
        mu = est["params"]
    err = np.abs(np.asarray(mu) - window.truth)
    dof = max(1, 2 * len(window.v[0]) * w - len(mu))
    return {"mu": mu, "std": est["std"], "error": float(err.max()), "z": float((err / est["std"]).max()),
            "loss": est["loss"], "loss_per_dof": est["loss"] / dof, "iterations": est["iterations"],
            "evaluations": est["evaluations"], "flags": list(est["flags"]), "seconds": seconds}


def run_case(name: str, case: str, w: int, seed: int) -> dict:
    window, gap = make_window(name, case, w, seed)
    if case in ("clean", "rest", "at-bound", "beyond-bound") and gap > CHECK_TOL:
        raise RuntimeError(f"robustness {name} {case}: our step is {gap:.1e} off MuJoCo's")
    return {"problem": name, "case": case, "window": len(window.tau), "truth": window.truth,
            "model_gap": gap, "losses": {loss: identify(name, window, loss, seed) for loss in LOSSES}}


def non_finite(x, path: str = "") -> list[str]:
    """Where in a nested report a number is NaN or infinite."""
    if isinstance(x, dict):
        return [p for k, v in x.items() for p in non_finite(v, f"{path}/{k}")]
    if isinstance(x, list):
        return [p for i, v in enumerate(x) for p in non_finite(v, f"{path}[{i}]")]
    return [path] if isinstance(x, float) and not np.isfinite(x) else []


def build(names, seed: int, window: int) -> dict:
    """Every case of every problem in `names`; raises if any number is NaN or infinite."""
    rows = [run_case(name, case, window, seed) for name in names for case in CASES]
    report = jsonable({"meta": {"seed": seed, "window": window, "noise_levels": NOISE_LEVELS,
                                "outlier_every": OUTLIER_EVERY, "problems": {n: vars(PROBLEMS[n]) for n in names}},
                       "rows": rows})
    bad = non_finite(report)
    if bad:
        raise RuntimeError(f"robustness: non-finite numbers at {bad}")
    return report


# --------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------


def _fmt(x) -> str:
    return ", ".join(f"{v:.4g}" for v in x)


def case_table(report: dict, name: str) -> list:
    header = ["case", "truth", "loss", "estimate", "error", "z", "loss / dof", "flags", "it / ev", "wall ms"]
    cells = []
    for r in report["rows"]:
        if r["problem"] != name:
            continue
        for loss, x in r["losses"].items():
            cells.append([r["case"], _fmt(r["truth"]), loss, _fmt(x["mu"]), f"{x['error']:.1e}",
                          f"{x['z']:.2g}" if x["error"] > NOISELESS else "-",
                          f"{x['loss_per_dof']:.3g}", ", ".join(x["flags"]) or "-",
                          f"{x['iterations']} / {x['evaluations']}", f"{1e3 * x['seconds']:.3g}"])
    return markdown_table(header, cells)


def findings(report: dict) -> list[str]:
    """What the run shows, computed from its rows."""
    out = []
    by = {(r["problem"], r["case"]): r for r in report["rows"]}
    for name in dict.fromkeys(r["problem"] for r in report["rows"]):
        clean, outl = by[(name, "clean")]["losses"], by[(name, "outliers")]["losses"]
        out.append(f"{name}, outliers: squared loss error {outl['squared']['error']:.1e}, Huber "
                   f"{outl['huber']['error']:.1e} (clean data: {clean['squared']['error']:.1e} and "
                   f"{clean['huber']['error']:.1e}).")
        noisy = by[(name, f"noise-{OUTLIER_NOISE:g}")]["losses"]
        out[-1] = out[-1][:-2] + (f"; the same noise without outliers: {noisy['squared']['error']:.1e} and "
                                  f"{noisy['huber']['error']:.1e}).")
        delay = by[(name, "delay")]["losses"]["squared"]
        out.append(f"{name}, delay: error {delay['error']:.1e}, flags {', '.join(delay['flags']) or 'none'}; "
                   f"loss / dof {delay['loss_per_dof']:.3g} against {clean['squared']['loss_per_dof']:.1e} on "
                   "clean data: the unmodelled delay shows in the misfit, flagged 'misfit' when loss / dof > 4.")
        z = max(x["z"] for c in CASES if c.startswith("noise-") for x in by[(name, c)]["losses"].values())
        out.append(f"{name}, noise: the largest z over the noise rows is {z:.2g}.")
        rest = by[(name, "rest")]["losses"]["squared"]
        out.append(f"{name}, rest: flags {', '.join(rest['flags']) or 'none'}, error {rest['error']:.1e}, estimate "
                   f"{_fmt(rest['mu'])}.")
    return out


NOTES = [
    "Huber loss (DiffOsi / OnlineOsi loss=\"huber\", huber=1.345): quadratic for scaled residuals up to "
    "1.345 residual scales, linear beyond; solved by iteratively reweighted least squares inside the "
    "bounded Levenberg-Marquardt (src/osi/lm.rs). The default stays the squared loss.",
    "Rest: the double pendulum hanging at its equilibrium (gravity against the hinge2 spring) pins both "
    "masses through the equilibrium itself but says nothing about damping at the truth (v = 0): the estimate "
    "says `unexcited` and gives the dampings the prior's std (0.29). They do move from their start during "
    "the solve: while the masses are wrong the model accelerates, and MuJoCo's implicit damping (our "
    "implicit_damping mode) divides that acceleration by 1 + h d / M, a weak handle on d that vanishes as "
    "the masses converge. The cartpole's mu is not unexcited at rest: the angle "
    "at which the offset COM hangs still depends on mu, so one motionless window identifies it.",
    "Bounds: a truth on its bound is reached; `at_bound` is raised when the estimate lands exactly on the "
    "bound (a solve that stops one rounding step inside does not raise it). A truth beyond its bound ends on "
    "the bound, flagged `at_bound`, with an error of at least its distance to the box.",
    "Noise: the identifier is told the noise level through `scale`; z compares the reported standard "
    "error (linearised at the estimate) with the actual error. The noise enters the regressors (q_t, v_t) "
    "as well as the targets (errors in variables), a bias the standard error does not include.",
]


def case_descriptions() -> list[str]:
    """The module docstring's list of cases, as Markdown lines."""
    cases = __doc__.split("Cases (", 1)[1].split("\n\nColumns", 1)[0]
    return cases.split("\n\n", 1)[1].split("\n")


def markdown(report: dict) -> list:
    meta = report["meta"]
    lines = [
        "# Identification under realistic data",
        "",
        f"Written by `python -m harness robustness --seed {meta['seed']} --window {meta['window']}`. Versions: "
        + ", ".join(f"{k} {v}" for k, v in meta["versions"].items()) + f". Machine: {meta['machine']} "
        "(shared; wall times are indicative).",
        "",
        "Each row identifies one window of W transitions MuJoCo generated (case descriptions below) with the "
        "squared and the Huber loss. error: max |estimate - truth|; z: max |estimate - truth| / reported std; "
        "loss / dof: final loss over 2 nv W - nmu; it / ev: iterations / evaluations; wall ms: wall-clock "
        "time of the identification (cartpole: all W online updates; double pendulum: one identify). No "
        "number in this report is NaN (the run asserts it).",
        "",
    ]
    for name in dict.fromkeys(r["problem"] for r in report["rows"]):
        what = ("mu (m), OnlineOsi on the task" if name == "cartpole"
                else "link1, link2 mass (kg), hinge1, hinge2 damping (N m s/rad), DiffOsi")
        lines += [f"## {name}: {what}", "", *case_table(report, name), ""]
    lines += ["## Findings", "", *[f"- {x}" for x in findings(report)], "", "## Notes", "",
              *[f"- {x}" for x in NOTES], "", "## Cases", "", *case_descriptions()]
    return lines


def add_arguments(parser) -> None:
    parser.add_argument("--problems", default=",".join(PROBLEMS), help="comma-separated: " + ", ".join(PROBLEMS))
    parser.add_argument("--window", type=int, default=40, help="transitions per window W (default 40)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=REPORTS, help="directory for robustness.{md,json}")


def run(args) -> int:
    names = [n for n in args.problems.split(",") if n]
    unknown = [n for n in names if n not in PROBLEMS]
    if unknown:
        raise SystemExit(f"robustness: unknown problem(s) {unknown}; choose from {list(PROBLEMS)}")
    if args.window < OUTLIER_EVERY:
        raise SystemExit(f"robustness: --window must be at least {OUTLIER_EVERY} (one outlier in {OUTLIER_EVERY})")
    report = build(names, args.seed, args.window)
    report["meta"]["versions"] = {p: importlib.metadata.version(p) for p in ("diffosi", "mujoco", "numpy")}
    report["meta"]["machine"] = f"{platform.machine()}, {os.cpu_count()} cores"
    write_json(args.out / "robustness.json", report)
    lines = markdown(report)
    write_markdown(args.out / "robustness.md", lines)
    print("\n".join(lines))
    return 0
