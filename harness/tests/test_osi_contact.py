"""DiffOSI on MuJoCo's transitions in contact: gymnasium's hopper and half cheetah standing on
their floors, five transitions under random controls (MuJoCo's solver converged). The torso is
30% heavier than the file says, alone or with the floor's friction or solref changed too. Our
constraint model is MuJoCo's and its step Jacobians go through the solver, so the parameters
come back to rounding. Run with `make test`."""

import mujoco
import numpy as np
import pytest

import diffosi
from harness.engines.base import gym_assets_dir
from harness.engines.mujoco import converge, load_mjcf


def transitions(path, edit, steps=5, settle=300, seed=0):
    """MuJoCo's model of `path` edited by `edit(model)`, and W = `steps` transitions
    (q, v, tau, q', v') after `settle` steps at rest, and the contacts at each."""
    m = load_mjcf(path)
    converge(m.opt)
    edit(m)
    mujoco.mj_setConst(m, mujoco.MjData(m))  # invweight0 for the new mass, as ours recomputes it
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, settle)  # feet on the floor
    rng = np.random.default_rng(seed)
    rows, contacts = [], []
    for _ in range(steps):
        d.ctrl[:] = rng.uniform(-0.5, 0.5, m.nu)
        q, v = d.qpos.copy(), d.qvel.copy()
        mujoco.mj_forward(m, d)
        tau = d.qfrc_actuator.copy()
        contacts.append(int(d.ncon))
        mujoco.mj_step(m, d)
        rows.append((q, v, tau, d.qpos.copy(), d.qvel.copy()))
    return m, [np.array(x) for x in zip(*rows)], contacts


def heavier_torso(m):
    m.body_mass[m.body("torso").id] *= 1.3


@pytest.mark.parametrize("name", ["hopper", "half_cheetah"])
def test_torso_mass_from_five_transitions_in_contact(name):
    path = gym_assets_dir() / f"{name}.xml"
    mj, (q, v, tau, q1, v1), contacts = transitions(path, heavier_torso)
    truth = mj.body_mass[mj.body("torso").id]
    assert min(contacts) > 0  # every transition in contact
    m = diffosi.Model.load(str(path))
    assert m.contact_model == "constraint"
    prior = m.get_param("body/torso/mass")[0]
    osi = diffosi.DiffOsi(m, params=["body/torso/mass"], lower=[0.1 * prior], upper=[3.0 * prior])
    est = osi.identify(q, v, tau, q1, v1, init=[prior])
    print(f"{name}: truth {truth}, prior {prior}, estimate {est['params'][0]}, loss {est['loss']:.1e}")
    assert est["flags"] == []
    assert abs(est["params"][0] - truth) <= 1e-6 * truth


@pytest.mark.parametrize("name", ["hopper", "half_cheetah"])
def test_floor_solref_jointly_with_the_torso_mass(name):
    """The floor's solref (time constant, damping ratio) mixes with each body geom's into
    the pair's (solmix); both move the contact forces of a standing robot."""
    def edit(m):
        heavier_torso(m)
        m.geom_solref[m.geom("floor").id] = [0.03, 0.8]

    path = gym_assets_dir() / f"{name}.xml"
    mj, (q, v, tau, q1, v1), contacts = transitions(path, edit)
    assert min(contacts) > 0
    truth = np.array([mj.body_mass[mj.body("torso").id], 0.03, 0.8])
    m = diffosi.Model.load(str(path))
    prior = m.get_param("body/torso/mass")[0]
    osi = diffosi.DiffOsi(m, params=["body/torso/mass", "geom/floor/solref"],
                          lower=[0.1 * prior, 0.021, 0.3], upper=[3.0 * prior, 0.2, 3.0])
    est = osi.identify(q, v, tau, q1, v1, init=[prior, 0.025, 1.0])
    print(f"{name}: truth {truth}, estimate {est['params']}, {est['iterations']} iterations")
    assert est["flags"] == []
    assert np.all(np.abs(est["params"] - truth) <= 1e-4 * truth)


@pytest.mark.parametrize("name, friction", [("hopper", 2.5), ("half_cheetah", 0.7)])
def test_floor_friction_jointly_with_the_torso_mass(name, friction):
    """A pair takes the larger of its geoms' frictions: a floor more slippery than the feet
    cannot be seen, one grippier can (the hopper's foot, at 2.0, hides a floor below 2: its
    solve from the file's 1.0 finds the truth on a restart). condim 3 leaves the torsional and
    rolling components without effect: they are reported unexcited."""
    def edit(m):
        heavier_torso(m)
        m.geom_friction[m.geom("floor").id, 0] = friction

    path = gym_assets_dir() / f"{name}.xml"
    mj, (q, v, tau, q1, v1), contacts = transitions(path, edit)
    assert min(contacts) > 0
    m = diffosi.Model.load(str(path))
    prior = m.get_param("body/torso/mass")[0]
    f0 = m.get_param("geom/floor/friction")
    osi = diffosi.DiffOsi(m, params=["body/torso/mass", "geom/floor/friction"],
                          lower=[0.1 * prior, 0.1, 0.0, 0.0], upper=[3.0 * prior, 5.0, 1.0, 1.0])
    est = osi.identify(q, v, tau, q1, v1, init=[prior, *f0])
    truth = [mj.body_mass[mj.body("torso").id], friction]
    print(f"{name}: truth {truth}, estimate {est['params']}, {est['iterations']} iterations")
    assert est["flags"] == ["unexcited"]
    assert np.all(np.abs(est["params"][:2] - truth) <= 1e-4 * np.array(truth))
