"""Numbers for the dataflow picture: boxes, columns, sub-assembly frames, panels and strips.

Kept apart from :mod:`.drawing` (pixels) so the layout is tested as numbers.
"""

from __future__ import annotations

import math
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

    # build-time resources: who provides what, and which provider each user was handed
    providers = {id(getattr(c, slot)): (n, slot) for n, c in plan.components.items() for slot in type(c).provides}

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
        if comp is not None:
            for slot in type(comp).provides:
                info.append(f"provides {slot}")
            for slot in type(comp).uses:
                prov = providers.get(id(getattr(comp, slot, None)))
                if prov is not None:
                    info.append(f"uses {slot}" + ("" if prov[0] == slot else f" ← {prov[0]}"))
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
