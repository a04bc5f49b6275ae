"""The quadruped task's model (src/tasks/quadruped/) against MuJoCo's (harness/engines/go1.py:
the same URDF through MuJoCo's importer, fusestatic off, with the task's additions made the same
way in an MjSpec), the one the transfer runs: one mj_step against one step of ours under the same
ctrl, and the forces an identifier is given for it."""

import mujoco
import numpy as np
import pytest

import diffosi
from harness.engines.go1 import MujocoGo1


def mujoco_go1(task, mu):
    """MuJoCo's Go1 (harness/engines/go1.py) with the task's mu applied by its named parameters."""
    engine = MujocoGo1()
    for name, value in task.mu_params(list(mu)).items():
        engine.set_param(name, value)
    return engine


def mj_step(engine, q, v, ctrl):
    engine.set_state(q, v)
    engine.step(np.zeros(len(v)), ctrl)
    return (*engine.get_state(), engine.d.ncon)


@pytest.fixture(scope="module")
def task():
    return diffosi.Task("quadruped")


def states(task, height, seed):
    """Reset states of the task, the base at `height`, with random velocities and actions."""
    rng = np.random.default_rng(seed)
    for k in range(5):
        q, v = task.reset(seed + k)
        q[2] = height
        v = rng.uniform(-0.5, 0.5, v.shape)
        yield q, v, rng.uniform(-1.0, 1.0, task.act_dim)


@pytest.mark.parametrize("mu", [(0.0, 0.0), (5.0, 0.07), (8.0, -0.1)])
def test_one_step_in_the_air_is_mujocos(task, mu):
    ours, theirs = task.model(list(mu)), mujoco_go1(task, mu)
    for q, v, action in states(task, 1.0, 1):
        ctrl = task.inputs(action)[1]
        q1, v1 = ours.step(q, v, np.zeros(18), ctrl=ctrl)
        mq, mv, ncon = mj_step(theirs, q, v, ctrl)
        assert ncon == 0
        assert np.max(np.abs(np.r_[q1 - mq, v1 - mv])) < 1e-10


@pytest.mark.parametrize("mu", [(0.0, 0.0), (5.0, 0.07)])
def test_one_step_with_the_feet_in_the_floor_is_mujocos(task, mu):
    """Feet spheres pressed 0.5 to 2 cm into the plane (sphere-plane contacts), and where the
    joint noise brings them down, calf boxes (box-plane)."""
    ours, theirs = task.model(list(mu)), mujoco_go1(task, mu)
    for q, v, action in states(task, 0.305, 2):
        ctrl = task.inputs(action)[1]
        q1, v1 = ours.step(q, v, np.zeros(18), ctrl=ctrl)
        mq, mv, ncon = mj_step(theirs, q, v, ctrl)
        assert ncon >= 4
        assert np.max(np.abs(np.r_[q1 - mq, v1 - mv])) < 1e-10


def test_the_forces_an_identifier_is_given_make_mujocos_servo_step(task):
    """The transfer pushes DiffOSI the MuJoCo step's start state and task.held_forces there: under
    them with zero ctrl ours makes MuJoCo's step under the servo targets, in contact too."""
    mu = (6.0, -0.04)
    ours, theirs = task.model(list(mu)), mujoco_go1(task, mu)
    for q, v, action in states(task, 0.305, 3):
        mq, mv, ncon = mj_step(theirs, q, v, task.inputs(action)[1])
        held = task.held_forces(q, v, action)
        assert ncon >= 4 and np.abs(held[6:]).max() > 1.0
        q1, v1 = ours.step(q, v, held)
        assert np.max(np.abs(np.r_[q1 - mq, v1 - mv])) < 1e-10
    assert (theirs.m.nq, theirs.m.nv, theirs.m.nu) == (ours.nq, ours.nv, 12)


def test_the_mujoco_go1_refuses_a_parameter_it_does_not_have():
    with pytest.raises(ValueError, match="no parameter 'body/trunk/mass'"):
        MujocoGo1().set_param("body/trunk/mass", 1.0)
