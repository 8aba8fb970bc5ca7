"""What the sampled monitors share: the rate they need, and the running worst a watch keeps.

``joint_limits`` (rad past a URDF limit, per joint) and ``terrain_clearance`` (m inside the terrain,
per link) are the same watch over different elements: sampled at their ``rate``, each keeps the
worst value of every element so far, shows the overall worst as its one output (its discrete state
x[0], so it holds between samples) and remembers the first sample where it passed ``tolerance``.
The evaluations (``traverse_evaluation``, ``vertical_mobility_evaluation``) need the rate too.
"""

from __future__ import annotations

import numpy as np

from snakesim.framework import Output


def require_rate(component) -> None:
    """A sampled monitor without a ``rate`` is an error naming it: its metrics advance per sample."""
    if component.rate is None:
        raise ValueError(f"{component.name}: {component.type_name} samples at a rate: give it `rate: HZ`")


class RunningWorst:
    """Per-run scratch (``u.cache``) of a watch over ``n`` elements: ``worst``, each element's worst value
    so far (>= 0, in the watch's unit), and ``first``, the first breach (t s, element name, value)."""

    def __init__(self, n: int):
        self.worst = np.zeros(n)
        self.first: tuple[float, str, float] | None = None

    def end_sample(self, t: float, xd: np.ndarray, tolerance: float, names, values) -> int | None:
        """Close the sample at ``t`` s that updated ``worst``: the overall worst into the watch's state
        xd[0]. When that is the first to pass ``tolerance``: the worst element's index, recorded as
        ``first`` = (t, its name in ``names``, its entry in ``values``: the value the report shows);
        None before that and after."""
        xd[0] = float(self.worst.max(initial=0.0))     # worst >= 0: the same as max() over >= 1 element
        if self.first is None and xd[0] > tolerance:
            i = int(np.argmax(self.worst))
            self.first = (t, names[i], float(values[i]))
            return i
        return None

    def over(self, tolerance: float) -> list[int]:
        """The elements whose worst passed ``tolerance``, worst first (the report's order)."""
        return [i for i in np.argsort(-self.worst) if self.worst[i] > tolerance]

    def first_report(self, element: str, value: str) -> dict:
        """The report's ``first`` entry, keyed ``time_s``, ``element`` and ``value``; {} without a breach."""
        if self.first is None:
            return {}
        return {"first": {"time_s": self.first[0], element: self.first[1], value: self.first[2]}}


def contact_hold_outputs() -> tuple[Output, Output, Output, Output]:
    """(contact_made, t_contact s, hold_time s, max_hold_time s): the field test's contact and static-hold
    metrics, as the mobility monitor and the vertical-mobility evaluation both output them (t_contact NaN
    before contact). Unpack in the class body, in this order."""
    return (Output(shape=(), unit="1"), Output(shape=(), unit="s", may_be_nan=True),
            Output(shape=(), unit="s"), Output(shape=(), unit="s"))


class WorstSoFarOutput:
    """Mixin for a watch whose one output, named by ``WORST_OUTPUT``, is its discrete state x[0]: the
    overall worst up to the last sample. It declares no ports, so the component's port order is its own."""

    WORST_OUTPUT: str = ""

    def discrete_state(self):
        return np.zeros(1)

    def output(self, t, x, u, y):
        getattr(y, self.WORST_OUTPUT)[...] = x[0]
