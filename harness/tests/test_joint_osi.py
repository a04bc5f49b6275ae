"""`python -m harness joint-osi` on a short run: DiffOSI recovers the torso mass from MuJoCo's
transitions with every parameter set under MuJoCo's conventions (and not under DART's), reports
every target and set, and is deterministic.
Run with `make test`."""

import argparse
import json

import numpy as np

from harness import joint_osi


def test_short_joint_identification_study(tmp_path):
    docs = []
    for name in ("a", "b"):
        args = argparse.Namespace(episodes=1, horizon=30, windows="4", seed=0, out=tmp_path / name)
        assert joint_osi.run(args) == 0
        docs.append(json.loads((tmp_path / name / "joint-osi-half_cheetah.json").read_text()))
    assert docs[0] == docs[1]
    doc = docs[0]
    assert list(doc["targets"]) == list(joint_osi.TARGETS)
    for target in doc["targets"].values():
        assert list(target["results"]) == [f"W=4 {s}" for s in joint_osi.SETS]
        assert all(r["windows"] == 2 for r in target["results"].values())
    dart_ways = "W=4 mass+armature, unknown constraints, DART's conventions"
    for key, r in doc["targets"]["mujoco"]["results"].items():  # the same contact law: exact
        if key != dart_ways:
            assert r["mae"] < 1e-6 and r["at_bound"] == 0.0, key
    assert doc["targets"]["mujoco"]["results"][dart_ways]["mae"] > 1e-3  # the conventions matter
    assert "| pybullet | W=4 mass+armature+floor |" in (tmp_path / "a" / "joint-osi-half_cheetah.md").read_text()
    assert list(doc["settings"]) == list(joint_osi.SETTINGS)  # the UC under each engine's settings
    returns = [r["return"][0] for r in doc["settings"].values()]
    assert all(np.isfinite(returns)) and len(set(returns)) == len(returns)  # each setting changes the run
