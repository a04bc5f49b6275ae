"""The Python module releases the GIL in its long calls: another Python thread runs while one
is inside them, and threads calling them on models of their own get the numbers one thread
gets. (How much threads gain is measured, not asserted: README, "Sweeps".)"""

import threading

import numpy as np
import pytest

import diffosi
from harness.engines.base import gym_assets_dir

HUMANOID = str(gym_assets_dir() / "humanoid.xml")


def humanoid_rollout(model, steps=1500):
    return model.rollout(model.reference_q(), np.zeros(model.nv), np.zeros((steps, model.nv)))


def runs_alongside(call) -> bool:
    """Whether this thread gets through a stretch of Python (some thousandths of a second)
    while another thread is inside `call` (which takes a good part of a second): a call
    that holds the GIL would keep this thread waiting until it returns."""
    entered = threading.Event()

    def worker():
        entered.set()
        call()

    t = threading.Thread(target=worker)
    t.start()
    entered.wait()
    total = 0
    for k in range(200_000):
        total += k
    alive = t.is_alive()
    t.join()
    return alive


@pytest.mark.parametrize("what", ["rollout", "train"])
def test_long_calls_let_other_threads_run(what):
    if what == "rollout":
        model = diffosi.Model.load(HUMANOID)
        call = lambda: humanoid_rollout(model)  # noqa: E731
    else:
        task = diffosi.Task("cartpole")
        call = lambda: diffosi.Policy.train(task, "uc", seed=0, steps=40_000)  # noqa: E731
    assert runs_alongside(call), f"{what} holds the GIL"


def test_threads_get_the_numbers_one_thread_gets():
    models = [diffosi.Model.load(HUMANOID) for _ in range(2)]
    alone = humanoid_rollout(models[0], 300)
    out = [None, None]

    def work(k):
        out[k] = humanoid_rollout(models[k], 300)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    [t.start() for t in threads]
    [t.join() for t in threads]
    for q, v in out:
        np.testing.assert_array_equal(q, alone[0])
        np.testing.assert_array_equal(v, alone[1])


def test_a_model_busy_in_another_thread_says_so():
    """A Model serves one thread at a time: a second thread gets a clear error, not a race."""
    model = diffosi.Model.load(HUMANOID)
    errors = []
    entered = threading.Event()

    def long():
        entered.set()
        humanoid_rollout(model, 3000)

    t = threading.Thread(target=long)
    t.start()
    entered.wait()
    while t.is_alive():
        try:
            model.nv
        except RuntimeError as e:
            errors.append(str(e))
            break
    t.join()
    assert errors and "borrowed" in errors[0]
