"""Contacts at the Python boundary (Model.contacts, Model.body_contact_forces; the smooth
model's forces and the constraint model's), the resting box in our engine and the three
references, and `python -m harness contact` on a short horizon (against MuJoCo model by
model). Run with `make test`."""

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

import diffosi
from harness import contact

MODELS = Path(__file__).resolve().parents[2] / "reference_models"
BOX = str(MODELS / "box.xml")
CHEETAH = str(MODELS / "half_cheetah.xml")
KEYS = {"geoms", "bodies", "point", "normal", "depth", "normal_force", "friction", "force", "torque", "frame",
        "frame_force"}


def sunk_box(depth=0.002):
    """The box level, `depth` into the floor, at rest (the smooth contact model)."""
    m = diffosi.Model.load(BOX).with_options(contact_model="smooth")
    q = np.zeros(6)
    q[2] = -depth
    return m, q, np.zeros(6)


# ---------------------------------------------------------------- the bindings


def test_contacts_of_a_sunk_box():
    m, q, v = sunk_box()
    contacts = m.contacts(q, v)
    assert len(contacts) == 4  # the bottom corners; the top ones are beyond the cut-off
    k = m.get_param("contact/stiffness")[0]
    for c in contacts:
        assert set(c) == KEYS
        assert c["geoms"] == ("box", "floor") and c["bodies"] == ("box", "world")
        assert c["depth"] == pytest.approx(0.002, abs=1e-15)
        np.testing.assert_array_equal(c["normal"], [0.0, 0.0, 1.0])
        assert abs(c["point"][2] + 0.001) < 1e-15  # halfway between the surfaces
        np.testing.assert_allclose(np.abs(c["point"][:2]), [0.2, 0.15], rtol=0, atol=1e-15)
        # at rest: the elastic force alone, k w ln(1 + e^(d / w)) (default width w = 1 mm); no friction
        assert c["normal_force"] == pytest.approx(k * 1e-3 * np.log1p(np.exp(2.0)), rel=1e-12)
        np.testing.assert_array_equal(c["friction"], np.zeros(3))
        np.testing.assert_allclose(c["force"], c["normal_force"] * c["normal"] + c["friction"], rtol=1e-15)


def test_body_forces_sum_the_contacts():
    m, q, v = sunk_box()
    v[0], v[5] = 0.2, -0.5  # sliding and spinning: friction too
    contacts = m.contacts(q, v)
    forces = m.body_contact_forces(q, v)
    assert forces.shape == (len(m.body_names), 3)
    box, world = m.body_names.index("box"), m.body_names.index("world")
    np.testing.assert_allclose(forces[box], sum(c["force"] for c in contacts), rtol=1e-15)
    np.testing.assert_array_equal(forces[world], -forces[box])
    assert forces[box][0] < 0  # friction opposes the slide
    for c in contacts:
        assert np.dot(c["friction"], c["normal"]) == pytest.approx(0.0, abs=1e-12)


def test_contacts_are_what_the_step_applies():
    m, q, v = sunk_box()
    q1, v1 = m.step(q, v, np.zeros(6))
    fz = m.body_contact_forces(q, v)[m.body_names.index("box")][2]
    assert v1[2] == pytest.approx(m.timestep * (fz / contact.BOX_MASS - 9.81), rel=1e-12)


def test_no_contacts_when_switched_off_or_far():
    m, q, v = sunk_box()
    off = m.with_options(contact=False)
    assert off.contacts(q, v) == []
    assert not off.body_contact_forces(q, v).any()
    q[2] = 1.0  # a metre up: beyond the cut-off
    assert m.contacts(q, v) == []


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_state_is_refused(bad):
    m, q, v = sunk_box()
    for args in [(np.where(np.arange(6) == 2, bad, q), v), (q, np.where(np.arange(6) == 4, bad, v))]:
        with pytest.raises(ValueError, match="not finite"):
            m.contacts(*args)
        with pytest.raises(ValueError, match="not finite"):
            m.body_contact_forces(*args)


def test_bad_shapes_and_huge_states_are_refused():
    m, q, v = sunk_box()
    for args in [(q[:5], v), (q, np.zeros((6, 2))), ("fast", v), (None, v)]:
        with pytest.raises((ValueError, TypeError)):
            m.contacts(*args)
        with pytest.raises((ValueError, TypeError)):
            m.body_contact_forces(*args)
    q[2] = -1e300  # deep but finite: finite forces
    assert np.isfinite(m.body_contact_forces(q, v)).all()
    q[2] = -1e306  # k d overflows: refused, never inf or a panic
    with pytest.raises(ValueError, match="not finite"):
        m.contacts(q, v)
    with pytest.raises(ValueError, match="not finite"):
        m.body_contact_forces(q, v)


def test_half_cheetah_contacts_name_its_geoms():
    m = diffosi.Model.load(CHEETAH).with_options(contact_model="smooth")
    q, v = np.zeros(9), np.zeros(9)
    q[1] = -0.2  # torso 0.5 m up: the feet in the floor
    contacts = m.contacts(q, v)
    touching = {c["geoms"][0] for c in contacts if c["depth"] > 0}
    assert {"bfoot", "ffoot"} <= touching
    assert all(c["geoms"][1] == "floor" and c["bodies"][1] == "world" for c in contacts)
    lift = m.body_contact_forces(q, v)[1:, 2].sum()
    assert lift == pytest.approx(sum(c["normal_force"] for c in contacts), rel=1e-12)


def test_constraint_contacts_carry_what_the_step_applies():
    """Under the constraint model (the MJCF default) the forces are the solver's: they
    depend on the applied forces, sum to the weight at rest, and come with MuJoCo's frame."""
    m = diffosi.Model.load(BOX)
    q, v = np.zeros(6), np.zeros(6)
    q[2] = -0.001  # 1 mm in the floor
    tau = np.zeros(6)
    rest = m.contacts(q, v, tau)
    assert len(rest) == 4 and all(c["geoms"] == ("box", "floor") for c in rest)
    assert all(c["depth"] == pytest.approx(0.001, abs=1e-15) for c in rest)
    pushed = m.contacts(q, v, np.array([0, 0, -50.0, 0, 0, 0]))
    assert sum(c["normal_force"] for c in pushed) > sum(c["normal_force"] for c in rest) + 40
    # The step's vertical velocity change is the contact force's, (f - m g) h / m.
    q1, v1 = m.step(q, v, tau)
    fz = m.body_contact_forces(q, v, tau)[m.body_names.index("box")][2]
    assert v1[2] == pytest.approx(m.timestep * (fz / contact.BOX_MASS - 9.81), rel=1e-12)
    with pytest.raises(ValueError, match="tau"):
        m.contacts(q, v, np.zeros(5))
    # The force in MuJoCo's contact frame (mj_contactForce): rows normal, tangents.
    for c in rest:
        np.testing.assert_allclose(c["frame"] @ c["frame"].T, np.eye(3), atol=1e-15)
        np.testing.assert_array_equal(c["frame"][0], c["normal"])
        assert c["frame_force"][0] == c["normal_force"]
        np.testing.assert_allclose(c["frame"][1:].T @ c["frame_force"][1:3], c["friction"], atol=1e-12)


# ---------------------------------------------------------------- the resting box


@pytest.mark.parametrize("engine", ["ours", "mujoco", "pybullet", "dart"])
def test_resting_box_carries_its_weight(engine):
    r = contact.resting_box(engine)
    print(f"{engine}: normal force {r['normal_force']!r} N, weight {r['weight']} N, "
          f"relative error {r['relative_error']:.1e} ({r['read_with']})")
    assert r["relative_error"] <= 1e-6
    assert r["max_speed"] < 1e-3  # settled


# ---------------------------------------------------------------- the command


def run_contact(out, *extra):
    parser = argparse.ArgumentParser()
    contact.add_arguments(parser)
    return contact.run(parser.parse_args(["--steps", "40", "--samples", "20", "--seed", "2",
                                          "--out", str(out), *extra]))


def finite_numbers(x) -> bool:
    if isinstance(x, dict):
        return all(finite_numbers(v) for v in x.values())
    if isinstance(x, list):
        return all(finite_numbers(v) for v in x)
    return not isinstance(x, float) or np.isfinite(x)


def test_contact_command_reports_finite_numbers(tmp_path):
    assert run_contact(tmp_path) == 0
    doc = json.loads((tmp_path / "contact-half_cheetah.json").read_text())
    assert doc["pass"] and finite_numbers(doc)
    assert set(doc["sequences"]) == {"random", "gait"}
    for name, seq in doc["sequences"].items():
        for engine in ("mujoco", "ours", "pybullet"):
            assert len(seq[engine]["force"]) == 40, (name, engine)
        assert max(seq["mujoco"]["force"]) > 100  # it lands: some 14 kg on the floor
        assert seq["ours"]["error"][1] < 1e-12  # the first steps fall freely: the same model
        free = seq["one_step"]["free"]["ours"]
        assert free["states"] > 0 and free["max_error"] <= 1e-9, (name, free)
        touching = seq["one_step"]["contact"]["ours"]
        assert touching["states"] > 0 and touching["max_error"] <= 1e-9, (name, touching)
    # MuJoCo's contact, model by model: one step from MuJoCo's own states in contact.
    models = {a["model"]: a for a in doc["agreement"]}
    assert set(models) == {"half_cheetah", "box", "free_box", "wiping_arm", "hopper", "walker2d", "ant",
                           "humanoid", "features_pyramidal", "features_elliptic", "box_stack", "capsule_box",
                           "overlapping_chain"}
    for name, a in models.items():
        assert a["pass"] and a["one_step"]["contact"]["states"] > 0, (name, a["one_step"])
        # the chain: 4704 rows on 50 dofs, the Newton system's conditioning
        assert a["one_step"]["contact"]["max"] <= (1e-10 if name == "overlapping_chain" else 1e-12), name
        assert a["normal_force"]["max_relative_gap"] <= 1e-9, (name, a["normal_force"])
    assert models["walker2d"]["one_step"]["limit"]["states"] > 0  # limits alone, too
    md = (tmp_path / "contact-half_cheetah.md").read_text()
    assert "Result: PASS" in md and "solref" in md and "missing_armature" in md
    assert (tmp_path / "contact-half_cheetah.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_contact_command_is_seeded(tmp_path):
    run_contact(tmp_path / "a")
    run_contact(tmp_path / "b")
    assert (tmp_path / "a" / "contact-half_cheetah.json").read_text() == \
        (tmp_path / "b" / "contact-half_cheetah.json").read_text()
