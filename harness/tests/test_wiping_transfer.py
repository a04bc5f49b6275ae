"""`python -m harness transfer --task wiping --target all` on one run: the controller (our code,
each engine's sensed force) regulates the mean force in every engine, MuJoCo (the contact law
ours runs) scores every method as ours does, the summary has the cartpole's format, and the
reports are deterministic. Run with `make test`."""

import json

import numpy as np

from harness.__main__ import main
from harness.wiping_transfer import METHODS, TARGETS


def test_one_run_in_every_engine(tmp_path):
    docs = []
    for name in ("a", "b"):
        out = tmp_path / name
        assert main(["transfer", "--task", "wiping", "--target", "all", "--runs", "1", "--seed", "3",
                     "--out", str(out)]) == 0
        docs.append({t: json.loads((out / f"transfer-wiping-{t}.json").read_text()) for t in TARGETS})
        summary = json.loads((out / "transfer-wiping-summary.json").read_text())
        assert set(summary["targets"]) == set(TARGETS) and set(summary["source"]) == set(METHODS)
        assert (out / "transfer-wiping-summary.png").stat().st_size > 10_000
        assert all((out / f"transfer-wiping-{t}.png").stat().st_size > 10_000 for t in TARGETS)
    assert docs[0] == docs[1]
    for target, doc in docs[0].items():
        run = doc["runs"][0]
        assert abs(run["canonical_last_second"]["mean_force"] - 3.0) < 0.5, target
        assert all(1.0 <= x <= 100.0 for x in run["mu_hat"])
        for m in run["methods"].values():
            assert np.isfinite(m["target"]) and 0.0 < m["ours"] < 10.0
        # UC-Oracle's gap taken apart: the parts sum to the metric in every engine.
        for where, parts in run["why"].items():
            assert abs(parts["landing"] + parts["after_dropout"] + parts["rest"] - parts["metric"]) < 1e-12, where
        assert run["why"][target]["metric"] == run["methods"]["UC-Oracle"]["target"]
        # UC-DiffOSI's gap taken apart: DiffOSI is exact on our own episode at the same mu, so what
        # it misses in a target is that engine's transitions; one component swapped at a time.
        assert np.max(run["ours_record"]["mu_abs_error"]) < 1e-6, target
        assert set(run["swaps"]) == {"k_p error only", "k_d error only"}
        assert all(np.isfinite(s["target"]) for s in run["swaps"].values())
        traj = run["trajectory"]
        assert len(traj["squared"]) == len(traj["huber"]) == len(traj["steps"]) and traj["steps"][-1] == 3000
        assert np.array_equal(traj["squared"][-1], run["mu_hat"]), target  # the whole episode: the estimate
        assert abs(run["why"]["ours"]["metric"] - run["methods"]["UC-Oracle"]["ours"]) < 1e-12  # Rust vs numpy sums
    mujoco = docs[0]["mujoco"]
    # The same contact law: MuJoCo's metric is ours to rounding, and DiffOSI finds mu from it.
    for m in mujoco["runs"][0]["methods"].values():
        assert abs(m["target"] - m["ours"]) <= 1e-6 * m["ours"]
    assert np.max(mujoco["runs"][0]["mu_abs_error"]) < 1e-6
    assert np.max(mujoco["runs"][0]["huber"]["mu_abs_error"]) < 1e-6
    assert mujoco["meets_goal"]
    # MuJoCo's parts are ours; DART drops the tip's contact for single steps, PyBullet does not,
    # and both hard contacts hold the tip shallower than our soft one.
    why = {t: docs[0][t]["runs"][0]["why"] for t in TARGETS}
    for key in ("landing", "after_dropout", "rest", "depth"):
        assert abs(why["mujoco"]["mujoco"][key] - why["mujoco"]["ours"][key]) < 1e-9, key
    assert why["dart"]["dart"]["dropouts"] > 0 and why["pybullet"]["pybullet"]["dropouts"] == 0
    for t in ("pybullet", "dart"):
        assert why[t][t]["depth"] < 0.1 * why[t]["ours"]["depth"], t


def test_wiping_takes_no_unmodelled_effects(tmp_path):
    assert main(["transfer", "--task", "wiping", "--target", "mujoco", "--unmodelled", "friction",
                 "--out", str(tmp_path)]) == 2
