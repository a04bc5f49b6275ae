"""The general convex collider (GJK and EPA, src/dynamics/collision/convex.rs) against
MuJoCo's mj_forward on the pairs it serves: an ellipsoid against a sphere, a capsule, an
ellipsoid, a cylinder and a box, at random poses up to 0.03 deep (fixed seed), a third of
them with a margin.

What is asserted is what holds: the same single contact in every state; its point, frame
and distance equal to MuJoCo's to 1e-9 in at least the number of states measured (seed 7;
the others take another iteration path: rounding differences decide GJK's stopping test and
EPA's budget ends the penetration), and within the iterations' accuracy in all (bounds per
pair below). Run with `make test`."""

import mujoco
import numpy as np
import pytest

import diffosi

# The pairs, the worst difference from MuJoCo allowed (twice the one measured) and the
# number of states that match to 1e-9 (measured, seed 7; the lower count where two machines
# differ, as on capsule-ellipsoid, 23 and 22: rounding decides GJK's stopping test). A sphere or capsule against an
# ellipsoid is GJK's distance of its centre or segment (GJK's 1e-6 tolerance); the others
# are EPA's, ended by its 35-expansion budget.
PAIRS = [
    (("sphere", "0.2", "ellipsoid", "0.1 0.2 0.3"), 5e-5, 38),
    (("capsule", "0.1 0.3", "ellipsoid", "0.1 0.2 0.3"), 5e-5, 22),
    (("ellipsoid", "0.2 0.1 0.3", "ellipsoid", "0.1 0.2 0.3"), 1.2e-2, 27),
    (("ellipsoid", "0.2 0.1 0.3", "cylinder", "0.1 0.2"), 2.5e-2, 30),
    (("ellipsoid", "0.2 0.1 0.3", "box", "0.1 0.2 0.15"), 1e-2, 34),
]
STATES = 40
DEEPEST = 0.03  # the deepest penetration sampled


def scene(pair, quat, margin):
    t1, s1, t2, s2 = pair
    return f"""<mujoco><option gravity="0 0 0"/><worldbody>
<geom name="a" type="{t1}" size="{s1}" quat="{quat}" margin="{margin}"/>
<body name="b" pos="0 0 1"><freejoint/><geom name="b" type="{t2}" size="{s2}" margin="{margin}"/></body>
</worldbody></mujoco>"""


def contact_error(c, theirs):
    """The largest difference between our contact `c` and MuJoCo's
    `theirs` (a d.contact entry): point, frame and signed distance."""
    return max(np.abs(c["point"] - theirs.pos).max(),
               np.abs(c["frame"] - theirs.frame.reshape(3, 3)).max(),
               abs(-c["depth"] - theirs.dist))


def unit(rng, n):
    x = rng.normal(size=n)
    return x / np.linalg.norm(x)


def forward(xml, q):
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    return m, d


def near_touch(pair, rng):
    """A random state of the pair up to DEEPEST deep: geom b along a random direction from
    geom a, at the distance where MuJoCo's contact appears (bisection) less the depth."""
    margin = 0.01 if rng.random() < 0.3 else 0.0
    xml = scene(pair, " ".join(map(str, unit(rng, 4))), margin)
    bare = xml.replace(f'margin="{margin}"', 'margin="0"')
    u, quat = unit(rng, 3), unit(rng, 4)
    lo, hi = 0.0, 2.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        _, d = forward(bare, np.concatenate([u * mid, quat]))
        lo, hi = (mid, hi) if d.ncon else (lo, mid)
    q = np.concatenate([u * (lo - rng.uniform(0.0, DEEPEST)), quat])
    return xml, q, margin


@pytest.mark.parametrize("pair, bound, matched", PAIRS, ids=[f"{p[0]}-{p[2]}" for p, _, _ in PAIRS])
def test_contacts_are_mujocos(pair, bound, matched, tmp_path):
    rng = np.random.default_rng(7)
    exact, worst = 0, 0.0
    for _ in range(STATES):
        xml, q, margin = near_touch(pair, rng)
        m, d = forward(xml, q)
        path = tmp_path / "pair.xml"
        path.write_text(xml)
        ours = diffosi.Model.load(str(path)).contacts(q, np.zeros(m.nv))
        assert len(ours) == d.ncon == 1, (pair, q)
        theirs, c = d.contact[0], ours[0]
        assert set(c["geoms"]) == {"a", "b"}
        err = contact_error(c, theirs)
        exact += err < 1e-9
        worst = max(worst, err)
    assert exact >= matched, (pair, exact)
    assert worst < bound, (pair, worst)


DROP = """<mujoco><option timestep="0.002"/><worldbody>
<geom name="a" type="{}" size="{}"/>
<body name="b" pos="0 0 1"><freejoint/><geom name="b" type="ellipsoid" size="0.1 0.2 0.3"/></body>
</worldbody></mujoco>"""


@pytest.mark.parametrize("kind, size, top", [("sphere", "0.2", 0.2), ("box", "0.5 0.5 0.1", 0.1),
                                            ("ellipsoid", "0.3 0.3 0.1", 0.1), ("plane", "1 1 0.1", 0.0)])
def test_step_jacobians_in_contact_match_central_differences(kind, size, top, tmp_path):
    """A tilted, moving ellipsoid 5 mm into a sphere, a box, an ellipsoid and a plane: the step's
    dv/dq (translation columns) and dv/dv against central differences (h = 1e-7). Measured:
    within 4e-7 relative for the sphere (GJK's tolerance shows in the differences), 3e-9 for
    the others (2e-9 for the plane, 0.4 mm deep). These are the derivatives of the iterations
    (dual numbers), which the differences of the same iterations confirm; the implicit
    derivative of the converged geometry is not built yet. The plane's contact is the
    ellipsoid's support point in closed form, so its dual derivative is exact."""
    path = tmp_path / "drop.xml"
    path.write_text(DROP.format(kind, size))
    m = diffosi.Model.load(str(path))
    half = 0.1
    quat = [np.cos(half), 0.6 * np.sin(half), 0.8 * np.sin(half), 0.0]
    q = np.concatenate([[0.03, -0.02, top + 0.3 - 0.005], quat])
    v = np.array([0.1, -0.2, -0.05, 0.3, 0.2, -0.1])
    tau = np.zeros(6)
    assert m.contacts(q, v)
    for block, err in free_body_jacobian_errors(m, q, v, tau).items():
        assert err < 1e-6, (kind, block, err)


def free_body_jacobian_errors(m, q, v, tau, h=1e-7):
    """A free body's step dv/dq (translation columns) and dv/dv against central differences
    of the step (step h): the largest difference relative to the largest difference quotient."""
    jac = m.step_jacobians(q, v, tau)
    errors = {}
    for block, size, shift in (("dv_dq", 3, lambda k: (np.eye(7)[k] * h, 0)),
                               ("dv_dv", 6, lambda k: (0, np.eye(6)[k] * h))):
        fd = np.zeros((6, size))
        for k in range(size):
            dq, dv = shift(k)
            fd[:, k] = (m.step(q + dq, v + dv, tau)[1] - m.step(q - dq, v - dv, tau)[1]) / (2 * h)
        errors[block] = np.abs(fd - jac[block][:, :size]).max() / np.abs(fd).max()
    return errors


PLANE = """<mujoco><worldbody>
<geom name="a" type="plane" size="1 1 0.1" quat="{}" margin="{}"/>
<body name="b" pos="0 0 1"><freejoint/><geom name="b" type="ellipsoid" size="0.1 0.2 0.3"/></body>
</worldbody></mujoco>"""


def rotation(quat):
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, dtype=float))
    return mat.reshape(3, 3)


def test_plane_ellipsoid_contacts_are_mujocos(tmp_path):
    """A tilted plane against an ellipsoid (MuJoCo's mjc_PlaneConvex: the support point along
    the plane's inward normal) at random poses from 3 cm deep to 1 cm apart, a third with a
    2 cm margin: the same contacts as mj_forward, to rounding."""
    rng = np.random.default_rng(11)
    path = tmp_path / "plane.xml"
    radii = np.array([0.1, 0.2, 0.3])
    seen = 0
    for _ in range(40):
        margin = 0.02 if rng.random() < 0.3 else 0.0
        plane, quat = unit(rng, 4), unit(rng, 4)
        normal = rotation(plane)[:, 2]
        reach = np.linalg.norm(radii * (rotation(quat).T @ normal))
        q = np.concatenate([normal * (reach + rng.uniform(-0.03, 0.01)), quat])
        xml = PLANE.format(" ".join(map(str, plane)), margin)
        m, d = forward(xml, q)
        path.write_text(xml)
        ours = diffosi.Model.load(str(path)).contacts(q, np.zeros(m.nv))
        assert len(ours) == d.ncon, q
        for c, theirs in zip(ours, d.contact[:d.ncon]):
            assert contact_error(c, theirs) < 1e-14
        seen += d.ncon
    assert 20 < seen < 40, seen
