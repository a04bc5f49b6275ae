"""The Python module `diffosi` against the contract in DESIGN.md ("Python contract").

Run with `make test` (or `.venv/bin/python -m pytest -q harness/tests` after
`make setup`, which builds the module into .venv).
"""

from pathlib import Path

import numpy as np
import pytest

import diffosi

MODELS = Path(__file__).resolve().parents[2] / "reference_models"
CARTPOLE = str(MODELS / "cartpole.xml")
CHEETAH = str(MODELS / "half_cheetah.xml")
RNG = np.random.default_rng(0)


def load(path):
    """The model under the smooth contact model, whose step Jacobians these tests check."""
    return diffosi.Model.load(path).with_options(contact_model="smooth")


def random_state(m, scale=0.3):
    return (
        scale * RNG.standard_normal(m.nq),
        scale * RNG.standard_normal(m.nv),
        scale * RNG.standard_normal(m.nv),
    )


# ---------------------------------------------------------------- loading, properties


def test_cartpole_properties():
    m = load(CARTPOLE)
    assert (m.nq, m.nv, m.nu) == (2, 2, 1)
    assert m.timestep == pytest.approx(0.02)
    assert m.joint_names == ["slider", "hinge"]
    assert m.body_names == ["world", "cart", "pole"]
    assert "body/pole/com" in m.param_names()
    assert "joint/hinge/damping" in m.param_names()
    r = repr(m)
    assert "cartpole" in r and "nq=2" in r and "nu=1" in r


def test_half_cheetah_properties():
    m = load(CHEETAH)
    assert (m.nq, m.nv, m.nu) == (9, 9, 6)
    assert len(m.joint_names) == 9 and m.joint_names[0] == "rootx"
    assert "torso" in m.body_names
    assert all(isinstance(n, str) for n in m.param_names())


KEYFRAMES = """<mujoco>
  <worldbody>
    <body pos="1 2 3" euler="0 0 90"><freejoint/><geom size="0.1"/>
      <body pos="0 0 1"><joint name="h" ref="30"/><joint type="slide" ref="0.5"/><geom size="0.1"/></body>
    </body>
  </worldbody>
  <actuator><motor joint="h"/></actuator>
  <keyframe>
    <key name="home" time="1.5" qpos="0 0 1 1 0 0 0 0.1 0.2" qvel="1 2 3 4 5 6 7 8" ctrl="0.5"/>
    <key qpos="5 6"/>
  </keyframe>
</mujoco>
"""


def test_keyframes_are_mujocos(tmp_path):
    import mujoco

    path = tmp_path / "keys.xml"
    path.write_text(KEYFRAMES)
    m = diffosi.Model.load(str(path))
    theirs = mujoco.MjModel.from_xml_path(str(path))
    assert m.keyframe_names == ["home", "key1"]
    for i, name in enumerate(m.keyframe_names):
        key = m.keyframe(name)
        assert set(key) == {"q", "v", "ctrl", "act", "mocap_pos", "mocap_quat", "time"}
        np.testing.assert_allclose(key["q"], theirs.key_qpos[i], rtol=0, atol=1e-15)
        np.testing.assert_array_equal(key["v"], theirs.key_qvel[i])
        np.testing.assert_array_equal(key["ctrl"], theirs.key_ctrl[i])
        np.testing.assert_array_equal(key["act"], theirs.key_act[i])
        assert key["time"] == theirs.key_time[i]
    with pytest.raises(KeyError, match="no keyframe 'away'"):
        m.keyframe("away")


def test_urdf_twin_steps_like_mjcf():
    # Twins are the same model; the URDF twin runs PyBullet's explicit damping,
    # so only compare where passive forces vanish (v = 0, q at the spring reference).
    mj, ur = load(CARTPOLE), load(str(MODELS / "cartpole.urdf"))
    assert (ur.nq, ur.nv) == (mj.nq, mj.nv)
    np.testing.assert_allclose(ur.get_param("body/pole/mass"), mj.get_param("body/pole/mass"))


def test_options_follow_the_file_and_with_options_copies():
    mj, ur = load(CARTPOLE), load(str(MODELS / "cartpole.urdf"))
    assert (mj.integrator, mj.passive) == ("Euler", "implicit_damping")  # MuJoCo's Euler
    assert ur.passive == "implicit_damping"  # MuJoCo's URDF importer's (was PyBullet's explicit)
    np.testing.assert_array_equal(mj.gravity, [0.0, 0.0, -9.81])
    dart = mj.with_options(passive="implicit_damping_stiffness", timestep=0.005, gravity=[0, 0, -1])
    assert (dart.passive, dart.timestep, list(dart.gravity)) == ("implicit_damping_stiffness", 0.005, [0, 0, -1])
    assert (mj.passive, mj.timestep) == ("implicit_damping", 0.02)  # the original is untouched
    q, v, tau = np.array([0.1, 0.4]), np.array([0.3, -2.0]), np.array([1.0, 0.0])
    h = 0.005
    fine = mj.with_options(timestep=h)
    q1, v1 = fine.step(q, v, tau)
    np.testing.assert_allclose(q1, q + h * v1, rtol=0, atol=1e-15)  # semi-implicit Euler at the new h


@pytest.mark.parametrize("kwargs, match", [
    ({"passive": "implicit"}, "passive must be one of explicit, implicit_damping"),
    ({"integrator": "Verlet"}, "integrator must be one of Euler, RK4, implicitfast, implicit"),
    ({"timestep": 0.0}, "timestep must be positive"),
    ({"timestep": float("nan")}, "timestep must be positive"),
    ({"gravity": [0.0, 1.0]}, "gravity"),
])
def test_bad_options_raise_value_error(kwargs, match):
    with pytest.raises(ValueError, match=match):
        load(CARTPOLE).with_options(**kwargs)


# ---------------------------------------------------------------- step and rollout


@pytest.mark.parametrize("path", [CARTPOLE, CHEETAH])
def test_step_shapes_and_dtypes(path):
    m = load(path)
    q, v, tau = random_state(m)
    q1, v1 = m.step(q, v, tau)
    for a, n in [(q1, m.nq), (v1, m.nv)]:
        assert isinstance(a, np.ndarray) and a.dtype == np.float64 and a.shape == (n,)
        assert np.all(np.isfinite(a))
    # Lists, tuples, ints and float32 arrays are accepted and mean the same.
    q2, v2 = m.step(list(q), tuple(v), tau.astype(np.float64))
    np.testing.assert_array_equal(q1, q2)
    np.testing.assert_array_equal(v1, v2)
    zeros = m.step([0] * m.nq, np.zeros(m.nv, dtype=np.float32), np.zeros(m.nv, dtype=int))
    assert zeros[0].dtype == np.float64


def test_step_is_semi_implicit_euler():
    m = load(CARTPOLE)
    q, v = np.array([0.0, 0.1]), np.zeros(2)
    q1, v1 = m.step(q, v, [0.0, 0.0])
    assert v1[1] > 0.0, "the tilted pole falls further"
    np.testing.assert_array_equal(q1, q + m.timestep * v1)


def test_step_strided_input():
    m = load(CHEETAH)
    big = RNG.standard_normal((m.nq, 3))
    q = big[:, 1]  # not contiguous
    assert not q.flags["C_CONTIGUOUS"]
    a = m.step(q, np.zeros(m.nv), np.zeros(m.nv))
    b = m.step(q.copy(), np.zeros(m.nv), np.zeros(m.nv))
    np.testing.assert_array_equal(a[0], b[0])


@pytest.mark.parametrize("path", [CARTPOLE, CHEETAH])
def test_rollout_equals_repeated_step_bitwise(path):
    m = load(path)
    q0, v0, _ = random_state(m, 0.1)
    taus = 0.5 * RNG.standard_normal((25, m.nv))
    Q, V = m.rollout(q0, v0, taus)
    assert Q.shape == (26, m.nq) and V.shape == (26, m.nv)
    assert Q.dtype == np.float64 and V.dtype == np.float64
    np.testing.assert_array_equal(Q[0], q0)
    np.testing.assert_array_equal(V[0], v0)
    q, v = q0, v0
    for t in range(25):
        q, v = m.step(q, v, taus[t])
        np.testing.assert_array_equal(Q[t + 1], q)
        np.testing.assert_array_equal(V[t + 1], v)
    # Lists of lists work; zero steps give the initial state alone.
    Q2, _ = m.rollout(list(q0), list(v0), taus.tolist())
    np.testing.assert_array_equal(Q, Q2)
    Q0, V0 = m.rollout(q0, v0, np.zeros((0, m.nv)))
    assert Q0.shape == (1, m.nq) and V0.shape == (1, m.nv)


# ---------------------------------------------------------------- parameters


def test_get_set_param():
    m = load(CARTPOLE)
    com = m.get_param("body/pole/com")
    assert isinstance(com, np.ndarray) and com.dtype == np.float64 and com.shape == (3,)
    mass = m.get_param("body/pole/mass")
    assert mass.shape == (1,)
    x = ([0.0, 0.1], [0.0, 0.0], [0.0, 0.0])
    before = m.step(*x)
    m.set_param("body/pole/com", np.array([0.1, 0.0, 0.52]))
    np.testing.assert_array_equal(m.get_param("body/pole/com"), [0.1, 0.0, 0.52])
    after = m.step(*x)
    assert not np.array_equal(before[1], after[1]), "set_param changes the dynamics"
    m.set_param("body/pole/mass", 2.5)  # a plain number is fine for one-value parameters
    np.testing.assert_array_equal(m.get_param("body/pole/mass"), [2.5])
    m.set_param("joint/hinge/damping", [0.3])
    assert m.get_param("joint/hinge/damping")[0] == 0.3
    # Jacobians see the new model too.
    J = m.step_jacobians(*x)
    np.testing.assert_allclose(J["dv_dtau"], m.step_jacobians(*x)["dv_dtau"])
    # A fresh model with the same edits steps identically.
    m2 = load(CARTPOLE)
    for name in ["body/pole/com", "body/pole/mass", "joint/hinge/damping"]:
        m2.set_param(name, m.get_param(name))
    np.testing.assert_array_equal(m.step(*x)[1], m2.step(*x)[1])


def test_every_param_round_trips():
    m = load(CHEETAH)
    for name in m.param_names():
        value = m.get_param(name)
        m.set_param(name, value)
        np.testing.assert_array_equal(m.get_param(name), value)


# ---------------------------------------------------------------- Jacobians

KEYS = ["dq_dq", "dq_dv", "dq_dtau", "dv_dq", "dv_dv", "dv_dtau", "dq_dp", "dv_dp"]


def central_fd(f, x, eps=1e-6):
    cols = []
    for i in range(len(x)):
        e = np.zeros_like(x)
        e[i] = eps
        cols.append((f(x + e) - f(x - e)) / (2 * eps))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("path", [CARTPOLE, CHEETAH])
def test_jacobian_shapes(path):
    m = load(path)
    q, v, tau = random_state(m)
    name = [n for n in m.param_names() if n.endswith("/com")][0]
    J = m.step_jacobians(q, v, tau, params=[name, m.param_names()[0]])
    assert sorted(J) == sorted(KEYS)
    n = m.nv
    for k in KEYS[:6]:
        assert J[k].shape == (n, n) and J[k].dtype == np.float64, k
    for k in KEYS[6:]:
        assert J[k].shape == (n, 4) and J[k].dtype == np.float64, k
    J0 = m.step_jacobians(q, v, tau)
    assert J0["dq_dp"].shape == (n, 0) and J0["dv_dp"].shape == (n, 0)


@pytest.mark.parametrize("path", [CARTPOLE, CHEETAH])
def test_jacobians_against_finite_differences(path):
    m = load(path)
    q, v, tau = random_state(m)
    J = m.step_jacobians(q, v, tau)
    fd_tau = central_fd(lambda t: np.concatenate(m.step(q, v, t)), tau)
    fd_q = central_fd(lambda x: np.concatenate(m.step(x, v, tau)), q)
    fd_v = central_fd(lambda x: np.concatenate(m.step(q, x, tau)), v)
    n = m.nv
    for exact, fd in [
        (np.vstack([J["dq_dtau"], J["dv_dtau"]]), fd_tau),
        (np.vstack([J["dq_dq"], J["dv_dq"]]), fd_q),
        (np.vstack([J["dq_dv"], J["dv_dv"]]), fd_v),
    ]:
        assert exact.shape == (2 * n, n)
        np.testing.assert_allclose(exact, fd, rtol=1e-5, atol=1e-6)


def test_transition_jacobians_are_the_blocks_in_mujocos_layout():
    # Standing on the floor under the constraint model: rows in contact.
    m = diffosi.Model.load(CHEETAH)
    Q, V = m.rollout(np.zeros(m.nq), np.zeros(m.nv), np.zeros((300, m.nv)))
    x = (Q[-1], V[-1], 0.1 * RNG.standard_normal(m.nv))
    assert m.contacts(*x), "the cheetah stands on its floor"
    A, B = m.transition_jacobians(*x)
    J = m.step_jacobians(*x)
    n = m.nv
    assert A.shape == (2 * n, 2 * n) and B.shape == (2 * n, n)
    np.testing.assert_array_equal(A, np.block([[J["dq_dq"], J["dq_dv"]], [J["dv_dq"], J["dv_dv"]]]))
    np.testing.assert_array_equal(B, np.vstack([J["dq_dtau"], J["dv_dtau"]]))
    with pytest.raises(ValueError, match="tau"):
        m.transition_jacobians(x[0], x[1], np.full(n, np.nan))


def param_fd(m, name, x, eps=1e-6):
    base = m.get_param(name)

    def f(p):
        m.set_param(name, p)
        return np.concatenate(m.step(*x))

    try:
        return central_fd(f, base, eps)
    finally:
        m.set_param(name, base)


@pytest.mark.parametrize(
    "path,names",
    [
        (CARTPOLE, ["body/pole/com"]),
        (CARTPOLE, ["body/pole/mass", "joint/hinge/damping", "body/pole/com"]),
        (CHEETAH, ["body/torso/mass", "body/bthigh/com", "joint/fshin/damping"]),
    ],
)
def test_parameter_jacobian_against_finite_differences(path, names):
    m = load(path)
    for name in names:  # central differences need room on both sides of a bound at 0
        if name.startswith("joint/") and m.get_param(name)[0] < 1e-3:
            m.set_param(name, 0.2)
    q, v, tau = random_state(m)
    x = (q, v, tau)
    J = m.step_jacobians(q, v, tau, params=names)
    fd = np.hstack([param_fd(m, name, x) for name in names])
    exact = np.vstack([J["dq_dp"], J["dv_dp"]])
    assert exact.shape == fd.shape
    np.testing.assert_allclose(exact, fd, rtol=1e-5, atol=1e-6)
    # The finite differences left the model as it was.
    J2 = m.step_jacobians(q, v, tau, params=names)
    np.testing.assert_array_equal(J2["dv_dp"], J["dv_dp"])


# ---------------------------------------------------------------- errors


@pytest.fixture
def cart():
    return load(CARTPOLE)


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda m: m.step([0.0], [0.0, 0.0], [0.0, 0.0]), r"\bq\b.*length.*2.*\(1,\)"),
        (lambda m: m.step([0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0]), r"\bv\b.*\(3,\)"),
        (lambda m: m.step([0.0, 0.0], [0.0, 0.0], [0.0]), r"\btau\b.*\(1,\)"),
        (lambda m: m.step([0.0, np.nan], [0.0, 0.0], [0.0, 0.0]), r"q\[1\] is not finite"),
        (lambda m: m.step([0.0, 0.0], [np.inf, 0.0], [0.0, 0.0]), r"v\[0\] is not finite"),
        (lambda m: m.step([[0.0, 0.0]], [0.0, 0.0], [0.0, 0.0]), r"\bq\b.*1-D.*\(1, 2\)"),
        (lambda m: m.step(["a", "b"], [0.0, 0.0], [0.0, 0.0]), r"\bq\b.*float64"),
        (lambda m: m.step(None, [0.0, 0.0], [0.0, 0.0]), r"\bq\b"),
        (lambda m: m.rollout([0.0, 0.0], [0.0, 0.0], np.zeros(3)), r"taus.*2-D.*\(3,\)"),
        (lambda m: m.rollout([0.0, 0.0], [0.0, 0.0], np.zeros((4, 3))), r"taus.*\(4, 3\)"),
        (
            lambda m: m.rollout([0.0, 0.0], [0.0, 0.0], [[0.0, 0.0], [np.nan, 0.0]]),
            r"taus\[1, 0\] is not finite",
        ),
        (lambda m: m.rollout([0.0], [0.0, 0.0], np.zeros((2, 2))), r"q0"),
        (lambda m: m.get_param("body/nobody/mass"), r"nobody"),
        (lambda m: m.get_param("nonsense"), r"nonsense"),
        (lambda m: m.set_param("body/pole/mass", -1.0), r"body/pole/mass.*-1"),
        (lambda m: m.set_param("body/pole/mass", np.nan), r"body/pole/mass"),
        (lambda m: m.set_param("body/pole/com", [1.0, 2.0]), r"body/pole/com.*3.*2"),
        (lambda m: m.set_param("body/pole/com", np.zeros((3, 1))), r"body/pole/com.*\(3, 1\)"),
        (lambda m: m.set_param("joint/hinge/damping", -0.5), r"joint/hinge/damping"),
        (lambda m: m.set_param("body/pole/inertia", [1, 1, 5, 0, 0, 0]), r"body/pole/inertia"),
        (lambda m: m.set_param("body/unknown/com", [0, 0, 0]), r"unknown"),
        (
            lambda m: m.step_jacobians([0.0, 0.0], [0.0, 0.0], [0.0, 0.0], params=["body/x/mass"]),
            r"body/x/mass",
        ),
        (lambda m: m.step_jacobians([0.0, 0.0], [0.0], [0.0, 0.0]), r"\bv\b"),
    ],
)
def test_bad_input_raises_value_error(cart, call, match):
    with pytest.raises(ValueError, match=match):
        call(cart)


def test_failed_set_param_leaves_model_unchanged(cart):
    x = ([0.0, 0.1], [0.0, 0.0], [0.0, 0.0])
    before = cart.step(*x)
    with pytest.raises(ValueError):
        cart.set_param("body/pole/mass", -1.0)
    np.testing.assert_array_equal(cart.get_param("body/pole/com"), [0.0, 0.0, 0.5])
    np.testing.assert_array_equal(cart.step(*x)[1], before[1])


def test_missing_file_raises_oserror(tmp_path):
    missing = tmp_path / "nope.xml"
    with pytest.raises(OSError, match="nope.xml"):
        diffosi.Model.load(str(missing))
    with pytest.raises(IOError):
        diffosi.Model.load(missing)  # a pathlib.Path works too



def test_urdf_load_warnings_are_user_warnings(tmp_path):
    """What the URDF loader takes as written comes as a UserWarning naming file, line and
    link: here a moving link without <inertial> (massless, as Pinocchio reads it)."""
    path = tmp_path / "r.urdf"
    path.write_text("""<robot name="r">
<link name="base"/>
<link name="virtual"/>
<link name="arm"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="a" type="continuous"><parent link="base"/><child link="virtual"/></joint>
<joint name="b" type="continuous"><parent link="virtual"/><child link="arm"/></joint>
</robot>""")
    with pytest.warns(UserWarning, match=r"r.urdf:3: <link>: moving links without <inertial> are massless.*: virtual$"):
        m = diffosi.Model.load(str(path))
    assert (m.contact_model, m.passive, m.joint_address("b")) == ("constraint", "implicit_damping", (1, 1))


def test_malformed_files_raise_value_error(tmp_path):
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body name='a'></worldbody>")
    with pytest.raises(ValueError, match="broken.xml"):
        diffosi.Model.load(str(broken))
    negative = tmp_path / "negative.xml"
    negative.write_text(
        "<mujoco><worldbody><body name='b'><joint name='j' type='hinge'/>"
        "<inertial pos='0 0 0' mass='-1' diaginertia='1 1 1'/></body></worldbody></mujoco>"
    )
    with pytest.raises(ValueError, match="negative.xml|mass"):
        diffosi.Model.load(str(negative))
    bad_urdf = tmp_path / "bad.urdf"
    bad_urdf.write_text("<robot name='r'><link name='a'/><joint name='j' type='warp'/></robot>")
    with pytest.raises(ValueError, match="bad.urdf"):
        diffosi.Model.load(str(bad_urdf))
    other = tmp_path / "model.obj"
    other.write_text("v 0 0 0")
    with pytest.raises(ValueError, match="model.obj"):
        diffosi.Model.load(str(other))


def test_free_and_ball_joints_have_nq_above_nv():
    """A model with free and ball joints: q is nq long (quaternions w, x, y, z), v and tau nv;
    the reference configuration is MuJoCo's qpos0; a step returns unit quaternions; a q of
    length nv is refused naming nq; the step Jacobians are in the tangent space (2 nv columns
    of state, MuJoCo's layout); identification takes nq-long q and q_next and recovers a mass
    from the model's own steps, and refuses unknown constraints on it clearly."""
    m = diffosi.Model.load(str(MODELS / "free_ball.xml")).with_options(contact=False)
    assert (m.nq, m.nv) == (16, 13)
    q_names, v_names = m.coordinate_names()
    assert len(q_names) == 16 and len(v_names) == 13 and q_names[3] == "root:qw" and v_names[3] == "root:wx"
    q0 = m.reference_q()
    assert q0.shape == (16,) and np.allclose(q0[:3], [0.1, 0.2, 1.5])
    assert np.isclose(np.linalg.norm(q0[3:7]), 1.0) and np.allclose(q0[7:11], [1, 0, 0, 0])
    q, v = m.step(2.0 * q0, np.full(13, 0.5), np.zeros(13))  # quaternions read normalised
    assert q.shape == (16,) and v.shape == (13,)
    for start in (3, 7, 12):
        assert abs(np.linalg.norm(q[start:start + 4]) - 1.0) < 1e-15
    with pytest.raises(ValueError, match="nq"):
        m.step(np.zeros(13), np.zeros(13), np.zeros(13))
    A, B = m.transition_jacobians(q0, np.zeros(13), np.zeros(13))
    assert A.shape == (26, 26) and B.shape == (26, 13) and np.isfinite(A).all()
    truth = m.with_options()
    truth.set_param("body/box/mass", 2.5)
    taus = np.random.default_rng(0).uniform(-5.0, 5.0, (4, 13))
    Q, V = truth.rollout(q0, np.full(13, 0.3), taus)
    osi = diffosi.DiffOsi(m, params=["body/box/mass"], lower=[1.0], upper=[3.0])
    est = osi.identify(Q[:-1], V[:-1], taus, Q[1:], V[1:])
    assert abs(est["params"][0] - 2.5) < 1e-6 and not est["flags"]
    with pytest.raises(ValueError, match="nq"):
        osi.identify(V[:-1], V[:-1], taus, Q[1:], V[1:])
    with pytest.raises(ValueError, match="ball or free joints"):
        diffosi.DiffOsi(m, params=["body/box/mass"], lower=[1.0], upper=[3.0], constraints="unknown")
