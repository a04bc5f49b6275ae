"""Our step Jacobians against finite differences of our step and of MuJoCo's (harness/gradcheck.py).

Thresholds (issue 4, item 7): every block within 1e-6 of ours-FD and within 1e-5 of
MuJoCo-FD, the error relative to the block (see harness/gradcheck.py for how a block
below what finite differences resolve is judged). Run with `make test`.
"""

import json

import numpy as np
import pytest

from harness import engines
from harness import gradcheck as gc
from harness.engines.sampling import sample_transitions
from harness.__main__ import main

MODELS = ["cartpole", "double_pendulum", "half_cheetah"]
STATES, SEED = 3, 7
MUJOCO_FIELDS = ("mass", "com", "damping", "stiffness")


@pytest.fixture(scope="module", params=MODELS)
def doc(request):
    """One gradcheck per model, read by several tests."""
    return gc.gradcheck(request.param, STATES, SEED)


def worst(doc, oracle):
    return max(r[oracle] for r in doc["rows"] if r[oracle] is not None)


def test_every_block_within_the_thresholds(doc):
    failed = [(r["block"], r["ours_fd"], r["mujoco_fd"]) for r in doc["rows"] if not r["pass"]]
    assert not failed, f"{doc['model']}: blocks over the thresholds {gc.THRESHOLDS}: {failed}"
    assert worst(doc, "ours_fd") <= 1e-6 and worst(doc, "mujoco_fd") <= 1e-5
    assert doc["pass"]


def test_every_parameter_is_checked_and_mujoco_checks_what_it_can_change(doc):
    with engines.load("mujoco", doc["model"]) as e:
        names = e.ours().param_names()
    rows = {r["block"]: r for r in doc["rows"]}
    state = [f"d{o}'/d{i}" for o in "qv" for i in ("q", "v", "tau")]
    assert list(rows) == state + names
    for name in state + names:
        mujoco_can = name in state or name.rsplit("/", 1)[1] in MUJOCO_FIELDS
        assert (rows[name]["mujoco_fd"] is not None) == mujoco_can, name


@pytest.mark.parametrize("options, mode", [
    ({"rk4": True}, ("RK4", "explicit")), ({"eulerdamp": False}, ("Euler", "explicit")),
], ids=["rk4", "explicit_damping"])
def test_other_integrator_and_passive_mode_against_mujoco(options, mode):
    doc = gc.gradcheck("double_pendulum", 2, SEED, **options)
    assert (doc["integrator"], doc["passive"]) == mode
    assert doc["pass"], [r for r in doc["rows"] if not r["pass"]]


@pytest.mark.parametrize("options", [
    {"integrator": "RK4"}, {"passive": "explicit"}, {"passive": "implicit_damping_stiffness"},
], ids=lambda o: "-".join(o.values()))
def test_our_other_modes_against_our_differences(options):
    # DART's implicit damping and stiffness has no MuJoCo twin: ours-FD only.
    with engines.load("mujoco", "half_cheetah") as e:
        ours = e.ours().with_options(**options)
        states = sample_transitions(e, np.random.default_rng(SEED), 2)
        errors = gc.worst_errors(ours, ours, states, ours.param_names(), gc.param_stepper(e))
    assert max(r["error"] for r in errors.values()) <= gc.THRESHOLDS["ours_fd"]


def test_a_wrong_jacobian_fails():
    # The exact Jacobians of a pole 1e-4 heavier than the model being differenced.
    with engines.load("mujoco", "cartpole") as e:
        ours = e.ours()
        wrong = e.ours()
        wrong.set_param("body/pole/mass", ours.get_param("body/pole/mass") * (1 + 1e-4))
        states = sample_transitions(e, np.random.default_rng(SEED), 1)
        errors = gc.worst_errors(wrong, ours, states, ["body/pole/com"], gc.param_stepper(e))
    assert errors["dv'/dq"]["error"] > 1e-6
    assert errors["body/pole/com"]["error"] > 1e-6


def test_fd_jacobian_fourth_order_and_one_sided():
    def f(x):
        return np.array([np.sin(x[0]) * x[1], np.exp(x[1]), x[0] ** 5])

    x = np.array([0.3, 0.0])
    exact = np.array([[np.cos(0.3) * 0.0, np.sin(0.3)], [0.0, 1.0], [5 * 0.3 ** 4, 0.0]])
    for one_sided in (None, [True, True]):
        j, rho = gc.fd_jacobian(f, x, gc.state_steps(x), one_sided)
        assert np.abs(j - exact).max() < 1e-10
        assert np.all(rho >= 0) and rho.max() < 1e-10


def test_fd_jacobian_shrinks_a_refused_step():
    evaluated = []

    def f(x):
        evaluated.append(x[0])
        return x ** 2

    # from x = 1, steps 1e-3 and 1e-4 reach below 0.9999 (refused); 1e-5 is taken
    j, _ = gc.fd_jacobian(f, np.array([1.0]), [1e-3], accepts=lambda x: x[0] >= 0.9999)
    assert min(evaluated) == pytest.approx(1.0 - 2e-5, abs=1e-15)
    assert j[0, 0] == pytest.approx(2.0, abs=1e-9)
    with pytest.raises(ValueError, match="no accepted finite-difference step"):
        gc.fd_jacobian(f, np.array([1.0]), [1e-3], accepts=lambda x: False)


def test_block_error_is_relative_and_judges_zero_blocks_by_rounding():
    fd, rho = np.array([[2.0, 1e-3]]), np.full((1, 2), 1e-12)
    assert gc.block_error(fd + [[2e-6, 0.0]], fd, rho) == pytest.approx(1e-6)
    zero, noise = np.zeros((1, 2)), np.array([[3e-13, -2e-13]])
    assert gc.block_error(zero, noise, rho) <= 0.3e-6  # ours exactly 0, differences at rounding
    assert gc.block_error(zero + 1e-9, noise, rho) > 1e-6  # a real difference above rounding


def test_cli_writes_the_reports_and_same_seed_same_numbers(tmp_path, capsys):
    args = ["gradcheck", "--model", "cartpole", "--states", "2", "--seed", "3", "--out", str(tmp_path)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    md = (tmp_path / "gradcheck-cartpole.md").read_text()
    doc = json.loads((tmp_path / "gradcheck-cartpole.json").read_text())
    assert md.strip() == printed.strip()
    assert "| dv'/dq |" in md and "| body/pole/com |" in md and "**PASS**" in md
    assert doc["model"] == "cartpole" and doc["seed"] == 3 and doc["states"] == 2 and doc["pass"]
    assert main(args) == 0
    assert json.loads((tmp_path / "gradcheck-cartpole.json").read_text()) == doc


def test_cli_exits_1_when_a_block_fails(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(gc, "THRESHOLDS", {"ours_fd": 1e-30, "mujoco_fd": 1e-30})
    assert main(["gradcheck", "--model", "cartpole", "--states", "1", "--out", str(tmp_path)]) == 1
    assert "| FAIL |" in capsys.readouterr().out
    assert not json.loads((tmp_path / "gradcheck-cartpole.json").read_text())["pass"]


@pytest.mark.parametrize("name", ["hopper", "half_cheetah"])
def test_jacobians_in_contact_match_ours_and_mujocos_differences(name):
    """States in contact along MuJoCo's converged trajectory (harness/gradcheck_contact.py):
    every block kept is within its threshold, and the torso mass is checked at least
    against our own differences (a stencil across a switch or kink skips a state)."""
    from harness import gradcheck_contact as gcc

    doc = gcc.gradcheck_contact(name, 2, SEED)
    assert doc["pass"], gcc.markdown(doc)
    rows = {r["block"]: r for r in doc["rows"]}
    assert rows["body/torso/mass"]["ours_fd"] is not None


def test_free_and_ball_jacobians_against_mujoco(tmp_path):
    """Tangent-space step Jacobians of gymnasium's ant and humanoid and of free_ball in a wind
    against MuJoCo's mjd_transitionFD (harness/gradcheck_free.py); a model of nq != nv."""
    from harness import gradcheck_free

    assert main(["gradcheck-free", "--states", "2", "--out", str(tmp_path)]) == 0
    doc = json.loads((tmp_path / "gradcheck-free.json").read_text())
    ant = doc["cases"]["ant"]
    assert (ant["nq"], ant["nv"]) == (15, 14) and ant["errors"]["A"] < 1e-8, ant
    assert all(c["errors"]["A"] <= gradcheck_free.TOLERANCE for c in doc["cases"].values())


def test_a_chains_joint_parameters_are_stepped_at_their_own_scale():
    """pybullet_data's five-link pendulum5: a joint's damping and armature matter at the
    inertia its dof moves against with the others free, 1 / (M^-1)_jj, up to 280 times less
    than M_jj. Steps scaled by M_jj left truncation errors of 1.2e-2 against our exact
    Jacobians (MuJoCo's differences agreeing with ours); at the right scale every block passes."""
    import pybullet_data

    path = f"{pybullet_data.getDataPath()}/pendulum5.urdf"
    doc = gc.gradcheck(path, 2, SEED)
    assert doc["pass"], [(r["block"], r["ours_fd"], r["mujoco_fd"]) for r in doc["rows"] if not r["pass"]]
    with engines.load("mujoco", path) as e:
        mass = e.mass_matrix(e.q_ref)
        scale = gc.param_stepper(e)("joint/joint1/armature", np.zeros(1))[0] / gc.H
    assert scale == pytest.approx(1.0 / np.linalg.inv(mass)[1, 1]) and mass[1, 1] > 100 * scale
