"""`python -m harness transfer` on every target with 2 short episodes, and the adapters'
native and friction options it relies on; the half cheetah in MuJoCo as gymnasium's
HalfCheetah-v5 runs it.

The episodes (seed 0) have mu = 0.28 and 0.33: the shipped UC keeps those poles up, while
with zero force the offset COM tips them over in well under the 100-step horizon. The half
cheetah's tests check the loop, not the gait: they train tiny policies with the binary.
"""

import json
import subprocess

import numpy as np
import pytest

import diffosi
from harness import engines
from harness.__main__ import main
from harness.engines.base import REPO
from harness.transfer import JOINT, METHODS, TASKS

HORIZON = 100
BINARY = REPO / "target" / "release" / "diffosi"


def run_transfer(out, target, *extra):
    return main(["transfer", "--task", "cartpole", "--target", target, "--episodes", "2", "--seeds", "0",
                 "--horizon", str(HORIZON), "--out", str(out), *extra])


def zero_force_score(target: str, mu, q0, v0) -> float:
    """Task metric of an episode with no cart force, in the same target."""
    task = diffosi.Task("cartpole")
    score = 0.0
    with engines.load(target, "cartpole", native=True) as env:
        for name, value in task.mu_params(mu).items():
            env.set_param(name, value)
        env.set_state(q0, v0)
        q, v = q0, v0
        for _ in range(HORIZON):
            env.step(np.zeros(2))
            q1, v1 = env.get_state()
            score += task.metric(q, v, [0.0], q1, v1)
            q, v = q1, v1
            if task.terminated(q, v):
                break
    return score


@pytest.mark.parametrize("target", engines.ENGINES)
def test_transfer_writes_reports_and_the_oracle_beats_no_force(tmp_path, target):
    assert run_transfer(tmp_path, target) == 0
    stem = tmp_path / f"transfer-cartpole-{target}"
    doc = json.loads(stem.with_suffix(".json").read_text())
    assert stem.with_suffix(".png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = stem.with_suffix(".md").read_text()
    assert "| UC-DiffOSI |" in md and "434.10 ± 110.88" in md  # the paper's Table 5 alongside
    assert doc["engine"]["name"] == target and list(doc["methods"]) == ["DR", "UC-DiffOSI", "UC-Oracle"]
    if target != "pybullet":  # MuJoCo and DART run this cartpole as ours does (to ~1e-13)
        for method, r in doc["methods"].items():
            assert doc["source"][method]["score"] == r["summary"]["score"], method
            assert np.allclose(doc["source"][method].get("mae", 0), r["summary"].get("mae", 0), atol=1e-9)
    mu, q0, v0 = diffosi.Task("cartpole").episodes(2, 0)
    oracle = doc["methods"]["UC-Oracle"]["episodes"]
    for k, e in enumerate(oracle):
        assert e["mu"] == mu[k, 0] and e["mae"] == 0.0
        assert e["score"] > zero_force_score(target, mu[k], q0[k], v0[k]), e
    for e in doc["methods"]["UC-DiffOSI"]["episodes"]:
        fed = np.array(e["mu_fed"])
        assert len(fed) == e["score"] and np.isfinite(fed).all() and np.all(np.abs(fed) <= 0.6)
        assert np.isfinite(e["mu_hat_final"]) and abs(e["mu_hat_final"]) <= 0.6
        assert e["mae"] < 0.05  # no unmodelled effect: mu is found within a few steps


def test_transfer_with_unmodelled_effects_is_seeded(tmp_path):
    for out in ("a", "b"):
        assert run_transfer(tmp_path / out, "dart", "--unmodelled", "delay,friction", "--friction", "0.5") == 0
    name = "transfer-cartpole-dart-friction-delay"
    first = (tmp_path / "a" / f"{name}.json").read_text()
    assert first == (tmp_path / "b" / f"{name}.json").read_text()
    doc = json.loads(first)
    assert doc["meta"]["friction"] == {"slider": 0.5} and doc["meta"]["delay"]
    assert doc["engine"]["settings"]["joint_friction"] == {"slider": "setCoulombFriction(0.5)"}
    assert "actuator delay" in (tmp_path / "a" / f"{name}.md").read_text()


def test_all_writes_a_summary_and_bad_effects_are_refused(tmp_path):
    assert run_transfer(tmp_path, "pybullet", "--unmodelled", "wind") == 2
    assert not any(tmp_path.iterdir())
    assert main(["transfer", "--target", "all", "--episodes", "1", "--seeds", "1", "--horizon", "20",
                 "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "transfer-cartpole-summary.json").read_text())
    assert list(summary["targets"]) == list(engines.ENGINES)
    md = (tmp_path / "transfer-cartpole-summary.md").read_text()
    assert "| dart | UC-Oracle |" in md and "| ours (source, no gap) | DR |" in md


@pytest.mark.parametrize("target", engines.ENGINES)
def test_friction_holds_the_cart_against_a_smaller_force(target):
    """Coulomb friction f on the slider: a force below f leaves the cart (nearly: MuJoCo's
    friction is a soft constraint) at rest, one above it moves the cart less than without."""
    def push(force, **options):
        with engines.load(target, "cartpole", native=True, **options) as env:
            env.set_state([0.0, 0.0], [0.0, 0.0])
            env.step([force, 0.0])
            return env.get_state()[1][0]
    free = push(1.0)
    assert abs(push(1.0, friction={"slider": 2.0})) < 0.2 * free
    assert 0 < push(3.0, friction={"slider": 2.0}) < push(3.0)
    with pytest.raises(ValueError):
        engines.load(target, "cartpole", friction={"rail": 1.0})


def test_native_pybullet_keeps_its_link_damping():
    speeds = {}
    for native in (False, True):
        with engines.load("pybullet", "cartpole", native=native) as env:
            env.set_state([0.0, 0.0], [1.0, 0.0])
            env.step([0.0, 0.0])
            speeds[native] = env.get_state()[1][0]
    assert speeds[False] == 1.0 and 0.99 < speeds[True] < 0.9999


# ---------------------------------------------------------------- the half cheetah in MuJoCo


@pytest.fixture(scope="module")
def cheetah_policies(tmp_path_factory):
    """UC and DR half-cheetah policies of policy seed 0 after a tiny PPO budget (2048 steps)."""
    assert BINARY.exists(), f"{BINARY} missing: run `make setup`"
    folder = tmp_path_factory.mktemp("half_cheetah")
    for kind in ("uc", "dr"):
        subprocess.run([str(BINARY), "train", "--task", "half_cheetah", "--policy", kind, "--seed", "0",
                        "--steps", "2048", "-o", str(folder / f"{kind}-seed0.json")], check=True, capture_output=True)
    return folder


def run_cheetah(out, policies, *extra, target="mujoco"):
    return main(["transfer", "--task", "half_cheetah", "--target", target, "--seeds", "0",
                 "--policies", str(policies), "--out", str(out), *extra])


def test_gym_mujoco_engine_steps_as_halfcheetah_v5():
    """Five GymMujocoEngine steps under task.forces(a) are HalfCheetah-v5's env.step(a), bit for
    bit (observation and reward), with the torso mass changed in both."""
    import gymnasium
    import mujoco

    from harness.contact import GYM_CHEETAH
    from harness.engines.mujoco import GymMujocoEngine

    task = diffosi.Task("half_cheetah")
    gym = gymnasium.make("HalfCheetah-v5").unwrapped
    gym.reset(seed=0)
    gym.model.body_mass[gym.model.body("torso").id] = 20.0
    mujoco.mj_setConst(gym.model, gym.data)
    ours = GymMujocoEngine(GYM_CHEETAH)
    ours.set_param("body/torso/mass", 20.0)
    _, q0, v0 = task.episodes(1, 3)
    gym.set_state(q0[0], v0[0])
    ours.set_state(q0[0], v0[0])
    rng = np.random.default_rng(0)
    contacts = 0
    for _ in range(60):
        action = rng.uniform(-1.0, 1.0, task.act_dim)
        obs, reward, *_ = gym.step(action)
        q, v = ours.get_state()
        tau = task.forces(action)
        for _ in range(task.substeps):
            ours.step(tau)
        q1, v1 = ours.get_state()
        assert task.observe(q1, v1).tobytes() == obs.tobytes()
        assert task.metric(q, v, action, q1, v1) == reward
        assert np.allclose(ours.d.qfrc_actuator, tau, rtol=1e-14, atol=0)
        contacts += ours.d.ncon > 0
    assert contacts > 30  # the floor was in play
    with pytest.raises(AssertionError):
        ours.step(np.ones(task.act_dim + 3))  # a force on a root dof has no motor


def test_cheetah_transfer_is_finite_and_seeded(tmp_path, cheetah_policies):
    for out in ("a", "b"):
        assert run_cheetah(tmp_path / out, cheetah_policies, "--episodes", "2", "--horizon", "40") == 0
    name = "transfer-half_cheetah-mujoco"
    first = (tmp_path / "a" / f"{name}.json").read_text()
    assert first == (tmp_path / "b" / f"{name}.json").read_text()
    doc = json.loads(first)
    assert doc["engine"]["model"] == "gymnasium:half_cheetah.xml" and doc["engine"]["settings"]["disableflags"] == []
    assert list(doc["methods"]) == list(TASKS["half_cheetah"].methods) and doc["meta"]["horizon"] == 40
    mu = diffosi.Task("half_cheetah").episodes(2, 0)[0][:, 0]
    for method, r in doc["methods"].items():
        for k, e in enumerate(r["episodes"]):
            assert e["mu"] == mu[k] and np.isfinite(e["score"]) and np.isfinite(e["peak_abs_q"]).all(), method
            assert method == "DR" or np.isfinite([e["mae"], e["mare"], e["bias"]]).all()
    for e in doc["methods"]["UC-DiffOSI"]["episodes"]:
        assert len(e["mu_fed"]) == 40 and all(1.0 <= x <= 50.0 for x in e["mu_fed"])
        assert e["mu_fed"][0] == 25.5 and e["mae"] == pytest.approx(np.mean(np.abs(np.array(e["mu_fed"]) - e["mu"])))
    for e in doc["source_diffosi"]:  # in our engine DiffOSI finds the mass
        assert abs(e["mu_hat_final"] - e["mu"]) < 0.1, e
    for e in doc["methods"][JOINT]["episodes"]:  # so does the joint identifier in MuJoCo, no contact law assumed
        assert len(e["mu_fed"]) == 40 and e["mu_fed"][0] == 25.5 and abs(e["mu_hat_final"] - e["mu"]) < 0.1, e
    assert np.isfinite(doc["joint_over_oracle"]) and isinstance(doc["joint_meets_goal"], bool)
    single = doc["single_transition"]  # one transition at a time: exact in ours, split by kind in MuJoCo
    assert list(single["ours"]) == ["all"] and single["ours"]["all"]["count"] == 80
    assert max(map(abs, single["ours"]["all"]["relative_error_quartiles"])) < 1e-9
    assert set(single["mujoco"]) <= {"constrained", "free"} and sum(r["count"] for r in single["mujoco"].values()) == 80
    md = (tmp_path / "a" / f"{name}.md").read_text()
    assert "| UC-DiffOSI |" in md and "## DiffOSI's torso mass under MuJoCo's contact" in md
    assert (tmp_path / "a" / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cheetah_source_row_is_the_rust_eval(tmp_path, cheetah_policies):
    """A full episode in our engine: UC-Oracle's and UC-DiffOSI's returns are `diffosi eval`'s."""
    assert run_cheetah(tmp_path, cheetah_policies, "--episodes", "1") == 0
    doc = json.loads((tmp_path / "transfer-half_cheetah-mujoco.json").read_text())
    for source, ours in (("oracle", doc["source"]["UC-Oracle"]["score"][0]),
                         ("diffosi-no-cd", doc["source_diffosi"][0]["score"])):
        out = subprocess.run([str(BINARY), "eval", "--task", "half_cheetah", "--policy",
                              str(cheetah_policies / "uc-seed0.json"), "--mu-source", source, "--window", "4",
                              "--episodes", "1", "--seed", "0", "--json"], check=True, capture_output=True, text=True)
        assert json.loads(out.stdout)["policies"][0]["metrics"] == [ours], source


@pytest.mark.parametrize("target", ["pybullet", "dart"])
def test_cheetah_goes_to_the_urdf_twins(tmp_path, cheetah_policies, target):
    """The URDF twin in PyBullet (on a plane) and DART (on a ground box) stands on its floor
    (contacts seen), the torso mass set per episode and checked, and the report names what
    the engine lacks."""
    assert run_cheetah(tmp_path, cheetah_policies, "--episodes", "1", "--horizon", "30", target=target) == 0
    doc = json.loads((tmp_path / f"transfer-half_cheetah-{target}.json").read_text())
    assert doc["engine"]["name"] == target and "missing_armature" in doc["engine"]["settings"]
    for r in doc["methods"].values():
        assert all(np.isfinite(e["score"]) and np.isfinite(e["peak_abs_q"]).all() for e in r["episodes"])
    assert doc["single_transition"][target]["constrained"]["count"] > 0
    assert doc["goal"] == 0.95
    report = (tmp_path / f"transfer-half_cheetah-{target}.md").read_text()
    name = {"pybullet": "PyBullet", "dart": "DART"}[target]
    assert f"return in {name}" in report and "no armature" in report
    assert f"{JOINT} reaches" in report and np.isfinite(doc["joint_over_oracle"])


def test_twins_set_the_torso_mass_they_are_given(tmp_path):
    """A twin given a torso mass steps as the twin whose file has it: COM and inertia about the
    COM kept, as our body/torso/mass (PyBullet's changeDynamics alone would recompute the
    inertia from the collision shapes, 8 times the file's at 49 kg)."""
    from harness.contact import CHEETAH_URDF, DartContact, PybulletContact

    text = CHEETAH_URDF.read_text()
    line = next(x for x in text.splitlines() if "<mass" in x and "6.25" in x)  # the torso's
    edited = tmp_path / CHEETAH_URDF.name
    edited.write_text(text.replace(line, line.replace(line.split('"')[1], "31.0")))
    rng = np.random.default_rng(0)
    q, v = np.r_[0.0, 3.0, rng.uniform(-0.3, 0.3, 7)], rng.uniform(-3.0, 3.0, 9)  # in the air
    tau = np.r_[0.0, 0.0, 0.0, rng.uniform(-50.0, 50.0, 6)]
    for kind in (DartContact, PybulletContact):
        ends = []
        for urdf, mass in ((CHEETAH_URDF, 31.0), (edited, None)):
            with kind(urdf, 0.01) as twin:
                if mass is not None:
                    twin.set_param("body/torso/mass", mass)
                    with pytest.raises(ValueError, match="cannot set"):
                        twin.set_param("body/nowhere/mass", 1.0)
                twin.set_state(q, v)
                twin.step(tau)
                ends.append(np.concatenate(twin.get_state()))
        assert np.allclose(ends[0], ends[1], rtol=0.0, atol=1e-12), (kind.name, np.abs(ends[0] - ends[1]).max())


def test_cheetah_takes_no_unmodelled_effects(tmp_path, cheetah_policies):
    assert run_cheetah(tmp_path, cheetah_policies, "--unmodelled", "delay") == 2
    assert not any(tmp_path.iterdir())


def test_contact_variant_gives_each_engine_its_own_settings(tmp_path):
    """half_cheetah_contact: the policies see all three components of mu; a reference engine is
    given the torso mass only, UC-Oracle is fed that engine's own settings (PyBullet: no
    armature) with the true mass, UC-Average the middle of the box."""
    folder = tmp_path / "policies"
    folder.mkdir()
    for kind in ("uc", "dr"):
        subprocess.run([str(BINARY), "train", "--task", "half_cheetah_contact", "--policy", kind, "--seed", "0",
                        "--steps", "2048", "-o", str(folder / f"{kind}-seed0.json")], check=True, capture_output=True)
    assert main(["transfer", "--task", "half_cheetah_contact", "--target", "pybullet", "--seeds", "0",
                 "--episodes", "2", "--horizon", "20", "--policies", str(folder), "--out", str(tmp_path)]) == 0
    doc = json.loads((tmp_path / "transfer-half_cheetah_contact-pybullet.json").read_text())
    assert doc["meta"]["environment"]["pybullet"] == [0.0, 0.4]
    assert list(doc["methods"]) == ["DR", "UC-Average", JOINT, "UC-Oracle"] and doc["diffosi_over_oracle"] is None
    assert np.isfinite(doc["joint_over_oracle"])
    mu = diffosi.Task("half_cheetah_contact").episodes(2, 0)[0][:, 0]
    for r in doc["methods"].values():
        assert [e["mu"] for e in r["episodes"]] == list(mu) and all(np.isfinite(e["score"]) for e in r["episodes"])
    average = doc["methods"]["UC-Average"]["episodes"][0]
    assert average["mae"] == pytest.approx(abs(25.5 - mu[0]))
    report = (tmp_path / "transfer-half_cheetah_contact-pybullet.md").read_text()
    assert "half_cheetah_contact" in report and "No UC-DiffOSI (the paper's residual" in report


def test_darts_cheetah_contact_is_the_one_we_think():
    """DartContact's cheetah: the URDF twin's shapes (a capsule as a cylinder and two end
    spheres, radius 0.046 m), restitution 0, and while sliding DART applies friction 0.4, the
    smaller of the cheetah's 0.4 and its floor's 1."""
    from harness.contact import dart_cheetah_contact

    c = dart_cheetah_contact()
    assert c["shapes"]["torso"].count("SphereShape [0.046]") == 4
    assert c["shapes"]["ground"] == "BoxShape [100.0, 100.0, 1.0]"
    assert all(c["shapes"][b].count("SphereShape [0.046]") == 2 for b in ("bthigh", "bshin", "bfoot", "fthigh"))
    assert c["friction_restitution"] == {"half_cheetah": [(0.4, 0.0)], "ground": [(1.0, 0.0)]}
    assert c["sliding_friction"] == pytest.approx(0.4, abs=1e-3) and c["sliding_speed_after"] > 1.0
