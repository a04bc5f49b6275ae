"""diffosi.Task, diffosi.Policy and diffosi.OnlineOsi: the engine's task, shipped policies
and online identifier from Python; every bad input is a ValueError (OSError for files)."""

from pathlib import Path

import numpy as np
import pytest

import diffosi

POLICIES = Path(__file__).resolve().parents[2] / "policies" / "cartpole"


@pytest.fixture(scope="module")
def task():
    return diffosi.Task("cartpole")


def test_task_facts_and_mu_map(task):
    assert (task.name, task.horizon, task.substeps, task.obs_dim, task.act_dim, task.nmu) == \
        ("cartpole", 500, 1, 4, 1, 1)
    lo, hi = task.mu_range
    assert lo.tolist() == [-0.6] and hi.tolist() == [0.6]
    np.testing.assert_allclose(task.mu_params([0.3])["body/pole/com"], [0.3, 0.0, 0.56])
    np.testing.assert_allclose(task.model([-0.5]).get_param("body/pole/com"), [-0.5, 0.0, 0.4])
    np.testing.assert_allclose(task.model().get_param("body/pole/com"), [0.0, 0.0, 0.5])
    np.testing.assert_array_equal(task.forces([0.5]), [250.0, 0.0])
    np.testing.assert_array_equal(task.forces([-3.0]), [-500.0, 0.0])
    assert task.observe([1, 2], [3, 4]).tolist() == [1, 2, 3, 4]
    assert not task.terminated([2.5, 0.0], [0, 0]) and task.terminated([2.6, 0.0], [0, 0])
    assert task.metric([0, 0], [0, 0], [0], [0, 1.6], [0, 0]) == 0.0


def test_episodes_are_seeded_and_in_range(task):
    mu, q0, v0 = task.episodes(50, 7)
    assert mu.shape == (50, 1) and q0.shape == (50, 2) and v0.shape == (50, 2)
    assert np.all(np.abs(mu) <= 0.6) and np.all(np.abs(q0) <= 0.05) and np.all(np.abs(v0) <= 0.05)
    again = task.episodes(50, 7)
    assert all(np.array_equal(a, b) for a, b in zip((mu, q0, v0), again))
    assert not np.array_equal(mu, task.episodes(50, 8)[0])
    q, v = task.reset(3)
    assert np.array_equal(q, task.reset(3)[0]) and np.all(np.abs(np.concatenate([q, v])) <= 0.05)


def test_policies_act_in_bounds(task):
    uc, dr = diffosi.Policy.load(POLICIES / "uc-seed0.json"), diffosi.Policy.load(POLICIES / "dr-seed0.json")
    assert (uc.kind, dr.kind, uc.task) == ("uc", "dr", "cartpole")
    a = uc.act(task, [0.0, 0.1], [0.0, 0.0], [0.2])
    assert a.shape == (1,) and -1 <= a[0] <= 1
    assert not np.array_equal(a, uc.act(task, [0.0, 0.1], [0.0, 0.0], [-0.4]))  # mu matters
    np.testing.assert_array_equal(dr.act(task, [0.0, 0.1], [0, 0]), dr.act(task, [0.0, 0.1], [0, 0], [0.5]))


def test_online_osi_recovers_mu_on_our_engine(task):
    mu = 0.37
    model, osi = task.model([mu]), diffosi.OnlineOsi(task, window=2)
    assert osi.mu.tolist() == [0.0] and (osi.window, osi.method, osi.change_detection) == (2, "lm", False)
    q, v = np.array([0.01, 0.02]), np.array([0.0, -0.01])
    for tau in ([3.0, 0.0], [-2.0, 0.0], [1.0, 0.0]):
        q1, v1 = model.step(q, v, tau)
        est = osi.push(q, v, tau, q1, v1)
        q, v = q1, v1
    assert abs(est["mu"][0] - mu) < 1e-9 and np.isfinite(est["std"]).all()
    assert set(est) == {"mu", "std", "loss", "iterations", "evaluations", "flags"}
    assert osi.mu[0] == est["mu"][0]


@pytest.mark.parametrize("call", [
    lambda t: diffosi.Task("walker"),
    lambda t: t.model([0.7]),
    lambda t: t.model([0.1, 0.2]),
    lambda t: t.mu_params([np.nan]),
    lambda t: t.observe([0.0], [0.0, 0.0]),
    lambda t: t.terminated([0.0, np.inf], [0.0, 0.0]),
    lambda t: t.forces([0.1, 0.2]),
    lambda t: t.forces("fast"),
    lambda t: t.metric([0, 0], [0, 0], [], [0, 0], [0, 0]),
    lambda t: diffosi.Policy.load(POLICIES / "uc-seed0.curve.csv"),
    lambda t: diffosi.Policy.load(POLICIES / "uc-seed0.json").act(t, [0, 0], [0, 0]),
    lambda t: diffosi.Policy.load(POLICIES / "uc-seed0.json").act(t, [0, 0], [0, 0], [0.1, 0.2]),
    lambda t: diffosi.Policy.load(POLICIES / "uc-seed0.json").act(t, [0, 0, 0], [0, 0], [0.1]),
    lambda t: diffosi.OnlineOsi(t, window=0),
    lambda t: diffosi.OnlineOsi(t, method="newton"),
    lambda t: diffosi.OnlineOsi(t, scale=[1.0, 1.0, 1.0, 0.0]),
    lambda t: diffosi.OnlineOsi(t).push([0, 0], [0, 0], [0, 0], [0, 0], [0, np.nan]),
    lambda t: diffosi.OnlineOsi(t).push([0, 0], [0, 0], [0], [0, 0], [0, 0]),
])
def test_bad_input_is_a_value_error(task, call):
    with pytest.raises(ValueError):
        call(task)


def test_missing_policy_file_is_an_os_error(tmp_path):
    with pytest.raises(OSError):
        diffosi.Policy.load(tmp_path / "none.json")


def test_a_rejected_push_changes_nothing(task):
    osi = diffosi.OnlineOsi(task)
    model = task.model([0.2])
    q1, v1 = model.step([0.0, 0.1], [0.0, 0.0], [5.0, 0.0])
    first = osi.push([0.0, 0.1], [0.0, 0.0], [5.0, 0.0], q1, v1)["mu"]
    with pytest.raises(ValueError):
        osi.push([0.0, 0.1], [0.0, 0.0], [5.0, 0.0], q1, [np.nan, 0.0])
    assert osi.mu[0] == first[0]


def test_change_detection_flags_a_new_mu(task):
    """mu jumps from 0.3 to -0.3 after 8 transitions: with change detection the window is
    emptied at once (flag "changed") and the estimate follows; without it, a window of 3
    still holds old transitions on the first push after the jump."""
    runs = {}
    for detect in (True, False):
        rng = np.random.default_rng(0)
        osi, q, v = diffosi.OnlineOsi(task, window=3, change_detection=detect), np.array([0.0, 0.1]), np.zeros(2)
        runs[detect] = []
        for k in range(12):
            tau = [rng.uniform(-5, 5), 0.0]
            q1, v1 = task.model([0.3 if k < 8 else -0.3]).step(q, v, tau)
            est = osi.push(q, v, tau, q1, v1)
            runs[detect].append((est["mu"][0], est["flags"]))
            q, v = q1, v1
    flagged = [k for k, (_, flags) in enumerate(runs[True]) if "changed" in flags]
    assert flagged == [8] and abs(runs[True][8][0] + 0.3) < 1e-9
    assert abs(runs[False][8][0] + 0.3) > 1e-3 and not any("changed" in f for _, f in runs[False])
