"""`python -m harness robustness`: identification from MuJoCo data with noise, delay,
outliers, no excitation and truths at and beyond the bounds never answers NaN, raises
the flags each case calls for, and the Huber loss beats the squared loss on outliers.

Window 20 (one corrupted transition) keeps the run short. The Huber margin: on the
outlier windows the squared loss lands 1e-2 to 1 away from the truth, Huber within a
few times the noise-only error (1e-4 cartpole mu, 1e-2 double pendulum); asking for a
factor 2 fails a Huber loss that does nothing. No timing is asserted.
"""

import json

import numpy as np
import pytest

import diffosi
from harness.__main__ import main
from harness.engines.base import MODELS
from harness.robustness import CASES, EXPECTED_FLAGS, PROBLEMS, build, make_window, non_finite

WINDOW = 20


@pytest.fixture(scope="module")
def report():
    return build(list(PROBLEMS), seed=0, window=WINDOW)


def rows(report):
    return {(r["problem"], r["case"]): r for r in report["rows"]}


def test_every_case_answers_without_nan(report):
    assert non_finite(report) == []
    assert len(report["rows"]) == len(PROBLEMS) * len(CASES)
    for r in report["rows"]:
        for loss, x in r["losses"].items():
            assert len(x["mu"]) == len(r["truth"]) and all(np.isfinite(x["std"])), (r["case"], loss)
            p = PROBLEMS[r["problem"]]
            assert np.all(np.asarray(x["mu"]) >= p.lower) and np.all(np.asarray(x["mu"]) <= p.upper)


def test_flags_where_expected(report):
    by = rows(report)
    for (name, case), flags in EXPECTED_FLAGS.items():
        for loss, x in by[(name, case)]["losses"].items():
            assert flags <= set(x["flags"]), (name, case, loss, x["flags"])
    for name in PROBLEMS:
        clean = by[(name, "clean")]["losses"]["squared"]
        assert clean["flags"] == [] and clean["error"] < 1e-9, (name, clean)
    # Beyond the bound the estimate sits on it: the error is the distance to the box.
    beyond = by[("cartpole", "beyond-bound")]["losses"]["squared"]
    assert beyond["mu"] == [0.6] and beyond["error"] == pytest.approx(0.2)


def test_huber_beats_squared_loss_on_outliers(report):
    by = rows(report)
    for name in PROBLEMS:
        outliers = by[(name, "outliers")]["losses"]
        assert 2 * outliers["huber"]["error"] < outliers["squared"]["error"], (name, outliers)


def test_same_seed_same_data():
    a, _ = make_window("double_pendulum", "outliers", WINDOW, 3)
    b, _ = make_window("double_pendulum", "outliers", WINDOW, 3)
    assert all(np.array_equal(x, y) for x, y in zip(a.arrays(), b.arrays()))


def test_bad_loss_options_are_value_errors():
    m = diffosi.Model.load(str(MODELS / "double_pendulum.xml"))
    args = (m, ["body/link1/mass"], [0.1], [5.0])
    assert diffosi.DiffOsi(*args).loss == "squared" and diffosi.DiffOsi(*args).huber is None
    assert diffosi.DiffOsi(*args, loss="huber").huber == 1.345
    bad = [({"loss": "huber", "huber": 0.0}, "huber = 0"), ({"loss": "huber", "huber": np.nan}, "huber = NaN"),
           ({"loss": "l1"}, "'l1'"), ({"loss": "huber", "method": "adam"}, "method='lm'")]
    for kwargs, words in bad:
        with pytest.raises(ValueError, match=words):
            diffosi.DiffOsi(*args, **kwargs)
    with pytest.raises(ValueError, match="huber = -1"):
        diffosi.OnlineOsi(diffosi.Task("cartpole"), loss="huber", huber=-1.0)


def test_command_writes_the_report(tmp_path, capsys):
    assert main(["robustness", "--problems", "cartpole", "--window", str(WINDOW), "--out", str(tmp_path)]) == 0
    doc = json.loads((tmp_path / "robustness.json").read_text())
    assert [r["case"] for r in doc["rows"]] == list(CASES)
    text = (tmp_path / "robustness.md").read_text()
    assert "| outliers | 0.3 | huber |" in text and text.strip() in capsys.readouterr().out
