"""Bad input at the Python boundary (issue 10), fuzzed: seeded random arguments of
many kinds (right and wrong shapes, NaN, infinities, 1e300, strings, None, nested
lists) reach every method of Model, DiffOsi, CmaEs, Task, Policy and OnlineOsi.
Each call returns finite numbers or raises ValueError, TypeError, OverflowError
(pyo3's conversion of a negative count) or OSError: never another exception (a
Rust panic would surface as pyo3's PanicException, a BaseException) and never
an abort. Run with `make test`."""

from pathlib import Path

import numpy as np
import pytest

import diffosi

ROOT = Path(__file__).resolve().parents[2]
CARTPOLE = str(ROOT / "reference_models" / "cartpole.xml")
CHEETAH = str(ROOT / "reference_models" / "half_cheetah.xml")
POLICY = ROOT / "policies" / "cartpole" / "uc-seed0.json"
REFUSALS = (ValueError, TypeError, OverflowError, OSError)


def arbitrary(r, n):
    """An argument where a length-n float vector is expected: usually one, else anything."""
    kind = r.integers(12)
    special = [np.nan, np.inf, -np.inf, 1e300, -1e300, 1e-300, 0.0]
    if kind < 4:
        return r.uniform(-3, 3, n)
    if kind == 4:
        x = r.uniform(-3, 3, n)
        x[r.integers(n)] = special[r.integers(len(special))] if n else 0.0
        return x
    if kind == 5:
        return r.uniform(-3, 3, n + r.choice([-1, 1]) if n else 1)
    if kind == 6:
        return r.uniform(-3, 3, (n, 2))
    if kind == 7:
        return [special[r.integers(len(special))] for _ in range(n)]
    return [None, "fast", 3, [[1.0], [2.0, 3.0]], {"a": 1}][kind - 8 if kind < 12 else 0]


def arbitrary_rows(r, w, n):
    """(w, n) rows, or something else."""
    return r.uniform(-1, 1, (w, n)) if r.integers(3) else arbitrary(r, n)


def name(r, names):
    return names[r.integers(len(names))] if r.integers(4) else ["", "body//mass", "joint/x/y", 7][r.integers(4)]


def assert_finite(x):
    """Every number in a returned value is finite."""
    if isinstance(x, dict):
        for v in x.values():
            assert_finite(v)
    elif isinstance(x, (tuple, list)):
        for v in x:
            assert_finite(v)
    elif isinstance(x, (float, np.ndarray)) and np.asarray(x).dtype.kind == "f":
        assert np.all(np.isfinite(x)), x


def model_calls(r):
    m = diffosi.Model.load([CARTPOLE, CHEETAH][r.integers(2)])
    n, names = m.nv, m.param_names()
    size = lambda p: m.get_param(p).size if p in names else 3
    return [
        lambda: m.step(arbitrary(r, n), arbitrary(r, n), arbitrary(r, n)),
        lambda: m.rollout(arbitrary(r, n), arbitrary(r, n), arbitrary_rows(r, int(r.integers(0, 30)), n)),
        lambda: m.step_jacobians(arbitrary(r, n), arbitrary(r, n), arbitrary(r, n),
                                 params=[name(r, names) for _ in range(int(r.integers(3)))]),
        lambda: m.transition_jacobians(arbitrary(r, n), arbitrary(r, n), arbitrary(r, n)),
        lambda: m.set_param(p := name(r, names), arbitrary(r, size(p))),
        lambda: m.get_param(name(r, names)),
        lambda: m.with_options(timestep=[0.01, 0.0, -1.0, np.nan, np.inf, 1e300, "x"][r.integers(7)],
                               gravity=arbitrary(r, 3),
                               integrator=["Euler", "RK4", "rk4", ""][r.integers(4)],
                               passive=["explicit", "implicit_damping", "dart"][r.integers(3)]),
        lambda: diffosi.Model.load(["", "/nonexistent.xml", CARTPOLE + ".urdf", str(ROOT)][r.integers(4)]),
    ]


def osi_calls(r):
    m = diffosi.Model.load(CARTPOLE)
    names = ["body/pole/mass", "joint/hinge/damping", "body/pole/com"]
    params = [names[k] for k in r.choice(3, size=int(r.integers(1, 3)), replace=False)]
    nmu = sum(3 if p.endswith("com") else 1 for p in params)
    lower, upper = arbitrary(r, nmu), arbitrary(r, nmu)
    w = int(r.integers(0, 4))
    window = [arbitrary_rows(r, w, 2) for _ in range(5)]
    return [
        lambda: diffosi.DiffOsi(m, params, lower, upper, method=["lm", "adam", "gd"][r.integers(3)]),
        lambda: diffosi.DiffOsi(m, params, -np.ones(nmu), np.ones(nmu) * 2).identify(
            *window, init=arbitrary(r, nmu) if r.integers(2) else None),
        lambda: diffosi.CmaEs(m, params, lower, upper, seed=int(r.integers(5)), max_evaluations=int(r.integers(0, 50))),
        lambda: diffosi.CmaEs(m, params, -np.ones(nmu), np.ones(nmu) * 2, max_evaluations=40).identify(*window),
    ]


def task_calls(r):
    t = diffosi.Task("cartpole")
    policy = diffosi.Policy.load(POLICY)
    return [
        lambda: t.model(arbitrary(r, 1)),
        lambda: t.mu_params(arbitrary(r, 1)),
        lambda: t.episodes(int(r.integers(-2, 4)), int(r.integers(0, 9))),
        lambda: t.observe(arbitrary(r, 2), arbitrary(r, 2)),
        lambda: t.forces(arbitrary(r, 1)),
        lambda: t.terminated(arbitrary(r, 2), arbitrary(r, 2)),
        lambda: t.metric(*(arbitrary(r, 2) for _ in range(2)), arbitrary(r, 1), *(arbitrary(r, 2) for _ in range(2))),
        lambda: policy.act(t, arbitrary(r, 2), arbitrary(r, 2), arbitrary(r, 1)),
        lambda: diffosi.OnlineOsi(t, window=int(r.integers(-1, 3)), method=["lm", "adam", "x"][r.integers(3)],
                                  scale=arbitrary(r, 4) if r.integers(2) else None),
        lambda: diffosi.OnlineOsi(t).push(*(arbitrary(r, 2) for _ in range(5))),
    ]


@pytest.mark.parametrize("calls", [model_calls, osi_calls, task_calls])
def test_random_bad_input_is_refused_with_an_exception_or_answered_finitely(calls):
    r = np.random.default_rng(10)
    refused = 0
    for trial in range(300):
        options = calls(r)
        call = options[r.integers(len(options))]
        try:
            assert_finite(call())
        except REFUSALS as e:
            assert str(e), f"trial {trial}: an empty message"
            refused += 1
    assert refused > 50  # the inputs really are bad, mostly


def test_overflowing_values_are_refused_naming_them():
    m = diffosi.Model.load(CHEETAH)
    with pytest.raises(ValueError, match=r"body/bfoot/com.*1e\+?300.*overflows"):
        m.set_param("body/bfoot/com", [1e300, 0.0, 0.0])
    p = diffosi.Model.load(str(ROOT / "reference_models" / "pendulum.xml"))
    p.set_param("body/pendulum/mass", 1e-300)
    p.set_param("body/pendulum/inertia", [1e-300, 1e-300, 1e-300, 0, 0, 0])
    p.step([0.3], [0.0], [1.0])  # the state itself stays finite
    with pytest.raises(ValueError, match="dq_dp is not finite"):
        p.step_jacobians([0.3], [0.0], [1.0], params=["body/pendulum/mass"])
    with pytest.raises(ValueError, match="diverged"):
        m.rollout(np.zeros(m.nq), np.full(m.nv, 1e200), np.zeros((2, m.nv)))
