"""`python -m harness osi-bench` on the cartpole: DiffOSI and mujoco.sysid recover the
paper's mu from the same MuJoCo window, and the report files are written.

Tolerance: the data are noiseless and come from the engine both tools model, so the
truth zeroes both residuals (the bench itself checks our step against MuJoCo's and
sysid's residual at the truth to 1e-12). What is left is each solver's stopping rule:
DiffOSI's exact Jacobians leave ~1e-12; sysid's finite-difference Gauss-Newton with its
default gradient tolerance leaves up to ~1e-6. 1e-5 (1e-5 of the mu range [-0.6, 0.6])
passes both and still fails any wrong basin, which lands 1e-1 away or more.
No timing is asserted (speed is reported, never tested).
"""

import json

import numpy as np

from harness import bench
from harness.__main__ import main
from harness.gym_env import pole_com
from harness.osi_bench import PROBLEMS, identify, make_case

MU = (-0.6, -0.3, 0.3, 0.6)
TOLERANCE = 1e-5
TOOLS = ("diffosi", "sysid", "sysid_tuned")


def test_osi_bench_cartpole_recovers_mu_and_writes_the_report(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(bench, "REPEATS", 2)  # timings are reported, not tested: keep the test short
    assert PROBLEMS["cartpole"].truths == [pole_com(mu) for mu in MU]
    assert main(["osi-bench", "--problems", "cartpole", "--windows", "2", "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "osi-bench.json").read_text())
    assert report["meta"]["repeats"] == 2
    text = (tmp_path / "osi-bench.md").read_text()
    assert "| cartpole | 2 | -0.6, 0.38 |" in text and text.strip() in capsys.readouterr().out

    rows = report["rows"]
    assert [r["truth"][0] for r in rows] == list(MU)
    for r in rows:
        assert r["one_step_error"] <= 1e-12 and r["sysid_residual_at_truth"] <= 1e-12
        mu = r["truth"][0]
        for tool in TOOLS:
            est = r["tools"][tool]
            assert abs(est["mu"][0] - mu) < TOLERANCE, (tool, mu, est["mu"])
            assert abs(est["mu"][2] - (0.5 + 0.2 * mu)) < TOLERANCE, (tool, mu, est["mu"])
            assert est["error"] < TOLERANCE and est["evaluations"] >= est["iterations"] >= 1
            assert est["seconds"] > 0.0
        # The planar cartpole cannot show the COM's y: DiffOSI keeps its start and says so.
        assert abs(r["tools"]["diffosi"]["mu"][1] - r["start"][1]) < 1e-12
        assert "unexcited" in r["tools"]["diffosi"]["flags"]
    summary = report["summary"]
    assert [s["problem"] for s in summary] == ["cartpole"] and summary[0]["rows"] == len(MU)


def test_same_seed_same_data_and_estimates():
    def once():
        case = make_case("double_pendulum", PROBLEMS["double_pendulum"].truths[0], 5, np.random.default_rng(7))
        return case, identify(case, threads=1)

    (a, ea), (b, eb) = once(), once()
    assert np.array_equal(a.Q, b.Q) and np.array_equal(a.V, b.V) and np.array_equal(a.taus, b.taus)
    for tool in TOOLS:
        assert ea[tool]["mu"] == eb[tool]["mu"]


def test_contact_problems_recover_mass_and_floor_solref_from_mujoco_data():
    """The hopper standing on its floor (MuJoCo's solver converged): torso mass with the
    floor's solref. Both tools model the same engine, so both reach the truth; DiffOSI's
    exact Jacobians through the constraint solver leave rounding."""
    name = "hopper_floor_solref"
    case = make_case(name, PROBLEMS[name].truths[1], 5, np.random.default_rng(3))
    assert case.one_step_error <= 1e-12 and case.sysid_residual_at_truth <= 1e-12
    estimates = identify(case, threads=1)
    for tool in TOOLS:
        relative = np.abs(np.asarray(estimates[tool]["mu"]) - case.truth) / case.truth
        assert relative.max() < 1e-6, (tool, estimates[tool])
    assert estimates["diffosi"]["flags"] == []
