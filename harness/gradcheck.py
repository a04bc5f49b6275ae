"""Check our step Jacobians against finite differences of our step and of MuJoCo's step.

    python -m harness gradcheck --model cartpole [--states 5] [--seed 0]

One step x' = step(x, tau; p) maps the state x = (q, v) (SI units, the model's
joint order), generalized forces tau (N or N m, one per dof) and the named
parameters p (DESIGN.md: body/<b>/mass|com|inertia, joint/<j>/damping|stiffness|
armature) to x' = (q', v'). `Model.step_jacobians` gives its exact Jacobians; here
they are compared with two finite-difference oracles, both run as MuJoCo runs the
MJCF file (harness.engines: contacts and limits off, the file's timestep and
integrator, implicit joint damping under Euler):

- ours-FD: our own step (`Engine.ours()`), differenced, every parameter;
- MuJoCo-FD: mj_step from a set state, forces through qfrc_applied, differenced;
  parameters changed in MuJoCo's MjModel by the adapter (mass, COM, damping,
  stiffness: what MuJoCo can change with our meaning; inertia and armature are
  ours-FD only).

Differences are fourth order: a five-point central stencil with step
s = H max(1, |x_i|) for states and forces and, for a parameter, H times its size
or the size at which it starts to matter (`param_stepper`). A parameter that must
stay >= 0 and is within 2 s of 0 gets the one-sided five-point stencil; a step
whose stencil the engine refuses (an unphysical inertia) is divided by 10 until
it accepts it.

Error of a block (dq'/dq, dq'/dv, ..., and per named parameter the worse of
dq'/dp and dv'/dp): ||J_ours - J_fd||_max / ||J_fd||_max, except that an entry
is never held to more than the differences can resolve: its denominator is at
least rho / RESOLVE, rho the bound on the rounding of its difference quotient
(`fd_jacobian`). So a block that is zero (a slider's COM) or below rounding is
judged against rounding, not divided by ~0. States: q, v, tau from
harness.engines.sampling (seeded); the worst over states is reported in
reports/gradcheck-NAME.md and .json; the exit status is 1 if a block fails.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from harness import engines
from harness.engines.sampling import sample_transitions
from harness.report import REPORTS, markdown_table, write_json, write_markdown

THRESHOLDS = {"ours_fd": 1e-6, "mujoco_fd": 1e-5}
H = 1e-3  # relative step; near optimal for the O(s^4) stencils in float64 (eps^(1/5))
ROUNDINGS = 10.0  # roundings of the output assumed in one step, for the bound rho
RESOLVE = 1e-6  # a block is judged relative to itself down to this resolution
TINY = 1e-300  # keeps an all-zero block from dividing by 0
MAX_SHRINK = 6  # times a refused step is divided by 10 before the check gives up
NONNEGATIVE = ("mass", "damping", "stiffness", "armature", "friction", "frictionloss", "solimp")
STATE_INPUTS = ("q", "v", "tau")

# first derivative stencils, error O(s^4): (offsets in steps, weights per step)
CENTRAL = (np.array([-2.0, -1.0, 1.0, 2.0]), np.array([1.0, -8.0, 8.0, -1.0]) / 12.0)
FORWARD = (np.arange(5.0), np.array([-25.0, 48.0, -36.0, 16.0, -3.0]) / 12.0)


# --------------------------------------------------------------------------------------
# Finite differences and the error of a block
# --------------------------------------------------------------------------------------


def fd_jacobian(f, x, steps, one_sided=None, accepts=None) -> tuple:
    """(J, rho): J[:, i] = df/dx_i by the stencils above (f maps a vector like x to a
    vector), and per entry the rounding bound rho = ROUNDINGS eps sum|w| max|f| / s."""
    x = np.asarray(x, dtype=float)
    cols, rho = [], []
    for i, s in enumerate(steps):
        offsets, weights = FORWARD if one_sided is not None and one_sided[i] else CENTRAL
        e = np.zeros_like(x)
        e[i] = 1.0
        for _ in range(MAX_SHRINK):
            if accepts is None or all(accepts(x + o * s * e) for o in offsets):
                break
            s /= 10.0
        else:
            raise ValueError(f"no accepted finite-difference step for component {i} of {x}")
        values = [f(x + o * s * e) for o in offsets]
        cols.append(sum(w * y for w, y in zip(weights, values)) / s)
        size = np.max(np.abs(values), axis=0)
        rho.append(ROUNDINGS * np.finfo(float).eps * np.abs(weights).sum() * size / s)
    return np.stack(cols, axis=1), np.stack(rho, axis=1)


def block_error(exact, fd, rho) -> float:
    """max_ij |exact - fd| / max(||fd||_max, rho_ij / RESOLVE) (see the module docstring)."""
    return float(np.max(np.abs(exact - fd) / np.maximum(np.abs(fd).max(), rho / RESOLVE)))


def state_steps(x) -> np.ndarray:
    return H * np.maximum(1.0, np.abs(x))


def param_stepper(e):
    """steps(name, p) for a parameter's components: H |p_i| for a body's (H max|p|, or H,
    where p_i = 0); for a joint's armature, damping and stiffness H times the larger of
    |p| and the size at which it starts to matter, m_j, m_j / h and m_j / h^2, where
    m_j = 1 / (M^-1)_jj is the inertia the joint's dof moves against with every other dof
    free (M at the engine's reference configuration). (M_jj, the dof's inertia with the
    others held, is up to 280 times m_j along a chain: pybullet_data's pendulum5. Its
    steps left fourth-order truncation errors of 1e-2 in dv'/d(damping, armature).)"""
    inertia = dict(zip(e.joint_names, 1.0 / np.diag(np.linalg.inv(e.mass_matrix(e.q_ref)))))
    per = {"armature": 1.0, "damping": 1.0 / e.timestep, "frictionloss": 1.0 / e.timestep,
           "stiffness": 1.0 / e.timestep ** 2}

    def steps(name, p):
        kind, owner, fld = name.split("/")
        if kind == "joint":
            return H * np.maximum(np.abs(p), inertia[owner] * per[fld])
        return H * np.where(p != 0.0, np.abs(p), np.abs(p).max() or 1.0)

    return steps


# --------------------------------------------------------------------------------------
# The blocks, exact and by differences: {(output, input): matrix}, output "q" or "v",
# input "q", "v", "tau" or a parameter name
# --------------------------------------------------------------------------------------


def exact_blocks(model, q, v, tau, params) -> dict:
    j = model.step_jacobians(q, v, tau, params=params)
    out = {(o, i): j[f"d{o}_d{i}"] for o in "qv" for i in STATE_INPUTS}
    col = 0
    for name in params:
        n = np.size(model.get_param(name))
        out["q", name], out["v", name] = j["dq_dp"][:, col:col + n], j["dv_dp"][:, col:col + n]
        col += n
    return out


def fd_blocks(oracle, q, v, tau, params, param_steps, scale=1.0) -> dict:
    """Like exact_blocks, each block a pair (J, rho) from `fd_jacobian` of the oracle's
    step(q, v, tau) -> (q', v'), every step times `scale`. The oracle's set_param raises
    ValueError for a value it refuses; every parameter is restored afterwards."""
    nq = len(q)
    out = {}

    def split(name, j, rho):
        out["q", name], out["v", name] = (j[:nq], rho[:nq]), (j[nq:], rho[nq:])

    def diff(f, x, steps, one_sided=None, accepts=None):
        return fd_jacobian(lambda y: np.concatenate(f(y)), x, steps, one_sided, accepts)

    split("q", *diff(lambda x: oracle.step(x, v, tau), q, scale * state_steps(q)))
    split("v", *diff(lambda x: oracle.step(q, x, tau), v, scale * state_steps(v)))
    split("tau", *diff(lambda x: oracle.step(q, v, x), tau, scale * state_steps(tau)))
    for name in params:
        base = np.atleast_1d(oracle.get_param(name)).astype(float)

        def f(p, name=name):
            oracle.set_param(name, p)
            return oracle.step(q, v, tau)

        def accepts(p, name=name):
            try:
                oracle.set_param(name, p)
            except ValueError:
                return False
            return True

        steps = scale * param_steps(name, base)
        one_sided = (base - 2.0 * steps < 0.0) & (name.rsplit("/", 1)[1] in NONNEGATIVE)
        try:
            split(name, *diff(f, base, steps, one_sided, accepts))
        finally:
            oracle.set_param(name, base)
    return out


def row_of(output: str, wrt: str) -> str:
    """The report's row: one per state block, one per parameter (its q' and v' blocks)."""
    return f"d{output}'/d{wrt}" if wrt in STATE_INPUTS else wrt


def worst_errors(model, oracle, states, params, param_steps) -> dict:
    """{row: {"error", "resolves", "max_abs"}}, each the worst over the states: the block
    error of the model's exact Jacobians vs differences of the oracle's step (a
    diffosi.Model or an EngineOracle), the relative precision the differences resolve
    (max rho / ||J_fd||_max, at most 1: a zero block) and the size of the exact block."""
    worst: dict = {}
    for q, v, tau in states:
        exact = exact_blocks(model, q, v, tau, params)
        fd = fd_blocks(oracle, q, v, tau, params, param_steps)
        for (output, wrt), j in exact.items():
            j_fd, rho = fd[output, wrt]
            now = {"error": block_error(j, j_fd, rho), "max_abs": float(np.abs(j).max()),
                   "resolves": float(min(1.0, rho.max() / max(np.abs(j_fd).max(), TINY)))}
            row = worst.setdefault(row_of(output, wrt), dict.fromkeys(now, 0.0))
            for k, x in now.items():
                row[k] = max(row[k], x)
    return worst


class EngineOracle:
    """A reference engine seen as a step function from a set state, like diffosi.Model."""

    def __init__(self, e):
        self.e = e
        self.get_param, self.set_param = e.get_param, e.set_param

    def step(self, q, v, tau):
        self.e.reset()  # no history (warm starts) carried from one evaluation to the next
        self.e.set_state(q, v)
        self.e.step(tau)
        return self.e.get_state()


def engine_params(e, names) -> list[str]:
    """The parameters among `names` that the adapter can set."""
    def supported(name):
        try:
            e.get_param(name)
        except ValueError:
            return False
        return True

    return [n for n in names if supported(n)]


# --------------------------------------------------------------------------------------
# The check of one model and its report
# --------------------------------------------------------------------------------------


def gradcheck(name: str, n_states: int, seed: int, **options) -> dict:
    """Every block of every parameter vs ours-FD, the MuJoCo-settable ones vs MuJoCo-FD.
    `options` go to the MuJoCo adapter (eulerdamp=False, rk4=True)."""
    with engines.load("mujoco", name, **options) as e:
        ours = e.ours()
        states = sample_transitions(e, np.random.default_rng(seed), n_states)
        params = ours.param_names()
        steps = param_stepper(e)
        ours_fd = worst_errors(ours, ours, states, params, steps)
        mujoco_fd = worst_errors(ours, EngineOracle(e), states, engine_params(e, params), steps)
        doc = {"model": name, "file": e.label, "mujoco": e.version, "timestep": e.timestep,
               "integrator": e.integrator, "passive": e.passive, "states": n_states, "seed": seed,
               "thresholds": THRESHOLDS}
    rows = []
    for row, r in ours_fd.items():
        errors = {"ours_fd": r["error"], "mujoco_fd": mujoco_fd[row]["error"] if row in mujoco_fd else None}
        rows.append({"block": row, "max_abs": r["max_abs"], **errors, "fd_resolves": r["resolves"],
                     "pass": all(x is None or x <= THRESHOLDS[k] for k, x in errors.items())})
    doc["rows"] = rows
    doc["pass"] = all(r["pass"] for r in rows)
    return doc


def fmt(x) -> str:
    return "—" if x is None else f"{x:.1e}"


def markdown(doc: dict) -> list[str]:
    t = doc["thresholds"]
    lines = [
        f"# Gradient check: {doc['model']}",
        "",
        f"Our step Jacobians vs finite differences of our step (ours-FD) and of MuJoCo "
        f"{doc['mujoco']}'s mj_step (MuJoCo-FD), on `{doc['file']}` run as MuJoCo runs it "
        f"(h = {doc['timestep']} s, {doc['integrator']}, passive {doc['passive']}, contacts and "
        f"limits off), at {doc['states']} random states (seed {doc['seed']}). Per block, the worst "
        f"over the states of the relative max-norm error ||J - J_fd|| / ||J_fd||; a parameter's "
        f"row is the worse of dq'/dp and dv'/dp. \"FD resolves\" is the relative precision the "
        f"differences can resolve for the block (their rounding bound / the block); where it "
        f"exceeds {RESOLVE:.0e} (or the block is zero: >= 1) the error is measured against that "
        f"rounding instead (harness/gradcheck.py). Thresholds: ours-FD <= {t['ours_fd']:.0e}, "
        f"MuJoCo-FD <= {t['mujoco_fd']:.0e}; — = a parameter MuJoCo cannot change with our "
        f"meaning (inertia, armature).",
        "",
    ]
    rows = [[r["block"], f"{r['max_abs']:.2e}", fmt(r["ours_fd"]), fmt(r["mujoco_fd"]),
             ">= 1" if r["fd_resolves"] >= 1.0 else f"{r['fd_resolves']:.0e}",
             "PASS" if r["pass"] else "FAIL"] for r in doc["rows"]]
    header = ["block", "max abs J", "vs ours-FD", "vs MuJoCo-FD", "FD resolves", "result"]
    lines += markdown_table(header, rows)
    worst = {k: max(r[k] for r in doc["rows"] if r[k] is not None) for k in THRESHOLDS}
    lines += ["", f"Worst: ours-FD {fmt(worst['ours_fd'])}, MuJoCo-FD {fmt(worst['mujoco_fd'])}: "
              f"**{'PASS' if doc['pass'] else 'FAIL'}**"]
    return lines


def add_arguments(parser) -> None:
    parser.add_argument("--model", required=True, help="a reference model (cartpole, double_pendulum, ...) or "
                        "an MJCF or URDF file MuJoCo loads "
                        "(with --contact: gymnasium's hopper or half_cheetah)")
    parser.add_argument("--contact", action="store_true",
                        help="states in contact, MuJoCo's solver converged (harness/gradcheck_contact.py)")
    parser.add_argument("--states", type=int, default=5, help="random states (default 5)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=REPORTS, help="report directory (default reports/)")


def run(args) -> int:
    if args.contact:
        from harness import gradcheck_contact

        return gradcheck_contact.run(args)
    doc = gradcheck(args.model, args.states, args.seed)
    lines = markdown(doc)
    stem = f"gradcheck-{Path(args.model).stem}"  # a model name, or a file's stem
    write_markdown(args.out / f"{stem}.md", lines)
    write_json(args.out / f"{stem}.json", doc)
    print("\n".join(lines))
    return 0 if doc["pass"] else 1
