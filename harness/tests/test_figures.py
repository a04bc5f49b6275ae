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
