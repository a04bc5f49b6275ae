"""`python -m harness wiping-transfer` on one run: the controller (our code, MuJoCo's sensed
force) regulates the mean force in MuJoCo too, every method is scored in both engines, and the
report is deterministic. Run with `make test`."""

import argparse
import json

import numpy as np

from harness import wiping_transfer


def test_one_run_in_mujoco_and_ours(tmp_path):
    docs = []
    for name in ("a", "b"):
        out = tmp_path / name
        assert wiping_transfer.run(argparse.Namespace(runs=1, seed=3, out=out)) == 0
        docs.append(json.loads((out / "transfer-wiping-mujoco.json").read_text()))
    assert docs[0] == docs[1]
    run = docs[0]["runs"][0]
    assert abs(run["canonical_last_second"]["mean_force"] - 3.0) < 0.5
    assert set(run["methods"]) == set(wiping_transfer.METHODS)
    for m in run["methods"].values():
        assert np.isfinite(m["mujoco"]) and 0.0 < m["ours"] < 10.0
    lo, hi = 1.0, 100.0
    assert all(lo <= x <= hi for x in run["mu_hat"])
