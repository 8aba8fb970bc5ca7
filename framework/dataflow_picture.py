"""Draw a built assembly's dataflow graph as a picture (``snakesim graph ASSEMBLY -o FILE``).

One box per component (name, type, state sizes, rate, recorded and stop
ports), coloured by kind; one arrow per connected pair of components,
labelled with every ``out → in`` it carries (written ``in ← out`` when the
arrow runs right to left, so each component's port names sit on its side).

Columns: longest-path layering, so a picture reads in the order a step
evaluates. Links into inputs that feed through to an output order the
columns first; a link into a state-only input (a force into a body, a
sample into a hold) orders them too unless it would close a cycle: that is
where every physical feedback loop is cut. Rows: the components of one
sub-assembly (``cell1/mass``, ``cell1/spring``) share a labelled frame,
nested for nested prefixes, and frames are packed onto a skyline so they
never overlap. Pruned components are drawn grey and dashed.

Staying legible at ~50 components: a tall stack of frames continues in
panels side by side, a long chain of columns wraps into strips (its wrap
arrows routed between the strips), arrows bend round boxes in their way,
long arrows carry their labels next to their targets, and an output
broadcast to five or more components is drawn as stubs instead of lines.

:func:`layout` (numbers, testable) is separate from :func:`draw` (pixels).
matplotlib is used without pyplot, on an Agg canvas, so drawing never
touches a global backend.
"""

from __future__ import annotations

import math
import re
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

# sizes in inches (the axes are drawn 1 data unit = 1 inch), fonts in points
NAME_PT, TEXT_PT, LABEL_PT, GROUP_PT = 8.5, 7.0, 6.5, 7.5
LINE_H = 0.16          # one text line in a box
BOX_PAD_X, BOX_PAD_Y = 0.10, 0.08
MIN_BOX_W = 1.05
ROW_GAP = 0.30         # between boxes stacked in one column
ITEM_GAP = 0.22        # between stacked sub-assembly frames
MIN_COL_GAP, MAX_COL_GAP = 0.75, 1.9
GROUP_PAD_X, GROUP_PAD_TOP, GROUP_PAD_BOTTOM = 0.09, 0.24, 0.08
STRIP_GAP = 0.45
PANEL_GAP = 0.6        # extra space between side-by-side panels
TARGET_ASPECT = 1.5    # width / height a wrapped picture aims for
MARGIN = 0.25
LONG_ARROW = 3.0       # inches of visible line beyond which a label sits by its target
FAN_OUT = 5            # an output feeding this many components is drawn as stubs, not lines

STYLE = {  # kind -> (fill, border)
    "continuous": ("#dbe9f6", "#3b6ea5"),
    "discrete": ("#fdebd0", "#b9770e"),
    "algebraic": ("#ffffff", "#555555"),
    "sink": ("#e2f0d9", "#3c763d"),
    "pruned": ("#f2f2f2", "#a8a8a8"),
}
LEGEND = {"continuous": "continuous state", "discrete": "discrete state (rate)",
          "algebraic": "no state", "sink": "sink", "pruned": "pruned (not run)"}
GROUP_FILLS = ("#f4f4f4", "#eaeaea", "#e0e0e0")


@dataclass
class Box:
    """One component in the picture."""

    name: str
    type_name: str
    kind: str                    # a STYLE key
    info: list[str]              # extra text lines under the type
    index: int                   # definition order
    group: tuple[str, ...] = ()  # sub-assembly prefixes, outermost first
    layer: int = 0
    x: float = 0.0               # top-left corner, inches
    y: float = 0.0
    w: float = 0.0
    h: float = 0.0
    strip: int = 0             # which strip or panel of a wrapped picture
    col: int = 0               # column, panels included

    @property
    def short(self) -> str:
        return self.name.rsplit("/", 1)[-1]

    @property
    def center(self) -> tuple[float, float]:
        return self.x + self.w / 2, self.y + self.h / 2


@dataclass
class Link:
    """Every connection from one component to another, merged into one arrow."""

    src: str
    dst: str
    ports: list[tuple[str, str]] = field(default_factory=list)
    through: bool = False        # some target input feeds through to an output
    orders: bool = False         # used to order the columns

    @property
    def label(self) -> str:
        return "\n".join(f"{a} → {b}" for a, b in self.ports)


@dataclass
class GroupFrame:
    path: tuple[str, ...]
    strip: int
    x0: float
    y0: float
    x1: float
    y1: float


@dataclass
class Layout:
    """Everything :func:`draw` needs, in inches with y pointing down."""

    title: str
    boxes: dict[str, Box]
    links: list[Link]
    frames: list[GroupFrame]
    width: float
    height: float
    n_layers: int
    n_strips: int                # strips or panels the picture is wrapped into
    mode: str = "single"         # "single", "strips" (stacked rows) or "panels" (side by side)
    strip_bottoms: list[float] = field(default_factory=list)   # per strip: where the gap below begins


# -- the graph ---------------------------------------------------------------------

def _split(ref: str) -> tuple[str, str]:
    comp, port = ref.rsplit(".", 1)
    return comp, port


def _feedthrough_inputs(cls) -> set[str]:
    if cls is None:
        return set()
    names = list(cls.inputs)
    return {i for p in cls.outputs.values() for i in p.feedthrough_inputs(names)}


def collect(session) -> tuple[dict[str, Box], list[Link], str]:
    """Boxes and links of a session's assembly, pruned components included."""
    plan = session.plan
    resolved = getattr(session, "resolved", None)
    registry = getattr(session, "registry", None)
    report = plan.report.get("components", {})
    specs = resolved.components if resolved is not None else {}
    names = list(specs) if specs else list(plan.components) + [n for n in plan.pruned if n not in plan.components]
    pruned = set(plan.pruned)

    recorded, stopped = defaultdict(list), defaultdict(list)
    if resolved is not None:
        for ref, _ in resolved.record:
            c, p = _split(ref)
            recorded[c].append(p)
        for spec, _ in resolved.stop:
            c, p = _split(spec.signal)
            stopped[c].append(p)

    boxes, classes = {}, {}
    for i, name in enumerate(names):
        comp = plan.components.get(name)
        if comp is not None:
            cls, type_name, rate = type(comp), comp.type_name, comp.rate
        else:
            spec = specs.get(name)
            type_name = spec.type if spec is not None else "?"
            rate = spec.rate if spec is not None else None
            try:
                cls = registry.component(type_name) if registry is not None else None
            except Exception:
                cls = None
        classes[name] = cls
        rep = report.get(name, {})
        nx, nxd = rep.get("continuous_states", 0), rep.get("discrete_states", 0)
        sink = bool(cls is not None and cls.is_sink)
        if name in pruned:
            kind = "pruned"
        elif sink:
            kind = "sink"
        elif nxd or rate is not None:
            kind = "discrete"
        elif nx:
            kind = "continuous"
        else:
            kind = "algebraic"
        facts = []
        if nx:
            facts.append(f"x: {nx}")
        if nxd:
            facts.append(f"xd: {nxd}")
        if rate is not None:
            facts.append(f"{rate:g} Hz")
        if sink:
            facts.append("sink")
        if name in pruned:
            facts.append("pruned")
        info = ["  ·  ".join(facts)] if facts else []
        if recorded.get(name):
            info.append("rec: " + ", ".join(recorded[name]))
        if stopped.get(name):
            info.append("stop: " + ", ".join(stopped[name]))
        boxes[name] = Box(name, type_name, kind, info, i, tuple(name.split("/")[:-1]))

    if resolved is not None:
        conns = [(s, t) for s, t, _ in resolved.connections]
    else:
        conns = [(str(src), str(dst)) for dst, src in plan.sources.items()]
    links: dict[tuple[str, str], Link] = {}
    for s, t in conns:
        sc, sp = _split(s)
        tc, tp = _split(t)
        if sc not in boxes or tc not in boxes:
            continue
        link = links.setdefault((sc, tc), Link(sc, tc))
        link.ports.append((sp, tp))
        if tp in _feedthrough_inputs(classes[tc]):
            link.through = True

    source = getattr(resolved, "source", None) if resolved is not None else None
    title = Path(source).name if source else "assembly"
    st = plan.report.get("state_size", {})
    n_pruned = len(pruned)
    title += (f": {len(boxes)} components" + (f" ({n_pruned} pruned)" if n_pruned else "")
              + f", {len(conns)} connections, state {st.get('continuous', 0)} continuous"
              + (f" + {st['discrete']} discrete" if st.get("discrete") else "")
              + (f", dt = {plan.dt:g} s" if getattr(plan, "dt", None) else ""))
    return boxes, list(links.values()), title


# -- columns -----------------------------------------------------------------------

def assign_layers(boxes: dict[str, Box], links: list[Link]) -> int:
    """Longest-path layering; returns the number of layers.

    Links into feedthrough inputs order the columns first; cycles among
    those (possible when a component mixes state-only and feedthrough
    outputs) are broken by dropping depth-first back edges. Then each link
    into a state-only input (a force into a body, a sample into a hold)
    orders the columns too unless it would close a cycle: that is where a
    physical feedback loop is cut, so the picture reads left to right from
    states, through the blocks they feed, to the inputs they drive. Links
    are taken in definition order, so the picture is deterministic.
    """
    order = sorted(boxes, key=lambda n: boxes[n].index)
    succ = defaultdict(list)
    for lk in links:
        if lk.through and lk.src != lk.dst:
            succ[lk.src].append(lk)
    for n in succ:
        succ[n].sort(key=lambda lk: boxes[lk.dst].index)
    state = {}
    for root in order:
        if root in state:
            continue
        state[root] = 1
        stack = [(root, iter(succ[root]))]
        while stack:
            n, it = stack[-1]
            lk = next(it, None)
            if lk is None:
                state[n] = 2
                stack.pop()
                continue
            s = state.get(lk.dst)
            if s == 1:
                continue                      # back edge: leave it out of the ordering
            lk.orders = True
            if s is None:
                state[lk.dst] = 1
                stack.append((lk.dst, iter(succ[lk.dst])))

    after = defaultdict(set)
    for lk in links:
        if lk.orders:
            after[lk.src].add(lk.dst)

    def reaches(a, b) -> bool:
        seen, todo = {a}, [a]
        while todo:
            n = todo.pop()
            if n == b:
                return True
            for m in after[n] - seen:
                seen.add(m)
                todo.append(m)
        return False

    for lk in sorted((lk for lk in links if not lk.through and lk.src != lk.dst),
                     key=lambda lk: (boxes[lk.src].index, boxes[lk.dst].index)):
        if not reaches(lk.dst, lk.src):
            lk.orders = True
            after[lk.src].add(lk.dst)

    preds, outs = defaultdict(list), defaultdict(list)
    for lk in links:
        if lk.orders:
            preds[lk.dst].append(lk.src)
            outs[lk.src].append(lk.dst)
    indeg = {n: len(preds[n]) for n in order}
    ready = [n for n in order if indeg[n] == 0]
    topo = []
    while ready:
        n = ready.pop(0)
        topo.append(n)
        for m in outs[n]:
            indeg[m] -= 1
            if indeg[m] == 0:
                ready.append(m)
    for n in topo:
        boxes[n].layer = max((boxes[p].layer + 1 for p in preds[n]), default=0)
    # sources (constants, states read by others) move right, next to their first reader
    for n in reversed(topo):
        if not preds[n] and outs[n]:
            boxes[n].layer = max(0, min(boxes[m].layer for m in outs[n]) - 1)
    return 1 + max((b.layer for b in boxes.values()), default=0)


# -- rows: sub-assemblies packed as frames -------------------------------------------

def _measure(boxes: dict[str, Box]) -> None:
    from matplotlib.backends.backend_agg import RendererAgg
    from matplotlib.font_manager import FontProperties

    r = RendererAgg(10, 10, 72)

    def width(text, size, **kw):
        w, _, _ = r.get_text_width_height_descent(text, FontProperties(size=size, **kw), ismath=False)
        return w / 72.0

    for b in boxes.values():
        w = max([width(b.short, NAME_PT, weight="bold"), width(b.type_name, TEXT_PT, style="italic")]
                + [width(line, TEXT_PT) for line in b.info])
        b.w = max(MIN_BOX_W, w + 2 * BOX_PAD_X)
        b.h = 2 * BOX_PAD_Y + LINE_H * (1.15 + 1 + len(b.info))


def _label_width(text: str) -> float:
    return max((len(line) for line in text.splitlines()), default=0) * 0.052


class _Group:
    def __init__(self, path):
        self.path = path
        self.members: list[Box] = []
        self.children: dict[str, _Group] = {}


def _tree(boxes: dict[str, Box]) -> _Group:
    root = _Group(())
    for b in sorted(boxes.values(), key=lambda b: b.index):
        g = root
        for i, part in enumerate(b.group):
            g = g.children.setdefault(part, _Group(b.group[: i + 1]))
        g.members.append(b)
    return root


def _descendants(g: _Group):
    yield from g.members
    for c in g.children.values():
        yield from _descendants(c)


def _pack(g: _Group, slot_h: float, n_cols: int, split: _Group | None = None,
          max_h: float | None = None) -> tuple[int, int, float]:
    """Place g's boxes relative to g's content top; returns (first col, last col, height).

    Items are the rows of g's own components (each box in its layer's
    column) and the frames of its sub-assemblies; in definition order each
    is dropped onto a skyline over the columns, so frames never overlap and
    a chain of sub-assemblies packs tight. At the ``split`` group, a stack
    taller than ``max_h`` continues in a new panel to the right (its columns
    shifted by ``n_cols``).
    """
    items = []
    per_layer = defaultdict(list)
    for b in g.members:
        per_layer[b.layer].append(b)
    for k in range(max((len(v) for v in per_layer.values()), default=0)):
        row = [v[k] for v in per_layer.values() if len(v) > k]
        items.append((min(b.col for b in row), max(b.col for b in row), slot_h, row, 0.0, ROW_GAP))
    for child in g.children.values():
        c0, c1, h = _pack(child, slot_h, n_cols, split, max_h)
        items.append((c0, c1, h + GROUP_PAD_TOP + GROUP_PAD_BOTTOM, list(_descendants(child)), GROUP_PAD_TOP, ITEM_GAP))
    sky: dict[int, float] = {}
    bottom, shift = 0.0, 0
    for c0, c1, h, members, pad, gap in items:
        while True:
            top = max((sky.get(c + shift, 0.0) for c in range(c0, c1 + 1)), default=0.0)
            if g is not split or max_h is None or top == 0.0 or top + h <= max_h:
                break
            shift += n_cols                       # next panel
        for b in members:
            b.y += top + pad
            b.col += shift
        for c in range(c0 + shift, c1 + shift + 1):
            sky[c] = top + h + gap
        bottom = max(bottom, top + h)
    return (min(b.col for b in _descendants(g)), max(b.col for b in _descendants(g)), bottom)


def _frames(g: _Group, parts: int) -> list[GroupFrame]:
    """Frames around each sub-assembly, one per strip or panel it appears in, inner first."""
    out = []
    for c in g.children.values():
        out += _frames(c, parts)
    if not g.path:
        return out
    for s in range(parts):
        rects = [(b.x, b.y, b.x + b.w, b.y + b.h) for b in g.members if b.strip == s]
        rects += [(f.x0, f.y0, f.x1, f.y1) for f in out if f.strip == s and f.path[: len(g.path)] == g.path
                  and len(f.path) == len(g.path) + 1]
        if rects:
            out.append(GroupFrame(g.path, s, min(r[0] for r in rects) - GROUP_PAD_X,
                                  min(r[1] for r in rects) - GROUP_PAD_TOP,
                                  max(r[2] for r in rects) + GROUP_PAD_X,
                                  max(r[3] for r in rects) + GROUP_PAD_BOTTOM))
    return out


def _place_rows(boxes, root, slot_h, n_layers, split=None, max_h=None) -> float:
    for b in boxes.values():
        b.y, b.col = 0.0, b.layer
    if not boxes:
        return slot_h
    height = _pack(root, slot_h, n_layers, split, max_h)[2]
    for b in boxes.values():               # centre each box in its slot
        b.y += (slot_h - b.h) / 2
    return height


def layout(session) -> Layout:
    """Where every box, arrow and frame goes (inches, y down)."""
    boxes, links, title = collect(session)
    n_layers = assign_layers(boxes, links) if boxes else 1
    _measure(boxes)
    slot_h = max((b.h for b in boxes.values()), default=0.6)
    root = _tree(boxes)
    height = _place_rows(boxes, root, slot_h, n_layers)

    col_w = defaultdict(float)
    for b in boxes.values():
        col_w[b.layer] = max(col_w[b.layer], b.w)
    near = [lk for lk in links if boxes[lk.dst].layer == boxes[lk.src].layer + 1]
    gap = min(MAX_COL_GAP, max([MIN_COL_GAP] + [_label_width(lk.label) + 0.45 for lk in near]))
    width = sum(col_w.values()) + gap * (n_layers - 1)

    # a tall stack of sub-assemblies continues in panels side by side
    split = root            # the group whose stack is cut: descend while one sub-assembly holds most boxes
    while len(split.children) == 1:
        only = next(iter(split.children.values()))
        if 2 * sum(1 for _ in _descendants(only)) <= sum(1 for _ in _descendants(split)):
            break
        split = only
    n_panels = 1
    if height > 2 * width / TARGET_ASPECT:
        k = max(1, round(math.sqrt(TARGET_ASPECT * height / (width + PANEL_GAP))))
        if k > 1:
            full = height
            for stretch in (1.02, 1.1, 1.2, 1.35, 1.5):   # no lonely last panel: k panels at most
                height = _place_rows(boxes, root, slot_h, n_layers, split, full / k * stretch)
                n_panels = 1 + max(b.col for b in boxes.values()) // n_layers
                if n_panels <= k:
                    break

    # a wide graph wraps into strips of consecutive columns
    per = n_layers
    if n_panels == 1 and n_layers > 4 and width > 2 * TARGET_ASPECT * height:
        best = None
        for k in range(1, n_layers + 1):
            p = math.ceil(n_layers / k)
            w = max(sum(col_w[c] for c in range(s, min(s + p, n_layers))) for s in range(0, n_layers, p)) \
                + gap * (p - 1)
            h = k * height + (k - 1) * STRIP_GAP
            score = abs(math.log((w / h) / TARGET_ASPECT))
            if best is None or score < best[0]:
                best = (score, p)
        per = best[1]
    n_strips = math.ceil(n_layers / per)
    for b in boxes.values():
        b.strip = b.col // n_layers if n_panels > 1 else b.layer // per
    local_w = [max(col_w[c] for c in range(j, n_layers, per)) for j in range(per)]
    x_of = [sum(local_w[:j]) + gap * j for j in range(per)]
    panel_x = [0.0]
    for p in range(n_panels - 1):    # each panel as wide as the columns it uses
        used = max((b.col % n_layers for b in boxes.values() if b.col // n_layers == p), default=0)
        panel_x.append(panel_x[-1] + x_of[used] + local_w[used] + PANEL_GAP)
    for b in boxes.values():
        j = (b.col % n_layers) % per
        b.x = x_of[j] + (local_w[j] - b.w) / 2 + (panel_x[b.strip] if n_panels > 1 else 0.0)

    frames: list[GroupFrame] = []
    bottoms: list[float] = []
    parts = max(n_panels, n_strips)
    if n_panels > 1:
        frames = _frames(root, parts)
        height = max([b.y + b.h for b in boxes.values()] + [f.y1 for f in frames])
    else:                                  # stack strips, each keeping only the rows it uses
        offset = 0.0
        for s in range(n_strips):
            members = [b for b in boxes.values() if b.strip == s]
            if not members:
                bottoms.append(offset - STRIP_GAP)
                continue
            top = min([b.y for b in members] + [f.y0 for f in _frames(root, parts) if f.strip == s])
            for b in members:
                b.y += offset - top
            strip_frames = [f for f in _frames(root, parts) if f.strip == s]
            frames += strip_frames
            bottoms.append(max([b.y + b.h for b in members] + [f.y1 for f in strip_frames]))
            offset = bottoms[-1] + STRIP_GAP
        height = max(offset - STRIP_GAP, slot_h)
    min_x = min([0.0] + [f.x0 for f in frames])
    min_y = min([0.0] + [f.y0 for f in frames])
    for b in boxes.values():
        b.x -= min_x
        b.y -= min_y
    for f in frames:
        f.x0, f.x1, f.y0, f.y1 = f.x0 - min_x, f.x1 - min_x, f.y0 - min_y, f.y1 - min_y
    total_w = max([b.x + b.w for b in boxes.values()] + [f.x1 for f in frames] + [1.0])
    mode = "panels" if n_panels > 1 else "strips" if n_strips > 1 else "single"
    return Layout(title, boxes, links, frames, total_w, height - min_y, n_layers, parts, mode,
                  [y - min_y for y in bottoms])


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
        else:
            fixed.append((*on_arc(src, dst, rad), _oriented(lk, left.name), greyed))

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
