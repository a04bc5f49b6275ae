"""The half cheetah's, the wiping arm's and the quadruped's gymnasium environments
(harness/gym_env.py): the env checker, seeding, the task's own dynamics and reward, mu, and their
vectorised variants."""

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import diffosi
from harness import gym_env

IDS = [gym_env.HALF_CHEETAH_ID, gym_env.WIPING_ID, gym_env.QUADRUPED_ID]


def make(env_id, **kwargs):
    return gymnasium.make(env_id, **kwargs).unwrapped


def trajectory(env, seed, actions):
    observation, info = env.reset(seed=seed)
    out = [observation]
    for a in actions:
        observation, reward, terminated, truncated, _ = env.step(a)
        out.append(np.r_[observation, reward])
    return np.array(out[1:]), info["mu"]


@pytest.mark.parametrize("env_id", IDS)
def test_passes_the_env_checker_without_warnings(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(make(env_id))


@pytest.mark.parametrize("env_id", IDS)
def test_same_seed_same_mu_and_trajectory(env_id):
    env = make(env_id)
    actions = np.random.default_rng(0).uniform(-1, 1, (20, env.action_space.shape[0]))
    (a, mu_a), (b, mu_b), (c, mu_c) = (trajectory(env, s, actions) for s in (3, 3, 4))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(mu_a, mu_b)
    assert not np.array_equal(mu_a, mu_c), "another seed, another mu"


def test_the_cheetah_steps_the_task_with_the_torso_mass_it_is_given():
    env = make(gym_env.HALF_CHEETAH_ID, mu=30.0)
    observation, info = env.reset(seed=1)
    task = diffosi.Task("half_cheetah")
    model = task.model([30.0])
    assert info["mu"] == 30.0 and model.get_param("body/torso/mass")[0] == 30.0
    q, v = env._q, env._v  # the state reset drew
    np.testing.assert_array_equal(observation, task.observe(q, v))
    action = np.linspace(-1, 1, 6)
    observation, reward, terminated, truncated, _ = env.step(action)
    q1, v1 = q, v
    for _ in range(task.substeps):
        q1, v1 = model.step(q1, v1, task.forces(action))
    np.testing.assert_array_equal(observation, task.observe(q1, v1))
    assert reward == task.metric(q, v, action, q1, v1) and not terminated and not truncated
    with pytest.raises(ValueError, match="torso mass"):
        make(gym_env.HALF_CHEETAH_ID, mu=80.0)


def test_the_cheetah_is_truncated_after_its_horizon():
    env = make(gym_env.HALF_CHEETAH_ID, mu=6.25)
    env.reset(seed=0)
    steps, truncated = 0, False
    while not truncated:
        *_, terminated, truncated, _ = env.step(np.zeros(6))
        steps += 1
        assert not terminated
    assert steps == diffosi.Task("half_cheetah").horizon


def test_the_quadruped_steps_the_task_through_its_servos():
    mu = np.array([6.0, -0.08])
    env = make(gym_env.QUADRUPED_ID, mu=mu)
    observation, info = env.reset(seed=2)
    task = diffosi.Task("quadruped")
    model = task.model(mu)
    np.testing.assert_array_equal(info["mu"], mu)
    assert model.get_param("body/payload/mass")[0] == 6.0
    q, v = env._q, env._v
    np.testing.assert_array_equal(observation, task.observe(q, v))
    action = np.linspace(-1, 1, 12)
    tau, ctrl = task.inputs(action)
    np.testing.assert_array_equal(tau, np.zeros(18))
    np.testing.assert_allclose(ctrl - task.inputs(np.zeros(12))[1], 0.5 * action, rtol=0, atol=1e-15)
    observation, reward, terminated, truncated, info = env.step(action)
    q1, v1 = q, v
    for _ in range(task.substeps):
        q1, v1 = model.step(q1, v1, tau, ctrl=ctrl)
    np.testing.assert_array_equal(observation, task.observe(q1, v1))
    assert reward == task.metric(q, v, action, q1, v1) and not terminated and not info["fell"]
    with pytest.raises(ValueError, match="payload mass"):
        make(gym_env.QUADRUPED_ID, mu=[9.0, 0.0])
    with pytest.raises(ValueError, match="does not render"):
        gym_env.QuadrupedEnv(render_mode="rgb_array")


def test_a_quadruped_that_falls_is_terminated():
    """Full-range actions alternating every 5 steps throw the Go1 over within its horizon."""
    env = make(gym_env.QUADRUPED_ID, mu=[8.0, 0.1])
    env.reset(seed=0)
    for k in range(env.task.horizon):
        sign = 1.0 if (k // 5) % 2 else -1.0
        _, _, terminated, truncated, info = env.step(sign * np.ones(12))
        if terminated:
            break
    assert terminated and info["fell"] and not truncated and k < env.task.horizon - 1


def test_wiping_with_the_canonical_gains_is_the_tasks_episode():
    """Actions that map to the canonical gains reproduce Wiping.episode; the reward is minus the
    squared force error of the strokes, and over the steps in contact its mean is the metric."""
    mu = np.array([40.0, 20.0])
    env = make(gym_env.WIPING_ID, mu=mu)
    task = diffosi.Wiping(2)
    lo, hi = (np.log(b) for b in task.gains_range)
    action = 2 * (np.log(task.canonical_gains) - lo) / (hi - lo) - 1
    np.testing.assert_allclose(env.gains(action), task.canonical_gains, rtol=1e-12)
    env.reset(seed=0)
    gains = env.gains(action)
    run = task.run(mu)
    forces, rewards = [], []
    for _ in range(run.steps):
        stroking = run.stroking
        forces.append(run.step(gains))
        _, reward, terminated, truncated, _ = env.step(action)
        rewards.append((reward, stroking))
        assert not terminated
    assert truncated
    reference = task.episode(mu, gains=gains)
    np.testing.assert_array_equal(forces, reference["force"][1:])
    touching = [(r, s) for (r, s), f in zip(rewards, forces) if f > task.contact_force and s]
    assert all(r == 0.0 for r, s in rewards if not s)
    assert -np.mean([r for r, _ in touching]) == pytest.approx(
        np.mean([(f - task.force_goal) ** 2 for f, (_, s) in zip(forces, rewards) if f > task.contact_force and s]))


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", ["sync", "async"])
def test_vectorised_copies_step_as_single_environments(env_id, mode):
    envs = gymnasium.make_vec(env_id, num_envs=3, vectorization_mode=mode)
    try:
        observations, infos = envs.reset(seed=5)
        actions = np.random.default_rng(1).uniform(-1, 1, (4, *envs.action_space.shape))
        rows = [envs.step(a) for a in actions]
    finally:
        envs.close()
    assert observations.shape == (3, *envs.single_observation_space.shape)
    for k in range(3):  # copy k is the single environment seeded 5 + k
        single, mu = trajectory(make(env_id), 5 + k, actions[:, k])
        np.testing.assert_array_equal(infos["mu"][k], mu)
        np.testing.assert_array_equal(np.array([np.r_[r[0][k], r[1][k]] for r in rows]), single)
