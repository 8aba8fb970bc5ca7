"""bench/tradeoff_plot.py: the speed–accuracy picture (docs/images/tradeoff-pareto.png) shows the default
setting as its own point, and no label overlaps another label, a marker or the legend."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
pytest.importorskip("matplotlib")

from tradeoff_plot import DEFAULT, MARKER_HALF, plot  # noqa: E402

SCENE = "surface-screw-traverse"


def _rows(default_ok=True):
    """A crowded panel: 14 settings within a factor 2 of each other in both RTF and error (the real plot's
    rosenbrock_w cluster), and the scene's own setting among them."""
    rng = np.random.default_rng(3)
    rows = [{"scene": SCENE, "setting": f"rosenbrock_w dt=0.005 method=ros2 jacobian_every={k}", "stable": True,
             "rtf": float(40 * 2 ** rng.uniform(0, 1)), "pos_err_m": float(1e-3 * 2 ** rng.uniform(0, 1)),
             "horizon_s": 2.0} for k in range(14)]
    default = {"scene": SCENE, "setting": DEFAULT, "horizon_s": 2.0, "stop": "duration reached"}
    default.update({"stable": True, "rtf": 55.0, "pos_err_m": 1.4e-3} if default_ok else
                   {"stable": False, "rtf": 50.0, "stop": "integrator rosenbrock_w failed after t = 0.5 s"})
    return rows + [default]


def _boxes(fig):
    from matplotlib.text import Text

    fig.canvas.draw()             # at the figure's own dpi (savefig drew it at 120)
    renderer = fig.canvas.get_renderer()
    ax = fig.axes[0]
    texts = [t for t in ax.texts]
    return ax, renderer, texts, [Text.get_window_extent(t, renderer) for t in texts]


@pytest.fixture(scope="module")
def crowded(tmp_path_factory):
    path = tmp_path_factory.mktemp("tradeoff") / "p.png"
    return plot(_rows(), path), path


def test_the_default_is_a_starred_labelled_point(crowded):
    rows = _rows()
    fig, path = crowded
    assert path.stat().st_size > 0
    ax, _, texts, _ = _boxes(fig)
    star = [c for c in ax.collections if "default" in str(c.get_label())]
    assert len(star) == 1 and np.allclose(star[0].get_offsets(), [[55.0, 1.4e-3]])
    assert sorted(t.get_text() for t in texts) == sorted(["default", *(r["setting"] for r in rows[:-1])])
    assert any("default" in t.get_text() for t in ax.get_legend().get_texts())


def test_no_label_overlaps_a_label_a_marker_or_the_legend(crowded):
    fig = crowded[0]
    ax, renderer, texts, boxes = _boxes(fig)
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert not a.overlaps(b), (a, b)
    half = MARKER_HALF * fig.dpi / 72.0 - 0.5
    for x, y in ax.transData.transform([t.xy for t in texts]):
        for b in boxes:
            assert not (b.x0 < x + half and x - half < b.x1 and b.y0 < y + half and y - half < b.y1)
    legend = ax.get_legend().get_window_extent(renderer)
    assert not any(legend.overlaps(b) for b in boxes)


def test_a_failed_default_is_still_shown_on_the_top_edge(tmp_path):
    fig = plot(_rows(default_ok=False), tmp_path / "p.png")
    ax, _, texts, _ = _boxes(fig)
    label = next(t.get_text() for t in texts if t.get_text().startswith("default"))
    assert "failed" in label and "rosenbrock_w failed" in label
    mark = next(c for c in ax.collections if "default" in str(c.get_label()))
    assert mark.get_offsets()[0][1] > 2e-3          # above every stable setting's error
