"""Mesh colliders (src/dynamics/collision/mesh.rs) against MuJoCo 4.0.0's mj_forward: a plane
against a mesh box, an irregular mesh, a hexagonal prism and two robot feet (Cassie's foot and Go2's convex
foot from example-robot-data), at random poses of plane and mesh from 5 mm apart to 20 mm
deep (fixed seed), a third of them with a margin.

Asserted: the same number of contacts in every state; each of ours equal to one of MuJoCo's
(point, frame, distance) to 1e-9 in at least the states measured (seed 7: all). MuJoCo keeps
at most four contacts, from the side of its hull that faces the plane. Go2's foot, a rounded
hull of 329 vertices that MuJoCo merges into 622 sides (one of 17 vertices), differs in 2 to 5
of 100 states at other seeds: the same first contact, other vertices for the extra ones (our
hull's triangles, from which the sides are merged, are not qhull's). Run with `make test`."""

import mujoco
import numpy as np
import pytest

import diffosi
from harness import corpus
from harness.tests.test_convex import contact_error, free_body_jacobian_errors, unit

STATES = 40


def meshes():
    robots = corpus.example_robot_data()
    return {
        "box": 'vertex="-.1 -.1 -.1  .1 -.1 -.1  -.1 .1 -.1  .1 .1 -.1  -.1 -.1 .1  .1 -.1 .1  -.1 .1 .1  .1 .1 .1"',
        "rock": 'vertex="0 0 .12  .1 0 .03  .03 .09 .02  -.08 .05 .04  -.08 -.05 .03  .03 -.09 .04  '
                '0 0 -.11  .07 .06 -.05  -.07 .06 -.04  -.06 -.07 -.05  .07 -.06 -.06  .11 .02 -.01"',
        # A hexagonal prism: sides of six vertices, pruned to four.
        "hexagon": 'vertex="' + " ".join(f"{np.cos(a):.4f} {np.sin(a):.4f} {z}" for z in (-0.3, 0.3)
                                         for a in np.arange(6) * np.pi / 3) + '" scale="0.1 0.1 0.1"',
        "cassie_foot": f'file="{robots}/cassie_description/meshes/foot.stl"',
        "go2_foot": f'file="{robots}/go2_description/collisions/foot_convex.stl"',
    }


def scene(mesh, quat, margin):
    return f"""<mujoco><asset><mesh name="m" {meshes()[mesh]}/></asset><worldbody>
<geom name="a" type="plane" size="1 1 0.1" quat="{quat}" margin="{margin}"/>
<body name="b" pos="0 0 1"><freejoint/><geom name="b" type="mesh" mesh="m" margin="{margin}"/></body>
</worldbody></mujoco>"""


def state(mesh, rng):
    """A random plane and mesh orientation, the mesh's lowest vertex `depth` below the plane."""
    margin = 0.01 if rng.random() < 0.3 else 0.0
    plane = unit(rng, 4)
    xml = scene(mesh, " ".join(map(str, plane)), margin)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[3:] = unit(rng, 4)
    mujoco.mj_forward(m, d)
    normal = d.geom_xmat[0].reshape(3, 3)[:, 2]
    start = m.mesh_vertadr[0]
    vertices = m.mesh_vert[start:start + m.mesh_vertnum[0]]
    lowest = (vertices @ d.geom_xmat[1].reshape(3, 3).T + d.geom_xpos[1]) @ normal
    d.qpos[:3] = normal * (-lowest.min() - rng.uniform(-0.005, 0.02))
    mujoco.mj_forward(m, d)
    return xml, m, d


@pytest.mark.parametrize("mesh, matched", [("box", 40), ("rock", 40), ("hexagon", 40), ("cassie_foot", 40), ("go2_foot", 40)])
def test_plane_mesh_contacts_are_mujocos(mesh, matched, tmp_path):
    rng = np.random.default_rng(7)
    exact = 0
    for _ in range(STATES):
        xml, m, d = state(mesh, rng)
        path = tmp_path / "pair.xml"
        path.write_text(xml)
        ours = diffosi.Model.load(str(path)).contacts(d.qpos.copy(), np.zeros(m.nv))
        assert len(ours) == d.ncon, (mesh, d.qpos)
        err = 0.0
        for c in ours:
            assert set(c["geoms"]) == {"a", "b"}
            err = max(err, min(contact_error(c, t) for t in d.contact[:d.ncon]))
        exact += err < 1e-9
    assert exact >= matched, (mesh, exact)


@pytest.mark.parametrize("mesh", ["box", "rock", "hexagon", "cassie_foot"])
def test_a_dropped_mesh_steps_as_in_mujoco(mesh, tmp_path):
    """The mesh, tilted and spinning, dropped on a floor and stepped 600 times by MuJoCo (it
    lands, tumbles and comes to rest on a side: three or four contacts): from every 20th state
    one step of ours equals mj_step (the solver converges) to 1e-9 (measured 1e-12 to 5e-12)."""
    xml = scene(mesh, "1 0 0 0", 0.0)
    path = tmp_path / "drop.xml"
    path.write_text(xml)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = [0.0, 0.0, 0.3, 0.9, 0.3, -0.2, 0.1]
    d.qpos[3:] /= np.linalg.norm(d.qpos[3:])
    d.qvel[:] = [0.3, 0.0, 0.0, 2.0, -1.0, 3.0]
    ours = diffosi.Model.load(str(path))
    worst, most = 0.0, 0
    for k in range(600):
        if k % 20 == 0:
            mujoco.mj_forward(m, d)
            most = max(most, d.ncon)
            q1, v1 = ours.step(d.qpos.copy(), d.qvel.copy(), np.zeros(6))
            q, v = d.qpos.copy(), d.qvel.copy()
            mujoco.mj_step(m, d)
            worst = max(worst, np.abs(q1 - d.qpos).max(), np.abs(v1 - d.qvel).max())
            d.qpos[:], d.qvel[:] = q, v
        mujoco.mj_step(m, d)
    assert most >= 3 and d.ncon >= 3, (most, d.ncon)
    assert worst < 1e-9, worst


@pytest.mark.parametrize("mesh", ["box", "rock"])
def test_step_jacobians_on_a_plane_match_central_differences(mesh, tmp_path):
    """A tilted, moving mesh 5 mm into the floor: the step's dv/dq (translation columns) and
    dv/dv against central differences (h = 1e-7), within 1e-6 relative (measured 4e-10 to 2e-8,
    the differences' own error). The contacts are
    vertices fixed on the mesh, so their dual-number derivatives are exact."""
    xml = scene(mesh, "1 0 0 0", 0.0)
    path = tmp_path / "mesh.xml"
    path.write_text(xml)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    half = 0.1
    d.qpos[3:] = [np.cos(half), 0.6 * np.sin(half), 0.8 * np.sin(half), 0.0]
    mujoco.mj_forward(m, d)
    start = m.mesh_vertadr[0]
    vertices = m.mesh_vert[start:start + m.mesh_vertnum[0]]
    lowest = (vertices @ d.geom_xmat[1].reshape(3, 3).T + d.geom_xpos[1])[:, 2].min()
    q = d.qpos.copy()
    q[2] -= lowest + 0.005
    v = np.array([0.1, -0.2, -0.05, 0.3, 0.2, -0.1])
    ours = diffosi.Model.load(str(path))
    tau = np.zeros(6)
    assert ours.contacts(q, v)
    for block, err in free_body_jacobian_errors(ours, q, v, tau).items():
        assert err < 1e-6, (mesh, block, err)


def convex_scene(other, mesh, quat, margin):
    """Geom a (`other`: a type and size, or "mesh" and the name of another mesh) fixed at
    orientation `quat`, and the free mesh b."""
    kind, size = other
    shape, second = f'size="{size}"', ""
    if kind == "mesh":
        shape, second = 'mesh="n"', f'<mesh name="n" {meshes()[size]}/>'
    return f"""<mujoco><option gravity="0 0 0"/><asset><mesh name="m" {meshes()[mesh]}/>{second}</asset><worldbody>
<geom name="a" type="{kind}" {shape} quat="{quat}" margin="{margin}"/>
<body name="b" pos="0 0 1"><freejoint/><geom name="b" type="mesh" mesh="m" margin="{margin}"/></body>
</worldbody></mujoco>"""


def near_touch(other, mesh, rng):
    """A random state up to 20 mm deep: the mesh along a random direction from the other geom,
    at the distance where MuJoCo's contact appears (bisection) less the depth."""
    margin = 0.01 if rng.random() < 0.3 else 0.0
    xml = convex_scene(other, mesh, " ".join(map(str, unit(rng, 4))), margin)
    bare = xml.replace(f'margin="{margin}"', 'margin="0"')
    m = mujoco.MjModel.from_xml_string(bare)
    d = mujoco.MjData(m)
    u, quat = unit(rng, 3), unit(rng, 4)
    lo, hi = 0.0, 2.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        d.qpos[:] = np.concatenate([u * mid, quat])
        mujoco.mj_forward(m, d)
        lo, hi = (mid, hi) if d.ncon else (lo, mid)
    return xml, np.concatenate([u * (lo - rng.uniform(0.0, 0.02)), quat])


# The other geom, the mesh, the worst difference allowed (twice the one measured) and the
# states of 40 that match MuJoCo to 1e-9 (measured, seed 7). A sphere is GJK's distance of
# its centre to the hull: all match (worst 4e-12). An ellipsoid is EPA's, ended by its
# 35-expansion budget: in the other states the iterations take another path (as for the
# primitive ellipsoid pairs, test_convex.py), worst 1e-2 and 2.6e-3.
CONVEX = [
    (("sphere", "0.05"), "rock", 1e-9, 40),
    (("sphere", "0.05"), "cassie_foot", 1e-9, 40),
    (("ellipsoid", "0.05 0.03 0.04"), "rock", 2e-2, 36),
    (("ellipsoid", "0.05 0.03 0.04"), "box", 6e-3, 38),
]


def both_contacts(other, mesh, rng, tmp_path):
    """A random near-touching state of the pair (near_touch), MuJoCo's mj_forward data there
    and our contacts."""
    xml, q = near_touch(other, mesh, rng)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    path = tmp_path / "pair.xml"
    path.write_text(xml)
    return q, d, diffosi.Model.load(str(path)).contacts(q, np.zeros(m.nv))


@pytest.mark.parametrize("other, mesh, bound, matched", CONVEX,
                         ids=[f"{o[0]}-{m}" for o, m, _, _ in CONVEX])
def test_convex_mesh_contacts_are_mujocos(other, mesh, bound, matched, tmp_path):
    rng = np.random.default_rng(7)
    exact, worst = 0, 0.0
    for _ in range(STATES):
        q, d, ours = both_contacts(other, mesh, rng, tmp_path)
        assert len(ours) == d.ncon == 1, (other, mesh, q)
        theirs, c = d.contact[0], ours[0]
        err = contact_error(c, theirs)
        exact += err < 1e-9
        worst = max(worst, err)
    assert exact >= matched, (other, mesh, exact)
    assert worst < bound, (other, mesh, worst)


@pytest.mark.parametrize("vertices, why", [("0 0 0  1 0 0  0 1 0  1 1 0", "coplanar"),
                                           ("0 0 0  1 1 1  2 2 2  3 3 3", "collinear"),
                                           ("0 0 0  0 0 0  0 0 0  0 0 0", "colocated")])
def test_degenerate_hulls_are_refused_at_load_as_in_mujoco(vertices, why, tmp_path):
    """A colliding mesh whose hull is flat, a line or a point: refused with the file, line and
    element, in MuJoCo's words (which refuses it too)."""
    xml = f"""<mujoco><asset>
<mesh name="bad" vertex="{vertices}"/></asset><worldbody><geom type="plane" size="1 1 .1"/>
<body><freejoint/><geom type="mesh" mesh="bad"/></body></worldbody></mujoco>"""
    path = tmp_path / "bad.xml"
    path.write_text(xml)
    with pytest.raises(ValueError, match=f"bad.xml:2: <mesh>: .*has {why} vertices"):
        diffosi.Model.load(str(path))
    with pytest.raises(ValueError, match=f"has {why} vertices"):
        mujoco.MjModel.from_xml_string(xml)


# Geoms with faces or edges against a mesh (MuJoCo's multiccd: up to four contacts where a
# face of each, or a face and an edge, touch): the other geom, the mesh, and of 40 states
# (seed 7) those with MuJoCo's number of contacts and those whose every contact equals one of
# MuJoCo's to 1e-9 (both measured). In the others GJK and EPA end on another face of the
# polytope (see the module documentation of convex.rs): a contact differs by up to 1e-2,
# or an extra contact is missed or found.
MULTI = [
    (("capsule", "0.05 0.1"), "box", 40, 40),
    (("capsule", "0.05 0.1"), "rock", 40, 35),
    (("cylinder", "0.05 0.1"), "box", 39, 34),
    (("cylinder", "0.05 0.1"), "rock", 40, 31),
    (("box", "0.1 0.05 0.08"), "box", 37, 36),
    (("box", "0.1 0.05 0.08"), "hexagon", 36, 32),
    (("mesh", "rock"), "box", 32, 30),
    (("mesh", "hexagon"), "rock", 39, 34),
]


@pytest.mark.parametrize("other, mesh, counted, matched", MULTI,
                         ids=[f"{o[0]}-{m}" for o, m, _, _ in MULTI])
def test_multi_contact_mesh_pairs_are_mujocos(other, mesh, counted, matched, tmp_path):
    rng = np.random.default_rng(7)
    same, exact = 0, 0
    for _ in range(STATES):
        q, d, ours = both_contacts(other, mesh, rng, tmp_path)
        assert 1 <= len(ours) <= 4 and 1 <= d.ncon <= 4, (other, mesh, q)
        if len(ours) != d.ncon:
            continue
        same += 1
        err = max(min(contact_error(c, t) for t in d.contact[:d.ncon]) for c in ours)
        exact += err < 1e-9
    assert same >= counted and exact >= matched, (other, mesh, same, exact)


PILE = """<mujoco><option timestep="0.002"/><asset><mesh name="box" {box}/><mesh name="rock" {rock}/>
<mesh name="hexagon" {hexagon}/></asset><worldbody><geom type="plane" size="1 1 0.1"/>
<geom name="base" type="mesh" mesh="box" pos="0 0 0.1"/>
<body pos="0.02 0.01 0.4"><freejoint/><geom type="mesh" mesh="rock"/></body>
<body pos="-0.05 0.02 0.7"><freejoint/><geom type="mesh" mesh="hexagon"/></body>
<body pos="0.04 -0.03 1.0"><freejoint/><geom type="capsule" size="0.03 0.06"/></body>
<body pos="0.0 0.04 1.3"><freejoint/><geom type="cylinder" size="0.04 0.05"/></body>
<body pos="-0.03 -0.02 1.6"><freejoint/><geom type="box" size="0.05 0.04 0.03"/></body>
</worldbody></mujoco>"""


def test_a_pile_on_a_mesh_steps_as_in_mujoco(tmp_path):
    """A rock and a hexagonal prism (meshes), a capsule, a cylinder and a box dropped in turn on
    a mesh box on the floor and stepped 1500 times by MuJoCo (they land on the box and on each
    other and tumble off): from every 25th state one step of ours is compared with mj_step.
    Asserted: every new mesh pair (capsule, cylinder, box and mesh against a mesh) takes
    part, and the steps agree to 1e-9 in at least
    the number of states measured; in the others GJK and EPA end on another face (see
    test_multi_contact_mesh_pairs_are_mujocos) and a contact differs."""
    m_ = meshes()
    xml = PILE.format(box=m_["box"], rock=m_["rock"], hexagon=m_["hexagon"])
    path = tmp_path / "pile.xml"
    path.write_text(xml)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    ours = diffosi.Model.load(str(path))
    matched, compared, pairs = 0, 0, set()
    for k in range(1500):
        if k % 25 == 0:
            mujoco.mj_forward(m, d)
            pairs |= {tuple(sorted(m.geom_type[c.geom])) for c in d.contact[:d.ncon]}
            q1, v1 = ours.step(d.qpos.copy(), d.qvel.copy(), np.zeros(m.nv))
            q, v = d.qpos.copy(), d.qvel.copy()
            mujoco.mj_step(m, d)
            compared += d.ncon > 0
            matched += d.ncon > 0 and max(np.abs(q1 - d.qpos).max(), np.abs(v1 - d.qvel).max()) < 1e-9
            d.qpos[:], d.qvel[:] = q, v
        mujoco.mj_step(m, d)
    g = mujoco.mjtGeom
    for other in (g.mjGEOM_CAPSULE, g.mjGEOM_CYLINDER, g.mjGEOM_BOX, g.mjGEOM_MESH):
        assert (int(other), int(g.mjGEOM_MESH)) in pairs, (other, pairs)
    # Measured: 54 of the 57 states in contact.
    assert compared >= 50 and matched >= 54, (matched, compared)
