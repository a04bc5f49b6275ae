"""Our engine against MuJoCo, PyBullet and DART through the adapters in harness/engines.

For each contact-free reference model and each engine, `engine.ours()` is our model run
as that engine runs the file (its file twin, timestep, gravity, integrator, passive-force
mode; what the engine ignores zeroed). Errors are max(|dq| / max(1, |q|), |dv| / max(1, |v|))
(harness/engines/numpy_step.step_error); mass matrices max |dM| / max |M|. Our M comes
out of one step: with explicit passive forces and h = 1, dv'/dtau = M^-1.
Run with `make test`.
"""

import numpy as np
import pytest

from harness import engines
from harness.engines.numpy_step import step_error
from harness.engines.sampling import sample_rollout, sample_state, sample_transition, sample_transitions, tau_scale
from harness.golden import ROLLOUT_TAU_FRACTION, case_seed

MODELS = ["cartpole", "pendulum", "double_pendulum", "half_cheetah", "wiping_arm"]
CASES = [(e, m) for e in engines.ENGINES for m in MODELS]
ONE_STEP_TOL, ROLLOUT_TOL, MASS_TOL = 1e-12, 1e-9, 1e-12
SAMPLES, STEPS = 100, 500


def ids(case):
    return "-".join(case)


def worst_one_step(e, ours, rng, n=SAMPLES):
    worst = 0.0
    for q, v, tau in sample_transitions(e, rng, n):
        e.reset()
        e.set_state(q, v)
        e.step(tau)
        worst = max(worst, step_error(*ours.step(q, v, tau), *e.get_state()))
    return worst


def our_mass_matrix(ours, q):
    unit = ours.with_options(timestep=1.0, passive="explicit")
    zero = np.zeros(ours.nv)
    return np.linalg.inv(unit.step_jacobians(q, zero, zero)["dv_dtau"])


def worst_mass_matrix(e, ours, rng, n=20):
    worst = 0.0
    for q, _, _ in sample_transitions(e, rng, n):
        theirs = e.mass_matrix(q)
        worst = max(worst, np.abs(our_mass_matrix(ours, q) - theirs).max() / np.abs(theirs).max())
    return worst


@pytest.mark.parametrize("case", CASES, ids=ids)
def test_one_step(case):
    with engines.load(*case) as e:
        worst = worst_one_step(e, e.ours(), case_seed(1, ids(case)))
    assert worst <= ONE_STEP_TOL, f"{ids(case)}: one-step error {worst:.1e} over {SAMPLES} samples"


@pytest.mark.parametrize("case", CASES, ids=ids)
def test_rollout(case):
    with engines.load(*case) as e:
        scale = tau_scale(e) * ROLLOUT_TAU_FRACTION
        q0, v0, taus = sample_rollout(e, case_seed(2, ids(case)), scale, STEPS)
        Q, V = e.ours().rollout(q0, v0, taus)
        e.reset()
        e.set_state(q0, v0)
        worst = 0.0
        for t, tau in enumerate(taus):
            e.step(tau)
            worst = max(worst, step_error(Q[t + 1], V[t + 1], *e.get_state()))
    assert np.abs(V).max() < 100.0, f"{ids(case)}: the rollout is not well-behaved"
    assert worst <= ROLLOUT_TOL, f"{ids(case)}: {STEPS}-step rollout error {worst:.1e}"


@pytest.mark.parametrize("case", CASES, ids=ids)
def test_mass_matrix(case):
    with engines.load(*case) as e:
        worst = worst_mass_matrix(e, e.ours(), case_seed(3, ids(case)))
    assert worst <= MASS_TOL, f"{ids(case)}: mass matrix relative error {worst:.1e}"


def changes(e):
    """A COM, a mass, a damping and (where the engine has joint springs) a stiffness of the
    model's last body and last joint, each moved well away from the file's value."""
    body, joint = e.body_names[-1], e.joint_names[-1]
    out = {f"body/{body}/com": e.get_param(f"body/{body}/com") + [0.03, -0.02, 0.05],
           f"body/{body}/mass": e.get_param(f"body/{body}/mass") * 1.5,
           f"joint/{joint}/damping": e.get_param(f"joint/{joint}/damping") + 0.2}
    if e.name != "pybullet":
        out[f"joint/{joint}/stiffness"] = e.get_param(f"joint/{joint}/stiffness") + 1.5
    return out


@pytest.mark.parametrize("case", CASES, ids=ids)
def test_parameter_setters_agree(case):
    with engines.load(*case) as e:
        wanted = changes(e)
        for name, value in wanted.items():
            e.set_param(name, value)
        for name, value in wanted.items():
            np.testing.assert_array_equal(e.get_param(name), value, err_msg=name)
        ours = e.ours()
        for name, value in wanted.items():
            np.testing.assert_array_equal(ours.get_param(name), value, err_msg=name)
        one_step = worst_one_step(e, ours, case_seed(4, ids(case)), n=20)
        mass = worst_mass_matrix(e, ours, case_seed(5, ids(case)))
        # the change is seen: the file's model steps differently
        with engines.load(*case) as unchanged:
            plain = unchanged.ours()
        q, v, tau = sample_transitions(e, case_seed(6, ids(case)), 1)[0]
        moved = step_error(*ours.step(q, v, tau), *plain.step(q, v, tau))
    assert one_step <= ONE_STEP_TOL, f"{ids(case)}: one-step error {one_step:.1e} after {list(wanted)}"
    assert mass <= MASS_TOL, f"{ids(case)}: mass matrix relative error {mass:.1e} after {list(wanted)}"
    assert moved > 1e-6, f"{ids(case)}: the changed parameters made no difference ({moved:.1e})"


@pytest.mark.parametrize("engine", engines.ENGINES)
def test_unknown_or_unsupported_parameters_raise(engine):
    with engines.load(engine, "cartpole") as e:
        for name in ["body/nobody/mass", "joint/hinge/friction", "body/pole/inertia", "pole/mass"]:
            with pytest.raises(ValueError, match="unknown parameter"):
                e.set_param(name, 1.0)
        with pytest.raises(ValueError, match="3 finite"):
            e.set_param("body/pole/com", [0.0, 0.0])
        with pytest.raises(ValueError, match="negative"):
            e.set_param("body/pole/mass", -1.0)
        if engine == "pybullet":
            with pytest.raises(ValueError, match="no joint springs"):
                e.set_param("joint/hinge/stiffness", 1.0)


def test_model_names_and_paths():
    assert engines.model_path("mujoco", "cartpole").name == "cartpole.xml"
    assert engines.model_path("dart", "cartpole").name == "cartpole.urdf"
    with pytest.raises(ValueError, match="unknown engine"):
        engines.load("bullet", "cartpole")
    with pytest.raises(ValueError, match="no model file"):
        engines.load("mujoco", "no_such_model")


@pytest.mark.parametrize("engine", ["pybullet", "dart"])
def test_a_free_base_speaks_mujocos_convention(engine):
    """The floating arm's URDF twin: PyBullet's free base and DART's FreeJoint read and
    written in MuJoCo's convention (harness/engines/floating.py) take our engine's steps, and
    keep doing so after the base's mass and a link's COM change. The base turns by more
    than DART's series threshold in every step (see the test below)."""
    with engines.load(engine, "floating_arm") as e:
        assert (e.free.name, len(e.q_ref), e.nv) == ("root", 9, 8)
        rng = case_seed(7, engine)
        q, v = sample_state(e, rng)
        q[3:7] *= -1 if q[3] > 0 else 1  # w < 0: the sign a user gave is the sign read back
        e.set_state(q, v)
        back_q, back_v = e.get_state()
        assert np.abs(back_q - q).max() < 1e-15 and np.abs(back_v - v).max() < 1e-14
        assert worst_free_step(e, e.ours(), rng) <= ONE_STEP_TOL
        q0, v0, taus = sample_rollout(e, rng, FREE_TAU * ROLLOUT_TAU_FRACTION, STEPS)
        v0[3:6] = turning(rng)
        Q, V = e.ours().rollout(q0, v0, taus)
        E = e.rollout(q0, v0, taus)
        assert max(step_error(*ours, *theirs) for ours, theirs in zip(zip(Q, V), zip(*E))) <= ROLLOUT_TOL
        for name, value in {"body/base/mass": 6.0, "body/lower/com": [0.12, 0.0, 0.03]}.items():
            e.set_param(name, value)
            np.testing.assert_array_equal(e.get_param(name), np.atleast_1d(value), err_msg=name)
        assert worst_free_step(e, e.ours(), rng) <= ONE_STEP_TOL
        with pytest.raises(NotImplementedError, match="not converted"):
            e.mass_matrix(e.q_ref)


FREE_TAU = np.r_[[60.0] * 3, [1.0] * 3, [1.0] * 2]  # the floating arm's forces (N), torques (N m)


def turning(rng) -> np.ndarray:
    """A base angular velocity of 1 to 2 rad/s: |w| h >= 2e-3 at h = 0.002."""
    w = rng.normal(size=3)
    return w / np.linalg.norm(w) * rng.uniform(1.0, 2.0)


def worst_free_step(e, ours, rng, n=SAMPLES):
    worst = 0.0
    for _ in range(n):
        q, v, tau = sample_transition(e, rng, FREE_TAU)
        v[3:6] = turning(rng)
        e.reset()
        e.set_state(q, v)
        e.step(tau)
        worst = max(worst, step_error(*ours.step(q, v, tau), *e.get_state()))
    return worst


def test_floating_base_floats_the_root_link_as_pybullets_load_urdf(tmp_path):
    """A URDF whose root link is not `world` (the floating arm without its world link and
    floating joint): by default welded to the world (MuJoCo's importer, Pinocchio);
    Model.load(path, floating_base=True) gives it a free joint 'root_joint' at the origin,
    and PyBullet's loadURDF with useFixedBase=False (its default) takes the same steps."""
    import xml.etree.ElementTree as ET

    import diffosi
    from harness.engines.base import MODELS

    ET.register_namespace("diffosi", "urn:diffosi:urdf")
    tree = ET.parse(MODELS / "floating_arm.urdf")
    robot = tree.getroot()
    robot.remove(robot.find("link[@name='world']"))
    robot.remove(robot.find("joint[@name='root']"))
    path = tmp_path / "arm.urdf"
    tree.write(path)
    fixed = diffosi.Model.load(str(path))
    assert (fixed.nq, fixed.joint_address(fixed.joint_names[0])) == (2, (0, 0))
    with engines.load("pybullet", path, floating_base=True) as e:
        assert (e.free.name, len(e.q_ref), e.nv, e.settings["fixed_base"]) == ("root_joint", 9, 8, False)
        ours = e.ours()
        assert ours.joint_names[0] == "root_joint"
        assert [ours.joint_address(n) for n in ours.joint_names] == [(0, 0), (7, 6), (8, 7)]
        np.testing.assert_array_equal(ours.reference_q(), e.q_ref)
        assert worst_free_step(e, ours, case_seed(7, "floating_base")) <= ONE_STEP_TOL
    with pytest.raises(ValueError, match="no joint named 'knee'"):
        ours.joint_address("knee")
    with pytest.raises(ValueError, match="floating_base applies to URDF files"):
        diffosi.Model.load(str(MODELS / "floating_arm.xml"), floating_base=True)


def test_inertial_reads_a_link_as_pinocchio_or_as_pybullet(tmp_path):
    """Model.load(path, inertial=...): a link without <inertial> is massless by default (the
    URDF spec, Pinocchio) and has PyBullet's 1 kg under inertial="pybullet"; an inertia whose
    principal moments violate the triangle inequality is kept as written, or zeroed as
    PyBullet zeroes it (its getDynamicsInfo shows the same). Bad values and MJCF refuse."""
    import pybullet

    import diffosi
    from harness.engines.base import MODELS

    path = tmp_path / "arm.urdf"
    limit = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
    path.write_text(f"""<robot name="arm">
<link name="base"/><link name="upper"/>
<link name="lower"><inertial><origin xyz="0 0 0.5"/><mass value="2"/>
<inertia ixx="0" iyy="0" izz="3e-6" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="a" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>{limit}</joint>
<joint name="b" type="revolute"><parent link="upper"/><child link="lower"/><axis xyz="0 1 0"/>{limit}</joint>
</robot>""")
    with pytest.warns(UserWarning):
        ours = {r: diffosi.Model.load(str(path), inertial=r) for r in ("pinocchio", "pybullet")}
    p = pybullet.connect(pybullet.DIRECT)
    try:
        body = pybullet.loadURDF(str(path), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE,
                                 physicsClientId=p)
        upper, lower = (pybullet.getDynamicsInfo(body, i, physicsClientId=p) for i in (0, 1))
    finally:
        pybullet.disconnect(p)
    assert (upper[0], upper[2], lower[0], lower[2]) == (1.0, (1.0, 1.0, 1.0), 2.0, (0.0, 0.0, 0.0))
    assert ours["pybullet"].get_param("body/upper/mass")[0] == 1.0
    np.testing.assert_array_equal(ours["pybullet"].get_param("body/upper/inertia"), [1, 1, 1, 0, 0, 0])
    np.testing.assert_array_equal(ours["pybullet"].get_param("body/lower/inertia"), np.zeros(6))
    assert ours["pinocchio"].get_param("body/upper/mass")[0] == 0.0
    np.testing.assert_array_equal(ours["pinocchio"].get_param("body/lower/inertia"), [0, 0, 3e-6, 0, 0, 0])
    with pytest.raises(ValueError, match="expected 'pinocchio' or 'pybullet', got 'mujoco'"):
        diffosi.Model.load(str(path), inertial="mujoco")
    with pytest.raises(ValueError, match="inertial applies to URDF files"):
        diffosi.Model.load(str(MODELS / "floating_arm.xml"), inertial="pybullet")


@pytest.mark.parametrize("engine", ["dart", "pybullet"])
def test_floating_base_floats_a_corpus_urdf_in_dart_and_pybullet(tmp_path, engine):
    """example-robot-data's double_pendulum_simple (a fixed base in the file's reading) with
    floating_base=True: DART's loader with a FLOATING root joint and PyBullet's useFixedBase=False
    step as ours with its free joint 'root_joint' (the file copied with a timestep, which the
    adapters read from <diffosi:options>)."""
    import xml.etree.ElementTree as ET

    from harness import corpus

    ET.register_namespace("diffosi", "urn:diffosi:urdf")
    source = corpus.example_robot_data() / "double_pendulum_description/urdf/double_pendulum_simple.urdf"
    tree = ET.parse(source)
    tree.getroot().insert(0, ET.Element("{urn:diffosi:urdf}options", timestep="0.002"))
    path = tmp_path / source.name
    tree.write(path)
    with engines.load(engine, path, floating_base=True) as e:
        assert (e.free.name, len(e.q_ref), e.nv) == ("root_joint", 9, 8)
        assert e.settings["free_base"].startswith("floating_base: the root link's")
        ours = e.ours()
        assert ours.joint_names[0] == "root_joint"
        np.testing.assert_array_equal(ours.reference_q(), e.q_ref)
        assert worst_free_step(e, ours, case_seed(11, "floating_base")) <= ONE_STEP_TOL
    with engines.load(engine, path) as e:
        assert (e.free, e.nv) == (None, 2)


def test_dart_turns_a_slow_free_base_by_a_series():
    """DART's FreeJoint turns by a truncated series when |w| h < 1e-3: the quaternion then
    parts from MuJoCo's (and ours) by about (|w| h)^3 / 20, and agrees to rounding above."""
    with engines.load("dart", "floating_arm") as e:
        ours = e.ours()
        q = e.q_ref.copy()
        for angle, low, high in [(5e-4, 1e-12, 1e-11), (2e-3, 0.0, 1e-15)]:
            v = np.r_[0.0, 0.0, 0.0, 0.48, 0.6, -0.64, 0.0, 0.0] * angle / e.timestep  # |w| h = angle
            e.set_state(q, v)
            e.step(np.zeros(8))
            error = np.abs(e.get_state()[0] - ours.step(q, v, np.zeros(8))[0]).max()
            assert low <= error <= high, f"|w| h = {angle}: {error:.1e}"


def test_golden_leaves_ball_and_free_joints_to_golden_free():
    """`harness golden --all` (make golden) steps every one-dof model of ours in every engine;
    the models with ball or free joints are golden-free's, which the MuJoCo adapter refuses."""
    from harness.engines.base import MODELS
    from harness.golden import cases

    names = set(cases(MODELS))
    assert {"mujoco_box", "pybullet_box", "dart_box", "mujoco_gym_hopper"} <= names
    assert not any(m in n for n in names for m in ("floating_arm", "free_ball", "free_box"))
