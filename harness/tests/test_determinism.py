"""Determinism through Python (issue 10): the same seed gives bitwise the same
trajectories, episodes and online estimates, and a Python rollout is bitwise the
`diffosi simulate` rollout of the Rust binary. The Rust side: tests/determinism.rs
(which lists the test proving each kind of run). Run with `make test`."""

import subprocess
from pathlib import Path

import numpy as np
import pytest

import diffosi

ROOT = Path(__file__).resolve().parents[2]
BINARY = ROOT / "target" / "release" / "diffosi"
POLICIES = ROOT / "policies" / "cartpole"


def seeded_rollout(path, seed, steps=300):
    """A rollout of seeded random forces in [-1, 1] from a seeded state near the reference."""
    m = diffosi.Model.load(path)
    r = np.random.default_rng(seed)
    q0 = m.rollout(np.zeros(m.nq), np.zeros(m.nv), np.zeros((0, m.nv)))[0][0]
    q0 = q0 + r.uniform(-0.3, 0.3, m.nq)
    v0 = r.uniform(-0.3, 0.3, m.nv)
    taus = r.uniform(-1.0, 1.0, (steps, m.nv))
    return (q0, v0, taus), m.rollout(q0, v0, taus)


@pytest.mark.parametrize("name", ["cartpole.xml", "half_cheetah.xml", "double_pendulum.urdf"])
def test_the_same_seed_gives_bitwise_the_same_rollout(name):
    path = str(ROOT / "reference_models" / name)
    _, (qa, va) = seeded_rollout(path, 5)
    _, (qb, vb) = seeded_rollout(path, 5)
    assert qa.tobytes() == qb.tobytes() and va.tobytes() == vb.tobytes()
    _, (qc, _) = seeded_rollout(path, 6)
    assert qa.tobytes() != qc.tobytes()


def test_a_python_rollout_is_bitwise_the_binary_rollout(tmp_path):
    assert BINARY.exists(), f"{BINARY} missing: run `make setup`"
    path = str(ROOT / "reference_models" / "half_cheetah.xml")
    (q0, v0, taus), (q, v) = seeded_rollout(path, 9, steps=200)
    torques = tmp_path / "taus.csv"
    np.savetxt(torques, taus, delimiter=",", fmt="%.17g")
    out = tmp_path / "out.csv"
    join = lambda x: ",".join(repr(float(e)) for e in x)
    subprocess.run(
        [str(BINARY), "simulate", path, "--steps", "200", "--torques", str(torques),
         "--q0", join(q0), "--v0", join(v0), "-o", str(out)],
        check=True, capture_output=True,
    )
    header = out.read_text().splitlines()[0].split(",")
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    nq, nv = q.shape[1], v.shape[1]
    # One transition per row: t, q, v, tau, q_next, v_next, then the force columns.
    blocks = np.split(rows[:, 1:], np.cumsum([nq, nv, nv, nq, nv]), axis=1)
    for got, want in zip(blocks, (q[:-1], v[:-1], taus, q[1:], v[1:])):
        assert np.ascontiguousarray(got).tobytes() == np.ascontiguousarray(want).tobytes()
    # The force-sensing columns, one per geom pair: the normal forces Model.contacts reports
    # under the torques of the step from that row.
    model = diffosi.Model.load(path)
    pairs = [name[len("fn_"):] for name in header[1 + 2 * nq + 3 * nv:]]
    assert pairs and all(p.endswith("_floor") for p in pairs)
    forces = blocks[-1]
    assert forces.max() > 1.0  # the cheetah does touch its floor
    for t in (0, int(forces.sum(axis=1).argmax()), 199):
        sensed = dict.fromkeys(pairs, 0.0)
        tau = taus[t]
        for c in model.contacts(q[t], v[t], tau):
            sensed["_".join(c["geoms"])] += c["normal_force"]
        assert forces[t].tolist() == list(sensed.values())


def test_episodes_policies_and_online_estimates_repeat_bit_for_bit():
    task = diffosi.Task("cartpole")
    a, b = task.episodes(4, 11), task.episodes(4, 11)
    assert all(x.tobytes() == y.tobytes() for x, y in zip(a, b))
    assert a[0].tobytes() != task.episodes(4, 12)[0].tobytes()
    policy = diffosi.Policy.load(POLICIES / "uc-seed0.json")

    def run():
        mus, q0s, v0s = task.episodes(1, 3)
        model = task.model(mus[0])
        osi = diffosi.OnlineOsi(task, window=3, seed=7)
        q, v, out = q0s[0], v0s[0], []
        for _ in range(20):
            tau = task.forces(policy.act(task, q, v, osi.mu))
            q1, v1 = model.step(q, v, tau)
            est = osi.push(q, v, tau, q1, v1)
            out += [est["mu"], est["std"], [est["loss"]], q1, v1]
            q, v = q1, v1
        return np.concatenate(out)

    assert run().tobytes() == run().tobytes()
