"""The gymnasium cartpole on our engine (harness/gym_env.py): API, seeding, episodes."""

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import diffosi
from harness import gym_env
from harness.gym_env import MODEL


def make(**kwargs):
    return gymnasium.make(gym_env.ENV_ID, **kwargs).unwrapped


def balance(observation):
    """A hand-tuned linear state feedback that keeps the mu = 0 pole up (theta > 0 leans towards +x)."""
    x, theta, x_dot, theta_dot = observation
    return np.array([(1.0 * x + 2.0 * x_dot + 20.0 * theta + 5.0 * theta_dot) / 500.0])


def episode(env, seed, policy):
    observation, _ = env.reset(seed=seed)
    observations, rewards = [observation], []
    while True:
        observation, reward, terminated, truncated, _ = env.step(policy(observation))
        observations.append(observation)
        rewards.append(reward)
        if terminated or truncated:
            return np.array(observations), np.array(rewards), terminated, truncated


def test_registered_and_passes_the_env_checker_without_warnings():
    env = make(mu=0.3)
    assert isinstance(env, gym_env.CartPoleEnv)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env)


@pytest.mark.parametrize("mu", [-0.6, 0.0, 0.3])
def test_mu_moves_the_pole_com_from_its_geometric_centre(mu):
    # the file's pole: 1 m long from the hinge (the pole frame's origin), COM at its middle
    centre = diffosi.Model.load(str(MODEL)).get_param("body/pole/com")
    np.testing.assert_array_equal(centre, [0.0, 0.0, 0.5])
    com = make(mu=mu).model.get_param("body/pole/com")
    np.testing.assert_allclose(com, centre + [mu, 0.0, 0.2 * mu], atol=1e-15)


def test_reset_is_seeded_and_in_range():
    env = make()
    first = [env.reset(seed=s)[0] for s in range(50)]
    again = [env.reset(seed=s)[0] for s in range(50)]
    np.testing.assert_array_equal(first, again)
    starts = np.array(first)
    assert starts.dtype == np.float64 and starts.shape == (50, 4)
    assert np.all(np.abs(starts) <= gym_env.RESET_RANGE)
    assert len({tuple(s) for s in starts}) == 50, "different seeds, different starts"


def test_same_seed_same_trajectory():
    def run(seed):
        actions = iter(np.random.default_rng(0).uniform(-0.02, 0.02, (gym_env.MAX_STEPS, 1)))
        return episode(make(mu=0.2), seed, lambda _: next(actions))[0]

    a, b, c = run(7), run(7), run(8)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a[:2], c[:2]), "another seed, another trajectory"


def test_zero_force_falls_and_terminates():
    observations, rewards, terminated, truncated = episode(make(), 0, lambda _: np.zeros(1))
    assert terminated and not truncated
    assert len(rewards) < 100, "an unforced pole falls within two seconds"
    assert abs(observations[-1][1]) > np.pi / 2 and np.all(np.abs(observations[:-1, 1]) <= np.pi / 2)
    assert rewards.sum() == len(rewards) - 1 and rewards[-1] == 0.0


def test_balanced_pole_is_truncated_at_500_steps():
    _, rewards, terminated, truncated = episode(make(), 1, balance)
    assert truncated and not terminated
    assert len(rewards) == gym_env.MAX_STEPS and rewards.sum() == gym_env.MAX_STEPS


def test_action_is_clipped_and_scaled():
    clipped, scaled = make(max_force=10.0), make(max_force=10.0)
    start, _ = clipped.reset(seed=0)
    scaled.reset(seed=0)
    after_clip = clipped.step(np.array([5.0]))[0]
    after_one = scaled.step(np.array([1.0]))[0]
    np.testing.assert_array_equal(after_clip, after_one)
    q, v = clipped.model.step(start[:2], start[2:], np.array([10.0, 0.0]))
    np.testing.assert_array_equal(after_one, np.concatenate([q, v]))
