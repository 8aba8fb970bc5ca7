"""The pictures of bench/tradeoff.py: speed against accuracy, one panel per scene (and two for the event cases).

Each panel is a log–log scatter of real-time factor against error with the Pareto front dashed. The scene's own
setting (``DEFAULT``: what ``snakesim run SCENE`` uses, the default integrator) is a large star in the legend,
"default"; a default that failed (unstable, or no error figure) is a cross on the top edge, still labelled.

Labels are placed greedily (:func:`place_labels`), no adjustText: each point in turn, lowest error first,
takes the first of the candidate offsets (12 directions on rings of 4 to 130 pt) whose text box overlaps
no label placed before, no marker and not the legend, and stays inside the axes; where none is free, the
one overlapping least. A label moved off its first ring gets a thin leader line. Each label's size is measured by the renderer, in
pixels, after the layout is final (``tight_layout`` first), so what is measured is what is saved.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: the label of the scene's own setting (bench/tradeoff.py settings()): the default integrator and step
DEFAULT = "scene's own setting"
#: pt, the rings of candidate label offsets
RINGS = (4.0, 10.0, 18.0, 28.0, 40.0, 56.0, 76.0, 100.0, 130.0)
#: pt, half the side of the square kept clear around each marker
MARKER_HALF = 3.5


def pareto(points):
    """Indices of the points no other point beats in both RTF (higher) and error (lower)."""
    idx = []
    for i, (r, e) in enumerate(points):
        if not any((r2 >= r and e2 <= e) and (r2 > r or e2 < e) for j, (r2, e2) in enumerate(points) if j != i):
            idx.append(i)
    return idx


def _candidates():
    """(dx, dy, ha, va, ring) offsets in pt, nearest ring first, 12 directions each (right first)."""
    out = []
    for k, r in enumerate(RINGS):
        for ang in np.radians([15, -15, 90, -90, 165, 195, 50, -50, 130, -130, 0, 180]):
            dx, dy = r * np.cos(ang), r * np.sin(ang)
            ha = "left" if dx > 1e-9 else "right" if dx < -1e-9 else "center"
            va = "bottom" if dy > 1e-9 else "top" if dy < -1e-9 else "center"
            out.append((float(dx), float(dy), ha, va, k))
    return out


def _box(x, y, w, h, ha, va) -> tuple:
    """(x0, y0, x1, y1) px of a w × h text anchored at (x, y) with alignment ``ha``, ``va``."""
    x0 = x - w if ha == "right" else x - w / 2 if ha == "center" else x
    y0 = y - h if va == "top" else y - h / 2 if va == "center" else y
    return (x0, y0, x0 + w, y0 + h)


def _overlap(a, b) -> float:
    """Area in px² shared by boxes a and b (x0, y0, x1, y1)."""
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return w * h if w > 0 and h > 0 else 0.0


def place_labels(ax, points, labels, fontsize: float = 6.0) -> list:
    """Annotate ``points`` (data coordinates, the axes' scales and limits final) with ``labels``, none
    overlapping another, a marker or the legend (module docstring); returns the annotations, in the order of
    ``points``. Each label's size is measured once; the candidates' boxes are then arithmetic."""
    fig = ax.figure
    renderer = fig.canvas.get_renderer()
    px_per_pt = fig.dpi / 72.0
    xy = ax.transData.transform(np.asarray(points, dtype=float).reshape(-1, 2))
    half = MARKER_HALF * px_per_pt
    markers = [(x - half, y - half, x + half, y + half) for x, y in xy]
    frame = ax.get_window_extent(renderer).extents
    legend = ax.get_legend()
    placed: list[tuple] = [tuple(legend.get_window_extent(renderer).extents)] if legend is not None else []
    pad = 1.0 * px_per_pt                       # a little air around each label
    out = [None] * len(xy)
    for i in sorted(range(len(xy)), key=lambda j: (xy[j][1], xy[j][0])):
        probe = ax.text(0, 0, labels[i], fontsize=fontsize)
        bb = probe.get_window_extent(renderer)
        probe.remove()
        w, h = bb.width + 2 * pad, bb.height + 2 * pad
        best = None
        for dx, dy, ha, va, ring in _candidates():
            box = _box(xy[i][0] + dx * px_per_pt, xy[i][1] + dy * px_per_pt, w, h, ha, va)
            outside = (max(frame[0] - box[0], 0) + max(box[2] - frame[2], 0)) * h + \
                (max(frame[1] - box[1], 0) + max(box[3] - frame[3], 0)) * w
            cost = sum(_overlap(box, b) for b in placed) + sum(_overlap(box, m) for m in markers) + outside
            if best is None or cost < best[0]:
                best = (cost, dx, dy, ha, va, ring, box)
            if cost == 0.0:
                break
        _, dx, dy, ha, va, ring, box = best
        # away from its point a leader line says whose label it is
        arrow = {"arrowstyle": "-", "lw": 0.3, "color": "0.5", "shrinkA": 0, "shrinkB": 2} if ring > 0 else None
        out[i] = ax.annotate(labels[i], points[i], xytext=(dx, dy), textcoords="offset points", ha=ha, va=va,
                             fontsize=fontsize, arrowprops=arrow)
        placed.append(box)
    return out


def scene_panel(ax, rows, scene):
    """One scene's settings: each stable setting's RTF against its error; the scene's own setting (the
    default) as a star; the Pareto front over all stable settings. The points and their labels, for
    :func:`place_labels` once the layout is final."""
    ok = [r for r in rows if r["scene"] == scene and r.get("stable") and "pos_err_m" in r]
    others = [r for r in ok if r["setting"] != DEFAULT]
    pts = [(r["rtf"], max(r["pos_err_m"], 1e-12)) for r in ok]
    ax.scatter([r["rtf"] for r in others], [max(r["pos_err_m"], 1e-12) for r in others], s=18, color="tab:blue",
               zorder=3)
    points = [(r["rtf"], max(r["pos_err_m"], 1e-12)) for r in others]
    labels = [r["setting"] for r in others]
    default = next((r for r in rows if r["scene"] == scene and r["setting"] == DEFAULT), None)
    if default is not None:
        failed = default not in ok
        top = max([p[1] for p in pts] + [1e-3]) * 3
        x = default.get("rtf") or (min(p[0] for p in pts) if pts else 1.0)
        y = top if failed else max(default["pos_err_m"], 1e-12)
        ax.scatter([x], [y], s=110, marker="X" if failed else "*", color="crimson", edgecolor="k", lw=0.5,
                   zorder=4, label="default (the scene's own setting)" + (": failed" if failed else ""))
        points.append((x, y))
        labels.append("default" + (f" (failed: {str(default.get('stop') or default.get('error', ''))[:40]})"
                                   if failed else ""))
    front = sorted((pts[i] for i in pareto(pts)), key=lambda p: p[0])
    if front:
        ax.plot(*zip(*front), "k--", lw=0.8, label="Pareto front")
    ax.set_xscale("log"), ax.set_yscale("log")
    ax.set_xlabel("real-time factor (sim s / wall s)")
    ax.set_ylabel("max position error vs reference, m")
    ax.set_title(f"{scene} ({ok[0]['horizon_s']:g} s)" if ok else scene)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7)
    return points, labels


def plot(rows, path, event_rows=()):
    """The figure (one panel per scene, two for the events), saved to ``path``; returned for inspection."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = sorted({r["scene"] for r in rows})
    panels = len(scenes) + (2 if event_rows else 0)
    if not panels:
        return None
    fig, axes = plt.subplots(1, panels, figsize=(6.5 * panels, 5), squeeze=False)
    pending = []
    if event_rows:
        pending.append((axes[0][len(scenes)], *plot_events(axes[0][len(scenes)], axes[0][len(scenes) + 1],
                                                           event_rows)))
    for ax, scene in zip(axes[0], scenes):
        pending.append((ax, *scene_panel(ax, rows, scene)))
    fig.tight_layout()
    for ax, points, labels in pending:       # after the layout: the boxes measured are the boxes saved
        place_labels(ax, points, labels)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    return fig


def plot_events(ax, ax_cases, event_rows):
    """Left: each event setting's RTF (CPU, over all cases) against its worst error, the settings that failed a
    case as crosses on the top edge, the Pareto front of the rest. Right: every case's point, by setting.
    The left panel's points and labels, for :func:`place_labels`."""
    import matplotlib
    import matplotlib.pyplot as plt

    ok = [e for e in event_rows if not e["failed"] and e["worst_error_m"] is not None]
    top = max([e["worst_error_m"] for e in ok] + [1e-3]) * 3
    colors = {e["setting"]: plt.cm.tab10(i % 10) for i, e in enumerate(event_rows)}
    points, labels = [], []
    for e in event_rows:
        failed = bool(e["failed"]) or e["worst_error_m"] is None
        y = top if failed else max(e["worst_error_m"], 1e-7)
        ax.scatter(e["rtf_cpu"], y, s=24, marker="x" if failed else "o", color=colors[e["setting"]])
        points.append((e["rtf_cpu"], y))
        labels.append(e["setting"] + (f" (failed {len(e['failed'])} of {e['cases']})" if e["failed"] else ""))
    pts = [(e["rtf_cpu"], max(e["worst_error_m"], 1e-7)) for e in ok]
    front = sorted((pts[i] for i in pareto(pts)), key=lambda p: p[0])
    if front:
        ax.plot(*zip(*front), "k--", lw=0.8, label="Pareto front")
    ax.set_xscale("log"), ax.set_yscale("log")
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("real-time factor by CPU time, all event cases")
    ax.set_ylabel("worst error over the cases vs reference, m (x: failed a case)")
    ax.set_title("events (bench/events.py): each setting ('scene': each case's own)", fontsize=10)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7)
    cases = sorted({p["case"] for e in event_rows for p in e["points"]})
    markers = dict(zip(cases, "os^vD<>pPh*"))
    for e in event_rows:
        for p in e["points"]:
            y = top if not p["completed"] or p["error_m"] is None else max(p["error_m"], 1e-7)
            ax_cases.scatter(p["rtf_cpu"], y, s=20, color=colors[e["setting"]], marker=markers[p["case"]],
                             alpha=0.35 if not p["completed"] else 0.9)
    handles = ([plt.Line2D([], [], color=colors[e["setting"]], marker="o", ls="", label=e["setting"])
                for e in event_rows] +
               [plt.Line2D([], [], color="0.3", marker=markers[c], ls="", label=c) for c in cases])
    ax_cases.legend(handles=handles, fontsize=5.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    ax_cases.set_xscale("log"), ax_cases.set_yscale("log")
    ax_cases.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax_cases.set_xlabel("real-time factor by CPU time")
    ax_cases.set_ylabel("error vs the case's reference, m (top edge: failed)")
    ax_cases.set_title("events: every case")
    ax_cases.grid(True, which="both", lw=0.3)
    return points, labels
