"""DiffOSI on MuJoCo's transitions in contact: gymnasium's hopper and half cheetah standing on
their floors, the torso 30% heavier than the file says, five transitions under random
controls (MuJoCo's solver converged). Our constraint model is MuJoCo's and its step Jacobians
go through the solver, so the torso mass comes back to rounding. Run with `make test`."""

import mujoco
import numpy as np
import pytest

import diffosi
from harness.engines.base import gym_assets_dir


def transitions(path, body, factor, steps=5, settle=300, seed=0):
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.tolerance, m.opt.ls_tolerance, m.opt.iterations, m.opt.ls_iterations = 0.0, 1e-15, 1000, 100
    b = m.body(body).id
    m.body_mass[b] *= factor
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
    return float(m.body_mass[b]), [np.array(x) for x in zip(*rows)], contacts


@pytest.mark.parametrize("name", ["hopper", "half_cheetah"])
def test_torso_mass_from_five_transitions_in_contact(name):
    path = gym_assets_dir() / f"{name}.xml"
    truth, (q, v, tau, q1, v1), contacts = transitions(path, "torso", 1.3)
    assert min(contacts) > 0  # every transition in contact
    m = diffosi.Model.load(str(path))
    assert m.contact_model == "constraint"
    prior = m.get_param("body/torso/mass")[0]
    osi = diffosi.DiffOsi(m, params=["body/torso/mass"], lower=[0.1 * prior], upper=[3.0 * prior])
    est = osi.identify(q, v, tau, q1, v1, init=[prior])
    print(f"{name}: truth {truth}, prior {prior}, estimate {est['params'][0]}, loss {est['loss']:.1e}")
    assert est["flags"] == []
    assert abs(est["params"][0] - truth) <= 1e-6 * truth
