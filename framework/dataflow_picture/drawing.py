"""Pixels for a :func:`~.layout.layout`: boxes, frames and routed, labelled arrows (matplotlib, Agg)."""

from __future__ import annotations

import math
import re
from collections import defaultdict
from pathlib import Path

from .layout import (
    BOX_PAD_Y, FAN_OUT, GROUP_FILLS, GROUP_PT, LABEL_PT, LEGEND, LINE_H, LONG_ARROW, MARGIN, NAME_PT,
    STRIP_GAP, STYLE, TEXT_PT, Box, Layout, Link, _label_width, layout,
)


# -- drawing -------------------------------------------------------------------------

def _bezier_point(p0, p2, rad, t):
    (x1, y1), (x2, y2) = p0, p2
    cx, cy = (x1 + x2) / 2 + rad * (y2 - y1), (y1 + y2) / 2 - rad * (x2 - x1)
    a, b, c = (1 - t) ** 2, 2 * t * (1 - t), t ** 2
    return a * x1 + b * cx + c * x2, a * y1 + b * cy + c * y2



def _pattern(names: list[str]) -> str:
    """'robot/module*/sensor.u' for names that differ only in their numbers, else a count."""
    pats = {re.sub(r"\d+", "*", n) for n in names}
    return pats.pop() if len(pats) == 1 else f"{len(names)} inputs"


def _fan_outs(links: list[Link]) -> tuple[list[Link], dict[tuple[str, str], list[tuple[str, str]]]]:
    """Split off outputs that feed FAN_OUT or more components; returns (other links, fans)."""
    targets = defaultdict(list)
    for lk in links:
        for o, i in lk.ports:
            targets[(lk.src, o)].append((lk.dst, i))
    fans = {k: v for k, v in targets.items() if len({d for d, _ in v}) >= FAN_OUT}
    rest = []
    for lk in links:
        ports = [(o, i) for o, i in lk.ports if (lk.src, o) not in fans]
        if ports:
            rest.append(Link(lk.src, lk.dst, ports, lk.through, lk.orders))
    return rest, fans


def _facing(a: Box, b: Box) -> tuple[float, float, float]:
    """Distance between centres and how far each centre is from its border along the line."""
    (ax_, ay), (bx, by) = a.center, b.center
    d = max(math.hypot(bx - ax_, by - ay), 1e-9)
    ux, uy = max(abs(bx - ax_) / d, 1e-9), max(abs(by - ay) / d, 1e-9)
    return d, min(a.w / 2 / ux, a.h / 2 / uy), min(b.w / 2 / ux, b.h / 2 / uy)


def _oriented(lk: Link, left: str) -> list[str]:
    """'out → in' lines, or 'in ← out' when the arrow runs right to left."""
    if lk.src == left:
        return [f"{o} → {i}" for o, i in lk.ports]
    return [f"{i} ← {o}" for o, i in lk.ports]


def _label_size(lines: list[str]) -> tuple[float, float]:
    return _label_width("\n".join(lines)) + 0.08, 0.115 * len(lines) + 0.06


def _overlap(r1, r2) -> float:
    w = min(r1[2], r2[2]) - max(r1[0], r2[0])
    h = min(r1[3], r2[3]) - max(r1[1], r2[1])
    return w * h if w > 0 and h > 0 else 0.0


def _hits(p0, p2, rad, obstacles, bounds=None) -> int:
    """How many sample points of an arc fall inside other boxes (or off the picture)."""
    n = 0
    for k in range(1, 32):
        x, y = _bezier_point(p0, p2, -rad, k / 32)
        n += any(x0 < x < x1 and y0 < y < y1 for x0, y0, x1, y1 in obstacles)
        if bounds is not None:
            n += 2 * (not (bounds[0] <= x <= bounds[2] and bounds[1] <= y <= bounds[3]))
    return n


def _choose_rad(p0, p2, preferred: float, obstacles, bounds=None) -> float:
    """The preferred bend unless the arc then crosses a box: then the least bend that clears."""
    if _hits(p0, p2, preferred, obstacles, bounds) == 0:
        return preferred
    cands = [preferred] + [s * r for r in (0.15, 0.25, 0.35, 0.5, 0.7) for s in (1, -1)]
    return min(cands, key=lambda r: (_hits(p0, p2, r, obstacles, bounds), abs(r)))


def _draw_links(ax, lay: Layout, patches: dict) -> None:
    from matplotlib.patches import FancyArrowPatch
    from matplotlib.path import Path as MplPath

    fixed, movable = [], []   # labels: (x, y, lines, greyed) and (candidates, lines, greyed)
    boxes = lay.boxes
    bounds = (-MARGIN, -MARGIN, lay.width + MARGIN, lay.height + MARGIN)

    def obstacles(*skip):
        return [(b.x - 0.03, b.y - 0.03, b.x + b.w + 0.03, b.y + b.h + 0.03)
                for n, b in boxes.items() if n not in skip]

    def arrow(src, dst, rad, color, alpha=1.0):
        ax.add_patch(FancyArrowPatch(src.center, dst.center, patchA=patches[src.name], patchB=patches[dst.name],
                                     connectionstyle=f"arc3,rad={rad:.4f}", arrowstyle="-|>", mutation_scale=9,
                                     color=color, lw=0.9, shrinkA=1, shrinkB=1, zorder=1, alpha=alpha))

    def on_arc(src, dst, rad):
        dd, rs, rt = _facing(src, dst)
        t = min(max(0.5 + (rs - rt) / (2 * dd), 0.1), 0.9)
        # arc3 bends in display space, where y points the other way: hence -rad
        return _bezier_point(src.center, dst.center, -rad, t)

    links, fans = _fan_outs(lay.links)
    for (src_name, out), targets in fans.items():
        # a broadcast: a stub at the source naming the receivers, a stub into each receiver naming the source
        src = boxes[src_name]
        greyed = src.kind == "pruned"
        y = src.y + src.h / 2
        ax.add_patch(FancyArrowPatch((src.x + src.w, y), (src.x + src.w + 0.3, y), arrowstyle="-|>",
                                     mutation_scale=9, color="#444444", lw=0.9, zorder=1, shrinkA=0, shrinkB=0))
        lines = [f"{out} → {len(targets)} inputs:", _pattern([f"{d}.{i}" for d, i in targets])]
        fixed.append((src.x + src.w + 0.34 + _label_size(lines)[0] / 2, y, lines, greyed))
        for dst_name, inp in targets:
            dst = boxes[dst_name]
            y = dst.y + dst.h / 2
            ax.add_patch(FancyArrowPatch((dst.x - 0.3, y), (dst.x, y), arrowstyle="-|>", mutation_scale=9,
                                         color="#444444", lw=0.9, zorder=1, shrinkA=0, shrinkB=1))
            tag = [f"{src_name}.{out} → {inp}"]
            fixed.append((dst.x - 0.32 - _label_size(tag)[0] / 2, y, tag, greyed or dst.kind == "pruned"))

    by_pair = defaultdict(list)
    for lk in links:
        by_pair[frozenset((lk.src, lk.dst))].append(lk)
    lanes = defaultdict(int)
    for group in by_pair.values():
        first = group[0]
        a, b = boxes[first.src], boxes[first.dst]
        greyed = "pruned" in (a.kind, b.kind)

        def color(lk):
            return "#b0b0b0" if greyed else ("#444444" if lk.orders or not lk.through else "#7a4f9a")

        if first.src == first.dst:               # a component feeding itself: a loop over its top
            x0, x1, y0 = a.x + a.w * 0.7, a.x + a.w * 0.3, a.y
            ax.add_patch(FancyArrowPatch((x0, y0), (x1, y0), connectionstyle="arc3,rad=0.9", arrowstyle="-|>",
                                         mutation_scale=9, color=color(first), lw=0.9, zorder=1))
            fixed.append((a.x + a.w / 2, a.y - 0.45 * (x0 - x1) - 0.05, _oriented(first, first.src), greyed))
            continue
        left, right = sorted((a, b), key=lambda bx: (bx.strip, bx.x, bx.y))

        if lay.mode == "strips" and a.strip != b.strip:
            # wrapped to another strip: down (or up) into the gap between strips, across, into the target
            for lk in group:
                src, dst = boxes[lk.src], boxes[lk.dst]
                upper = min(src.strip, dst.strip)
                lane = lanes[upper]
                lanes[upper] += 1
                gy = lay.strip_bottoms[upper] + STRIP_GAP * (0.35 + 0.15 * (lane % 3))
                sx, tx = src.x + src.w * 0.5, dst.x + dst.w * 0.5
                sy = src.y + src.h if dst.strip > src.strip else src.y
                ty = dst.y if dst.strip > src.strip else dst.y + dst.h
                path = MplPath([(sx, sy), (sx, gy), (tx, gy), (tx, ty)])
                ax.add_patch(FancyArrowPatch(path=path, arrowstyle="-|>", mutation_scale=9, color=color(lk),
                                             lw=0.9, zorder=1, shrinkA=0, shrinkB=1))
                lw_, _ = _label_size(_oriented(lk, lk.src))
                side = 1 if sx > tx else -1
                fixed.append((tx + side * (lw_ / 2 + 0.12), gy, _oriented(lk, lk.src), greyed))
            continue

        d, r_left, r_right = _facing(left, right)
        far = a.strip != b.strip or d - r_left - r_right > LONG_ARROW
        obs = obstacles(a.name, b.name)
        if len(group) == 2:
            one, two = group
            src, dst = boxes[one.src], boxes[one.dst]
            small = min(0.15, 0.12 / d)
            if a.strip != b.strip or (_hits(src.center, dst.center, small, obs, bounds) == 0
                                      and _hits(dst.center, src.center, small, obs, bounds) == 0):
                rads = (small, small)            # the two arrows bow apart
            else:                                # both arcs bend round the same side, nested
                r = _choose_rad(src.center, dst.center, 0.25, obs, bounds)
                r = r if abs(r) >= 0.15 else math.copysign(0.25, r or 1.0)
                rads = (r, -(r + math.copysign(0.1, r)))
            arrow(src, dst, rads[0], color(one), 0.55 if a.strip != b.strip else 1.0)
            arrow(dst, src, rads[1], color(two), 0.55 if a.strip != b.strip else 1.0)
            if far:
                for lk, rad in zip(group, rads):
                    s_, t_ = boxes[lk.src], boxes[lk.dst]
                    dd, rs, rt = _facing(s_, t_)
                    ts = [1 - (rt + k * 0.25) / dd for k in range(1, int((dd - rs - rt) / 0.25))]
                    cands = [_bezier_point(s_.center, t_.center, -rad, t) for t in ts if 0.02 < t < 0.98]
                    movable.append((cands or [on_arc(s_, t_, rad)], _oriented(lk, left.name), greyed))
            elif rads[0] == rads[1]:
                # one label for both directions, the left component's ports on the left
                t = 0.5 + (r_left - r_right) / (2 * d)
                x, y = _bezier_point(left.center, right.center, 0.0, t)
                # arc3 bows a right-to-left arrow up and a left-to-right one down: lines in that order
                lines = [ln for lk in sorted(group, key=lambda lk: lk.src == left.name)
                         for ln in _oriented(lk, left.name)]
                fixed.append((x, y, lines, greyed))
            else:
                for lk, rad in zip(group, rads):
                    fixed.append((*on_arc(boxes[lk.src], boxes[lk.dst], rad), _oriented(lk, left.name), greyed))
            continue

        lk = first
        src, dst = a, b
        if dst.strip == src.strip and dst.layer > src.layer:
            same_row = abs(src.center[1] - dst.center[1]) < 1e-6
            rad = 0.0 if (dst.layer == src.layer + 1 or not same_row) else min(0.25, 0.5 / d)
        else:
            rad = min(0.3, 0.45 / d)
        if a.strip == b.strip:
            rad = _choose_rad(src.center, dst.center, rad, obs, bounds)
        arrow(src, dst, rad, color(lk), 0.55 if a.strip != b.strip else 1.0)
        if far:       # somewhere free along the arrow, as near its target as possible
            dd, rs, rt = _facing(src, dst)
            ts = [1 - (rt + k * 0.25) / dd for k in range(1, int((dd - rs - rt) / 0.25))]
            cands = [_bezier_point(src.center, dst.center, -rad, t) for t in ts if 0.02 < t < 0.98]
            movable.append((cands or [on_arc(src, dst, rad)], _oriented(lk, left.name), greyed))
        else:     # mid-arrow unless that collides (crossing arrows): then a free spot along it
            cands = [on_arc(src, dst, rad)] + [_bezier_point(src.center, dst.center, -rad, t)
                                               for t in (0.38, 0.62, 0.3, 0.7)]
            movable.append((cands, _oriented(lk, left.name), greyed))

    taken = [(b.x, b.y, b.x + b.w, b.y + b.h) for b in boxes.values()]

    def rect(x, y, lines):
        w, h = _label_size(lines)
        return (x - w / 2, y - h / 2, x + w / 2, y + h / 2)

    for x, y, lines, _ in fixed:
        taken.append(rect(x, y, lines))
    placed = list(fixed)
    for cands, lines, greyed in movable:
        best = min(cands, key=lambda c: round(sum(_overlap(rect(*c, lines), r) for r in taken), 3))
        taken.append(rect(*best, lines))
        placed.append((*best, lines, greyed))
    for x, y, lines, greyed in placed:
        ax.text(x, y, "\n".join(lines), color="#8a8a8a" if greyed else "#222222", ha="center", va="center",
                fontsize=LABEL_PT, zorder=4, linespacing=1.1,
                bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85))


def draw(session, path: Path) -> Path:
    """Write the assembly's dataflow graph to ``path`` (.svg or .png)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyBboxPatch, Patch, Rectangle

    path = Path(path)
    lay = layout(session)
    title_h, legend_h = 0.45, 0.35
    fw = lay.width + 2 * MARGIN
    fh = lay.height + 2 * MARGIN + title_h + legend_h
    W = max(fw, 6.0, 0.085 * len(lay.title) + 0.4)
    fig = Figure(figsize=(W, fh))
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0, legend_h / fh, 1, (fh - title_h - legend_h) / fh))
    ax.set_xlim(-MARGIN - (W - fw) / 2, lay.width + MARGIN + (W - fw) / 2)
    ax.set_ylim(lay.height + MARGIN, -MARGIN)
    ax.set_axis_off()
    fig.text(0.5, 1 - 0.5 * title_h / fh, lay.title, ha="center", va="center", fontsize=10)

    for f in sorted(lay.frames, key=lambda f: len(f.path)):
        depth = len(f.path) - 1
        ax.add_patch(FancyBboxPatch((f.x0, f.y0), f.x1 - f.x0, f.y1 - f.y0, boxstyle="round,pad=0,rounding_size=0.06",
                                    fc=GROUP_FILLS[depth % len(GROUP_FILLS)], ec="#b0b0b0", lw=0.8, zorder=0 + 0.01 * depth))
        ax.text(f.x0 + 0.07, f.y0 + 0.04, f.path[-1], ha="left", va="top", fontsize=GROUP_PT, color="#555555",
                fontweight="bold", zorder=0.5)

    patches = {}
    for b in lay.boxes.values():
        fill, edge = STYLE[b.kind]
        pruned = b.kind == "pruned"
        p = FancyBboxPatch((b.x, b.y), b.w, b.h, boxstyle="round,pad=0,rounding_size=0.05", fc=fill, ec=edge,
                           lw=1.1, ls="--" if pruned else "-", zorder=2)
        ax.add_patch(p)
        patches[b.name] = p
        tx = b.x + b.w / 2
        ty = b.y + BOX_PAD_Y
        ink = "#8a8a8a" if pruned else "#111111"
        ax.text(tx, ty, b.short, ha="center", va="top", fontsize=NAME_PT, fontweight="bold", color=ink, zorder=3)
        ty += LINE_H * 1.15
        ax.text(tx, ty, b.type_name, ha="center", va="top", fontsize=TEXT_PT, style="italic",
                color="#8a8a8a" if pruned else "#444444", zorder=3)
        for line in b.info:
            ty += LINE_H
            ax.text(tx, ty, line, ha="center", va="top", fontsize=TEXT_PT, color=ink, zorder=3)

    _draw_links(ax, lay, patches)

    kinds = [k for k in LEGEND if any(b.kind == k for b in lay.boxes.values())]
    handles = [Patch(fc=STYLE[k][0], ec=STYLE[k][1], ls="--" if k == "pruned" else "-", label=LEGEND[k]) for k in kinds]
    if any(lk.through and not lk.orders for lk in lay.links):
        from matplotlib.lines import Line2D
        handles.append(Line2D([], [], color="#7a4f9a", lw=0.9, label="closes a loop through feedthrough"))
    if lay.frames:
        handles.append(Rectangle((0, 0), 1, 1, fc=GROUP_FILLS[0], ec="#b0b0b0", label="sub-assembly"))
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), frameon=False, fontsize=7,
               bbox_to_anchor=(0.5, 0.1 * legend_h / fh))

    suffix = path.suffix.lower()
    if suffix not in (".svg", ".png"):
        raise ValueError(f"'{path}': the picture must end in .svg or .png")
    path.parent.mkdir(parents=True, exist_ok=True)
    import matplotlib

    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": "snakesim"}):
        dpi = max(50, min(130, 7000 / max(fw, fh)))
        fig.savefig(path, format=suffix[1:], dpi=dpi, metadata={"Date": None} if suffix == ".svg" else None)
    return path
