"""MuJoCo 4's multi-contact convex collision (multiccd, on by default; src/dynamics/collision/
multiccd.rs) against mj_forward on the pairs it serves among the primitives: a cylinder against
a cylinder, a capsule and a box, at random poses up to 0.03 deep (fixed seed), a third of them
with a margin. Half the states are generic (one contact), half have the geoms' axes aligned or
at a right angle, where a cap or box face meets a face or a side edge and MuJoCo clips the two
features to up to four contacts.

What is asserted is what holds: the same number of contacts as MuJoCo in every state but the
ones listed (one generic cylinder-box state, where EPA's contact normal is 2e-2 rad off
MuJoCo's, the gap test_convex.py measures, and MuJoCo finds an edge on a face that we do
not); every contact's point, frame and distance equal to MuJoCo's to 1e-9 in at least the
number of states measured (seed 7; the others are EPA's gap, or two clipped contacts listed
in the other order than MuJoCo's), and within the bounds below in all. Run with
`make test`."""

import mujoco
import numpy as np
import pytest

import diffosi
from harness.tests.test_convex import contact_error, forward, scene, unit

# The pairs, the worst difference allowed (about twice the one measured: 0.12, 0.25, 0.27; a
# pair of clipped contacts listed in the other order differs by the distance between them),
# the number of states of 40 that match to 1e-9 (measured, seed 7: generic, then aligned; the
# lower count where two machines differ, as on cylinder-cylinder's aligned states, 29 and 28:
# rounding decides which states take EPA's other path) and the number of generic states whose
# contact count differs from MuJoCo's.
PAIRS = [
    (("cylinder", "0.1 0.2", "cylinder", "0.15 0.1"), 0.5, (34, 28), 0),
    (("capsule", "0.1 0.3", "cylinder", "0.15 0.1"), 0.5, (27, 33), 0),
    (("cylinder", "0.1 0.2", "box", "0.1 0.2 0.15"), 0.5, (33, 34), 1),
]
STATES = 40
DEEPEST = 0.03


def near_touch(pair, rng, aligned):
    """A random state up to DEEPEST deep: geom b along a random direction from geom a, at the
    distance where MuJoCo's first contact appears (bisection) less the depth; aligned, b has
    a's orientation or a's turned a quarter about its x axis."""
    margin = 0.01 if rng.random() < 0.3 else 0.0
    qa = unit(rng, 4)
    xml = scene(pair, " ".join(map(str, qa)), margin)
    bare = xml.replace(f'margin="{margin}"', 'margin="0"')
    u = unit(rng, 3)
    quat = qa.copy() if aligned else unit(rng, 4)
    if aligned and rng.random() < 0.5:
        mujoco.mju_mulQuat(quat, qa, np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0, 0]))
    lo, hi = 0.0, 2.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        _, d = forward(bare, np.concatenate([u * mid, quat]))
        lo, hi = (mid, hi) if d.ncon else (lo, mid)
    return xml, np.concatenate([u * (lo - rng.uniform(0.0, DEEPEST)), quat])


@pytest.mark.parametrize("pair, bound, matched, miscounted", PAIRS,
                         ids=[f"{p[0]}-{p[2]}" for p, _, _, _ in PAIRS])
def test_contacts_are_mujocos(pair, bound, matched, miscounted, tmp_path):
    rng = np.random.default_rng(7)
    path = tmp_path / "pair.xml"
    for aligned, want in zip((False, True), matched):
        exact, worst, multi, counts = 0, 0.0, 0, 0
        for _ in range(STATES):
            xml, q = near_touch(pair, rng, aligned)
            m, d = forward(xml, q)
            path.write_text(xml)
            ours = diffosi.Model.load(str(path)).contacts(q, np.zeros(m.nv))
            assert len(ours) >= 1 and d.ncon >= 1, (pair, q)
            if len(ours) != d.ncon:
                counts += 1
                continue
            multi += d.ncon > 1
            err = 0.0
            for c, theirs in zip(ours, d.contact[: d.ncon]):
                assert set(c["geoms"]) == {"a", "b"}
                err = max(err, contact_error(c, theirs))
            exact += err < 1e-9
            worst = max(worst, err)
        assert counts <= (0 if aligned else miscounted), (pair, aligned, counts)
        assert exact >= want, (pair, aligned, exact)
        assert worst < bound, (pair, aligned, worst)
        if aligned:
            assert multi > 0, pair  # the aligned states do reach the clipping


def test_multiccd_disabled_is_refused_within_reach(tmp_path):
    """Without multiccd MuJoCo keeps one contact; that is not built, so the pair refuses."""
    path = tmp_path / "off.xml"
    path.write_text("""<mujoco><option><flag multiccd="disable"/></option><worldbody>
<geom type="cylinder" size="0.1 0.2"/>
<body pos="0 0 0.29"><freejoint/><geom type="box" size="0.3 0.3 0.1"/></body>
</worldbody></mujoco>""")
    m = diffosi.Model.load(str(path))
    q = np.array([0, 0, 0.29, 1, 0, 0, 0.0])
    with pytest.raises(ValueError, match="collider"):
        m.step(q, np.zeros(6), np.zeros(6))
