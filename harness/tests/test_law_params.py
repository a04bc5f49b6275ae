"""Actuator and equality named parameters against MuJoCo itself.

`actuator/<name>/gain` is MuJoCo's actuator_gainprm[:3], `actuator/<name>/bias`
its actuator_biasprm[:3] (a position servo: gain [kp, 0, 0], bias
[0, -kp, -kv]), `equality/<name>/solref` and `solimp` its eq_solref and
eq_solimp. Checked: the values read are MuJoCo's; a model edited through
them steps as MuJoCo with the same fields edited in place; their step
Jacobian columns equal central differences of our step; DiffOsi recovers a
servo's kp (and kv) and a connect's solref from MuJoCo's own transitions
to 1e-6; bad values and the integrators without these derivatives are
refused with the reason.
"""

import pathlib
import re

import mujoco
import numpy as np
import pytest

import diffosi

DATA = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data"
SOLVER = 'tolerance="1e-15" ls_tolerance="1e-12" iterations="1000"'


def models(tmp_path, file, options=""):
    text = (DATA / file).read_text()
    text = re.sub(r"<option ", f"<option {SOLVER} {options} ", text, count=1)
    path = tmp_path / file
    path.write_text(text)
    return mujoco.MjModel.from_xml_path(str(path)), diffosi.Model.load(str(path))


def random_state(m, rng):
    q = m.qpos0.copy()
    mujoco.mj_integratePos(m, q, rng.uniform(-0.2, 0.2, m.nv), 1.0)
    return q, rng.normal(size=m.nv), rng.normal(size=m.nv), rng.uniform(-1, 1, m.nu)


def mj_step(m, d, q, v, tau, ctrl):
    d.qpos[:], d.qvel[:], d.qfrc_applied[:], d.ctrl[:] = q, v, tau, ctrl
    mujoco.mj_step(m, d)
    return d.qpos.copy(), d.qvel.copy()


def test_values_are_mujocos_fields(tmp_path):
    m, ours = models(tmp_path, "servo_arm.xml")
    for i, name in enumerate(["servo", "spin", "push"]):
        assert list(ours.get_param(f"actuator/{name}/gain")) == list(m.actuator_gainprm[i, :3])
        if m.actuator_biastype[i]:
            assert list(ours.get_param(f"actuator/{name}/bias")) == list(m.actuator_biasprm[i, :3])
    m, ours = models(tmp_path, "equality_fourbar.xml")
    assert list(ours.get_param("equality/close/solref")) == list(m.eq_solref[0])
    assert list(ours.get_param("equality/close/solimp")) == list(m.eq_solimp[0])
    # Resolvable, not listed (param_names feeds every shipped model's gradcheck).
    assert not any(n.startswith(("actuator/", "equality/")) for n in ours.param_names())


EDITS = {
    "servo_arm.xml": [
        ("actuator/servo/gain", [35.0, 0.0, 0.0], "actuator_gainprm", 0),
        ("actuator/servo/bias", [0.1, -35.0, -2.5], "actuator_biasprm", 0),
        ("actuator/push/gain", [0.5, -0.4, 0.2], "actuator_gainprm", 2),
    ],
    "equality_fourbar.xml": [
        ("equality/close/solref", [0.01, 0.7], "eq_solref", 0),
        ("equality/close/solimp", [0.8, 0.9, 0.002, 0.4, 3.0], "eq_solimp", 0),
    ],
}


@pytest.mark.parametrize("file", list(EDITS))
def test_edited_models_step_as_mujoco_edited(tmp_path, file):
    m, ours = models(tmp_path, file)
    for name, value, field, row in EDITS[file]:
        ours.set_param(name, np.array(value))
        getattr(m, field)[row, : len(value)] = value
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, v, tau, ctrl = random_state(m, rng)
        q1, v1 = ours.step(q, v, tau, ctrl=ctrl) if m.nu else ours.step(q, v, tau)
        mq, mv = mj_step(m, d, q, v, tau, ctrl)
        np.testing.assert_allclose(q1, mq, rtol=0, atol=1e-10)
        np.testing.assert_allclose(v1, mv, rtol=0, atol=1e-10)


@pytest.mark.parametrize("file", list(EDITS))
def test_jacobians_match_central_differences(tmp_path, file):
    """Each scalar's column against our step at the parameter +- 1e-6; a
    fixed gain's gainprm[1:3] (read by nothing, not settable) are zero."""
    _, ours = models(tmp_path, file)
    m = mujoco.MjModel.from_xml_path(str(tmp_path / file))
    rng = np.random.default_rng(8)
    names = [e[0] for e in EDITS[file]]
    for _ in range(2):
        q, v, tau, ctrl = random_state(m, rng)
        kw = {"ctrl": ctrl} if m.nu else {}
        assert_columns_match_central_differences(
            ours, (q, v, tau), names, kw, unread=lambda name, k: name == "actuator/servo/gain" and k > 0
        )


def assert_columns_match_central_differences(ours, point, names, kw, unread=lambda name, k: False):
    """Each scalar's step Jacobian column at (q, v, tau) against our step at the parameter +- 1e-6
    (relative, 1e-6); a scalar nothing reads (`unread`) has a zero column."""
    q, v, tau = point
    J = ours.step_jacobians(q, v, tau, params=names, **kw)
    col = 0
    for name in names:
        base = ours.get_param(name)
        for k in range(len(base)):
            exact = np.concatenate([J["dq_dp"][:, col], J["dv_dp"][:, col]])
            col += 1
            if unread(name, k):
                assert not exact.any()
                continue
            h = 1e-6 * max(1.0, abs(base[k]))
            steps = []
            for sign in (1, -1):
                moved = base.copy()
                moved[k] += sign * h
                ours.set_param(name, moved)
                steps.append(np.concatenate(ours.step(q, v, tau, **kw)))
            ours.set_param(name, base)
            fd = (steps[0] - steps[1]) / (2 * h)
            scale = max(1.0, np.abs(fd).max())
            assert np.abs(exact - fd).max() / scale < 1e-6, f"{name}[{k}]"
    return J


def transitions(m, count, seed):
    """One mj_step from each of `count` random states, ctrl = 0."""
    d = mujoco.MjData(m)
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(count):
        q, v, tau, _ = random_state(m, rng)
        rows.append((q, v, tau, *mj_step(m, d, q, v, tau, np.zeros(m.nu))))
    return [np.array(x) for x in zip(*rows)]


def test_servo_kp_and_kv_identified_from_mujoco(tmp_path):
    """At ctrl = 0 a position servo's force is its bias, 0 - kp l - kv l':
    its bias recovers kp = 20 and kv = 1.5 (MuJoCo's biasprm) from a start
    at half and double."""
    m, ours = models(tmp_path, "servo_arm.xml")
    ours.set_param("actuator/servo/bias", np.array([0.0, -10.0, -3.0]))
    osi = diffosi.DiffOsi(
        ours, params=["actuator/servo/bias"], lower=[-1.0, -100.0, -10.0], upper=[1.0, 0.0, 0.0]
    )
    est = osi.identify(*transitions(m, 30, 1))
    np.testing.assert_allclose(est["params"], m.actuator_biasprm[0, :3], rtol=0, atol=1e-6)
    assert abs(-est["params"][1] - 20.0) < 1e-6


def test_equality_solref_identified_from_mujoco(tmp_path):
    """A four-bar's connect at solref (0.015, 0.8) in MuJoCo, recovered from
    (0.03, 1.2)."""
    m, ours = models(tmp_path, "equality_fourbar.xml")
    m.eq_solref[0] = [0.015, 0.8]
    ours.set_param("equality/close/solref", np.array([0.03, 1.2]))
    osi = diffosi.DiffOsi(
        ours, params=["equality/close/solref"], lower=[0.005, 0.2], upper=[0.1, 3.0]
    )
    est = osi.identify(*transitions(m, 30, 2))
    np.testing.assert_allclose(est["params"], [0.015, 0.8], rtol=0, atol=1e-6)


def test_bad_values_and_names_are_refused(tmp_path):
    _, ours = models(tmp_path, "servo_arm.xml")
    cases = [
        ("actuator/servo/gain", [20.0, 1.0, 0.0], "fixed gain (gaintype fixed) reads gainprm[0] only"),
        ("actuator/servo/bias", [0.0, -20.0, 1.0], "reads as a damping ratio"),
        ("actuator/push/bias", [0.0, 0.0, 0.0], "actuator 'push' has no bias (biastype none)"),
        ("actuator/nope/gain", [1.0, 0.0, 0.0], "no actuator named 'nope'"),
        ("actuator/servo/kp", [1.0], "actuator fields are gain, bias"),
        ("actuator/servo/gain", [np.nan, 0.0, 0.0], "not finite"),
    ]
    for name, value, message in cases:
        with pytest.raises(ValueError, match=re.escape(message)):
            ours.set_param(name, np.array(value))
    assert list(ours.get_param("actuator/servo/gain")) == [20.0, 0.0, 0.0]
    _, four = models(tmp_path, "equality_fourbar.xml")
    with pytest.raises(ValueError, match=re.escape("equality 'close': solref [0.02, -1.0]")):
        four.set_param("equality/close/solref", np.array([0.02, -1.0]))
    with pytest.raises(ValueError, match="no equality named 'open'"):
        four.get_param("equality/open/solimp")
    # RK4 with a servo: every block from dual numbers, which do not carry
    # the actuators' gain and bias yet.
    m, rk4 = models(tmp_path, "servo_arm.xml", 'integrator="RK4"')
    q, v, tau, ctrl = random_state(m, np.random.default_rng(0))
    with pytest.raises(ValueError, match="not supported yet under the Rk4 integrator"):
        rk4.step_jacobians(q, v, tau, params=["actuator/servo/gain"], ctrl=ctrl)
