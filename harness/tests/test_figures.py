"""The window-study figure from a small hand-made study JSON (the layout of src/experiments/mod.rs)."""

import json

from harness.__main__ import main


def test_window_figure_is_drawn_with_gaps(tmp_path):
    doc = {"task": "toy", "seed": 0, "models": ["a"], "episodes_per_model": 2, "steps": 3,
           "curves": [{"context_window": n, "transitions": n - 1, "mean_abs_error": [0.3, 1e-14, None],
                       "running": [2, 2, 0]} for n in (2, 3)]}
    (tmp_path / "window-toy.json").write_text(json.dumps(doc))
    assert main(["figures", "--task", "toy", "--reports", str(tmp_path)]) == 0
    png = (tmp_path / "window-toy.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


def test_missing_study_is_a_clear_error(tmp_path):
    try:
        main(["figures", "--task", "toy", "--reports", str(tmp_path)])
    except SystemExit as e:
        assert "run `diffosi reproduce toy` first" in str(e)
    else:
        raise AssertionError("no error for a missing study")


def test_by_mu_figure_draws_every_method_and_empty_bins(tmp_path):
    from harness.figures import by_mu_figure

    def bins(means):
        return [{"lo": -0.6 + 0.3 * k, "hi": -0.3 + 0.3 * k, "episodes": 0 if m is None else 2, "mean": m}
                for k, m in enumerate(means)]

    doc = {"task": "cartpole", "methods": [
        {"label": "UC-Oracle", "source": "oracle", "summary": {"by_mu": bins([300.0, 500.0, None, 500.0])},
         "episodes": [{}] * 6},
        {"label": "DR", "source": None, "summary": {"by_mu": bins([100.0, 450.0, None, 200.0])},
         "episodes": [{}] * 6},
    ]}
    png = by_mu_figure(doc, tmp_path / "by-mu.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
