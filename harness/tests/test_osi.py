"""diffosi.DiffOsi against the contract in DESIGN.md ("Online identification").

Transitions come from diffosi.Model itself (set_param, then step from random
states and forces), so without noise the true parameters are recoverable to
rounding. Run with `make test`.
"""

from pathlib import Path

import numpy as np
import pytest

import diffosi

CARTPOLE = str(Path(__file__).resolve().parents[2] / "reference_models" / "cartpole.xml")
PARAMS = ["body/pole/mass", "joint/hinge/damping"]
LOWER, UPPER = [0.01, 0.0], [10.0, 5.0]
TRUTH = np.array([0.3, 0.2])


def window(truth=TRUTH, w=5, seed=0):
    """W transitions of the cartpole whose pole mass and hinge damping are `truth`."""
    m = diffosi.Model.load(CARTPOLE)
    for name, value in zip(PARAMS, truth):
        m.set_param(name, value)
    r = np.random.default_rng(seed)
    q = r.uniform(-1.0, 1.0, (w, m.nq)) * [1.0, 0.5]
    v = r.uniform(-1.0, 1.0, (w, m.nv)) * [1.0, 2.0]
    tau = r.uniform(-1.0, 1.0, (w, m.nv)) * [10.0, 1.0]
    q_next, v_next = np.zeros_like(q), np.zeros_like(v)
    for t in range(w):
        q_next[t], v_next[t] = m.step(q[t], v[t], tau[t])
    return q, v, tau, q_next, v_next


def diffosi_for(method="lm", **kwargs):
    m = diffosi.Model.load(CARTPOLE)
    return diffosi.DiffOsi(m, params=PARAMS, lower=LOWER, upper=UPPER, method=method, **kwargs)


def check_estimate(est, nmu=2):
    assert set(est) >= {"params", "std", "loss", "iterations", "evaluations", "flags"}
    for key in ("params", "std"):
        assert isinstance(est[key], np.ndarray) and est[key].dtype == np.float64
        assert est[key].shape == (nmu,) and np.all(np.isfinite(est[key]))
    assert np.isfinite(est["loss"]) and est["loss"] >= 0.0
    assert est["iterations"] >= 0 and est["evaluations"] >= 1
    assert isinstance(est["flags"], list)
    assert set(est["flags"]) <= {"unexcited", "at_bound", "not_converged", "misfit"}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lm_recovers_pole_mass_and_hinge_damping(seed):
    osi = diffosi_for("lm")
    est = osi.identify(*window(seed=seed), init=[1.0, 0.1])
    check_estimate(est)
    np.testing.assert_allclose(est["params"], TRUTH, atol=1e-6)
    assert est["flags"] == []
    assert np.all(est["std"] < 1e-6)


def test_lm_recovers_from_two_transitions_with_the_default_start():
    osi = diffosi_for("lm")
    # The model's own values (mass 0.1, damping 0) are inside the bounds.
    np.testing.assert_allclose(osi.prior, [0.1, 0.0])
    est = osi.identify(*window(truth=[2.5, 1.3], w=2, seed=4))
    check_estimate(est)
    np.testing.assert_allclose(est["params"], [2.5, 1.3], atol=1e-6)


def test_adam_converges_with_many_more_iterations():
    data = window(seed=3)
    lm = diffosi_for("lm").identify(*data, init=[1.0, 0.1])
    adam = diffosi_for("adam").identify(*data, init=[1.0, 0.1])
    check_estimate(adam)
    np.testing.assert_allclose(adam["params"], TRUTH, atol=1e-3)
    assert adam["iterations"] > 10 * lm["iterations"]


def test_explicit_scale_and_lists_in():
    osi = diffosi_for("lm", scale=[2e-8, 2e-8, 1e-6, 1e-6])
    q, v, tau, q_next, v_next = window(seed=5)
    est = osi.identify(q.tolist(), v.tolist(), tau, q_next, v_next, init=(1.0, 0.1))
    np.testing.assert_allclose(est["params"], TRUTH, atol=1e-6)


def test_unexcited_window_keeps_init_and_says_so():
    # At rest, upright, without force, neither the mass nor the damping shows.
    zero = np.zeros((3, 2))
    for method in ("lm", "adam"):
        est = diffosi_for(method).identify(zero, zero, zero, zero, zero, init=[1.0, 0.1])
        check_estimate(est)
        np.testing.assert_allclose(est["params"], [1.0, 0.1], rtol=0, atol=1e-12)
        assert "unexcited" in est["flags"]
        # The uniform prior's std on the bounds.
        np.testing.assert_allclose(est["std"], (np.array(UPPER) - LOWER) / np.sqrt(12))


def test_init_defaults_to_the_model_values_clamped_into_the_bounds():
    m = diffosi.Model.load(CARTPOLE)
    m.set_param("body/pole/mass", 20.0)
    osi = diffosi.DiffOsi(m, params=PARAMS, lower=LOWER, upper=UPPER)
    np.testing.assert_allclose(osi.prior, [10.0, 0.0])
    zero = np.zeros((1, 2))
    est = osi.identify(zero, zero, zero, zero, zero)
    np.testing.assert_array_equal(est["params"], [10.0, 0.0])
    assert "unexcited" in est["flags"] and "at_bound" in est["flags"]


def test_vector_parameters_flatten_into_mu():
    m = diffosi.Model.load(CARTPOLE)
    m.set_param("body/pole/mass", TRUTH[0])  # the window's pole mass, which is not identified here
    osi = diffosi.DiffOsi(
        m, params=["body/pole/com", "joint/hinge/damping"], lower=[-1, -1, 0, 0], upper=[1, 1, 1, 1]
    )
    assert osi.params == ["body/pole/com", "joint/hinge/damping"]
    assert osi.lower.shape == (4,) and osi.method == "lm"
    est = osi.identify(*window(seed=6))
    check_estimate(est, nmu=4)
    # The pole's COM off its axis (y) cannot show in a planar cartpole.
    assert "unexcited" in est["flags"] and "misfit" not in est["flags"]
    np.testing.assert_allclose(est["params"][[0, 2, 3]], [0.0, 0.5, TRUTH[1]], atol=1e-6)


def test_data_the_model_cannot_explain_is_flagged():
    # The window's pole mass is 0.3 while this model keeps its own and identifies only the damping.
    m = diffosi.Model.load(CARTPOLE)
    assert m.get_param("body/pole/mass")[0] != TRUTH[0]
    osi = diffosi.DiffOsi(m, params=["joint/hinge/damping"], lower=[0.0], upper=[5.0])
    est = osi.identify(*window(seed=6))
    assert "misfit" in est["flags"]


def test_bad_input_raises_value_error_naming_it():
    m = diffosi.Model.load(CARTPOLE)
    q, v, tau, q_next, v_next = window(w=3)

    def make(**kw):
        args = dict(params=PARAMS, lower=LOWER, upper=UPPER)
        args.update(kw)
        return diffosi.DiffOsi(m, **args)

    bad_constructors = [
        (dict(method="cmaes"), "method"),
        (dict(params=["body/pole/nonsense"]), "nonsense"),
        (dict(params=[]), "params"),
        (dict(params=PARAMS + PARAMS[:1]), "twice"),
        (dict(lower=[0.01]), "lower"),
        (dict(upper=[10.0, 5.0, 1.0]), "upper"),
        (dict(lower=[0.01, np.nan]), "lower"),
        (dict(upper=[10.0, np.inf]), "upper"),
        (dict(lower=[1.0, 0.0], upper=[0.5, 5.0]), "lower[0]"),
        (dict(scale=[1e-3] * 3), "scale"),
        (dict(scale=[1e-3, 1e-3, 0.0, 1e-3]), "scale[2]"),
        (dict(scale=[1e-3, np.nan, 1e-3, 1e-3]), "scale"),
    ]
    for kwargs, word in bad_constructors:
        with pytest.raises(ValueError, match=word.replace("[", r"\[").replace("]", r"\]")):
            make(**kwargs)

    osi = make()
    nan_v = v.copy()
    nan_v[1, 0] = np.nan
    bad_calls = [
        ((q[:, :1], v, tau, q_next, v_next), {}, "q must"),
        ((q, v, tau[:2], q_next, v_next), {}, "tau has 2 rows"),
        ((q, nan_v, tau, q_next, v_next), {}, r"v\[1, 0\]"),
        ((q, v, tau, q_next, v_next.ravel()), {}, "v_next"),
        ((q[:0], v[:0], tau[:0], q_next[:0], v_next[:0]), {}, "no transitions"),
        ((q, v, tau, q_next, v_next), dict(init=[1.0]), "init"),
        ((q, v, tau, q_next, v_next), dict(init=[1.0, np.nan]), "init"),
        ((q, v, tau, q_next, v_next), dict(init=[20.0, 0.1]), "bounds"),
        ((q, v, tau, q_next, v_next), dict(init="x"), "init"),
    ]
    for args, kwargs, word in bad_calls:
        with pytest.raises(ValueError, match=word):
            osi.identify(*args, **kwargs)
    # A failed call leaves the object usable.
    np.testing.assert_allclose(osi.identify(*window(seed=7), init=[1.0, 0.1])["params"], TRUTH, atol=1e-6)


# ---------------------------------------------------------------- CMA-ES baseline


def cmaes_for(**kwargs):
    args = dict(params=PARAMS, lower=LOWER, upper=UPPER)
    args.update(kwargs)
    return diffosi.CmaEs(diffosi.Model.load(CARTPOLE), **args)


def test_cmaes_reaches_the_same_answer_with_many_more_evaluations():
    data = window(seed=3)
    lm = diffosi_for("lm").identify(*data, init=[1.0, 0.1])
    cma = cmaes_for(seed=1).identify(*data, init=[1.0, 0.1])
    check_estimate(cma)
    np.testing.assert_allclose(cma["params"], TRUTH, atol=1e-6)
    assert cma["flags"] == []
    assert cma["evaluations"] > 20 * lm["evaluations"]


def test_cmaes_same_seed_same_bits_and_evaluation_cap():
    data = window(seed=8)
    a = cmaes_for(seed=5).identify(*data, init=[1.0, 0.1])
    b = cmaes_for(seed=5).identify(*data, init=[1.0, 0.1])
    np.testing.assert_array_equal(a["params"], b["params"])
    assert a["evaluations"] == b["evaluations"]
    capped = cmaes_for(seed=5, max_evaluations=30).identify(*data, init=[1.0, 0.1])
    check_estimate(capped)
    assert capped["evaluations"] <= 30 + 6 and "not_converged" in capped["flags"]


def test_cmaes_unexcited_window_is_flagged_not_nan():
    zero = np.zeros((3, 2))
    est = cmaes_for().identify(zero, zero, zero, zero, zero, init=[1.0, 0.1])
    check_estimate(est)
    assert "unexcited" in est["flags"]
    np.testing.assert_allclose(est["params"], [1.0, 0.1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(est["std"], (np.array(UPPER) - LOWER) / np.sqrt(12))


def test_cmaes_bad_input_raises_value_error():
    for kwargs, word in [
        (dict(seed=-1), "seed"),
        (dict(seed="a"), "seed"),
        (dict(max_evaluations=0), "max_evaluations"),
        (dict(lower=[0.01]), "lower"),
        (dict(params=["body/pole/nonsense"]), "nonsense"),
    ]:
        with pytest.raises(ValueError, match=word):
            cmaes_for(**kwargs)
    cma = cmaes_for()
    q, v, tau, q_next, v_next = window(w=2)
    with pytest.raises(ValueError, match="init"):
        cma.identify(q, v, tau, q_next, v_next, init=[20.0, 0.1])
    with pytest.raises(ValueError, match="tau"):
        cma.identify(q, v, tau[:, :1], q_next, v_next)
