"""The quadruped task's model (src/tasks/quadruped/) against MuJoCo: the same URDF through
MuJoCo's importer, with the task's additions made the same way in an MjSpec (free base, floor,
floor-only collisions, position servos, the base inertia MuJoCo accepts, the payload body), one
mj_step against one step of ours under the same ctrl.

MuJoCo's importer fuses the URDF's fixed links into their parents by default (compiler
fusestatic); ours keeps them as welded bodies. Without contact that is the same model; in contact
it is not: a contact's softness reads its bodies' invweight0, and a foot's own body is lighter to
push than the fused calf (0.03 m/s apart after one step). So MuJoCo runs with fusestatic off
here, as the harness's transfer must (issue 41)."""

import mujoco
import numpy as np
import pytest

import diffosi
from harness.engines.base import MODELS

URDF = MODELS / "go1" / "go1.urdf"
KP, KD = 20.0, 0.5
PAYLOAD_BOX = np.array([0.2, 0.1, 0.05])
LEGS, PARTS = ("FR", "FL", "RR", "RL"), ("hip", "thigh", "calf")


def mujoco_go1(mu):
    """The task's model for mu = (payload mass, COM offset) built on MuJoCo's URDF import."""
    spec = mujoco.MjSpec.from_file(str(URDF))
    spec.compiler.fusestatic = False
    base = spec.body("base")
    base.fullinertia = [1e-6, 1e-6, 1e-6, 0.0, 0.0, 0.0]
    base.add_freejoint()
    spec.option.timestep = 0.005
    for geom in spec.geoms:
        geom.contype, geom.conaffinity = 1, 0
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], contype=0,
                            conaffinity=1, friction=[1.0, 0.005, 0.0001])
    a, b, c = PAYLOAD_BOX**2 / 12
    spec.body("trunk").add_body(name="payload", mass=mu[0], ipos=[mu[1], 0.0, 0.082],
                                inertia=mu[0] * np.array([b + c, a + c, a + b]))
    for leg in LEGS:
        for part in PARTS:
            effort = 35.55 if part == "calf" else 23.7
            spec.add_actuator(target=f"{leg}_{part}_joint", trntype=mujoco.mjtTrn.mjTRN_JOINT,
                              gainprm=[KP] + [0.0] * 9, biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                              biasprm=[0.0, -KP, -KD] + [0.0] * 7, forcelimited=True,
                              forcerange=[-effort, effort])
    return spec.compile()


def mj_step(m, q, v, ctrl):
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.ctrl[:] = q, v, ctrl
    mujoco.mj_step(m, d)
    return d.qpos.copy(), d.qvel.copy(), d.ncon


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
    ours, theirs = task.model(list(mu)), mujoco_go1(mu)
    assert (theirs.nq, theirs.nv, theirs.nu) == (ours.nq, ours.nv, 12)
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
    ours, theirs = task.model(list(mu)), mujoco_go1(mu)
    for q, v, action in states(task, 0.305, 2):
        ctrl = task.inputs(action)[1]
        q1, v1 = ours.step(q, v, np.zeros(18), ctrl=ctrl)
        mq, mv, ncon = mj_step(theirs, q, v, ctrl)
        assert ncon >= 4
        assert np.max(np.abs(np.r_[q1 - mq, v1 - mv])) < 1e-10
