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

from .drawing import draw
from .layout import layout

__all__ = ["draw", "layout"]
