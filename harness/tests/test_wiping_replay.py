"""`python -m harness wiping-replay` on a short episode (the approach and the first
contact): our engine reproduces its own record, MuJoCo (the same contact law) agrees with
it to 1e-9 at every step, in contact too, PyBullet's and DART's contact gaps are reported,
and the report is deterministic.
Run with `make test`."""

import argparse
import json

import numpy as np

from harness import wiping_replay


def run(tmp_path, name):
    out = tmp_path / name
    args = argparse.Namespace(mu="30,70", steps=400, every=5, out=out)
    status = wiping_replay.run(args)
    return status, json.loads((out / "wiping-replay.json").read_text())


def test_short_replay_passes_and_is_deterministic(tmp_path):
    status, doc = run(tmp_path, "a")
    assert status == 0
    engines = doc["engines"]
    assert set(engines) == {"ours", "mujoco", "pybullet", "dart"}
    ours = engines["ours"]
    assert ours["open_loop"]["max_q_gap"] == 0.0
    assert ours["one_step"]["contact"]["force_gap"]["max"] == 0.0
    assert doc["free_until_step"] > 50 and doc["first_contact_step"] < 400
    mj = engines["mujoco"]
    for phase in ("free", "contact"):
        assert mj["one_step"][phase]["rows"] > 0 and mj["one_step"][phase]["v_gap"]["max"] <= 1e-9
    assert mj["open_loop"]["max_q_gap"] <= 1e-9
    for name in ("mujoco", "pybullet", "dart"):
        contact = engines[name]["one_step"]["contact"]
        assert contact["rows"] > 0 and np.isfinite(contact["force_gap"]["max"])
        assert len(engines[name]["open_loop"]["force"]) == 401
    assert (tmp_path / "a" / "wiping-replay.png").stat().st_size > 10_000
    _, again = run(tmp_path, "b")
    assert again == doc
