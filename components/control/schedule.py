"""A piecewise-constant schedule: values switched at given times (gravity toggle, attach/release).

    y(t) = initial            for t < times[0]
    y(t) = values[i]          for times[i] <= t < times[i+1]

A scalar per switch gives y[1] (e.g. the multibody's ``gravity`` input in
"scale" mode: 1 on, 0 off); a list per switch gives y[n].

out  y[n]  (no inputs, no state)
"""

from __future__ import annotations

import numpy as np
from pydantic import Field, model_validator

from snakesim.framework import Component, Output, Params


def check_switch_times(times, entries, what: str) -> None:
    """A schedule's switch times: one per entry of ``what``, finite, strictly increasing."""
    if len(times) != len(entries):
        raise ValueError(f"times has {len(times)} entries but {what} has {len(entries)}")
    t = np.asarray(times, dtype=float)
    if not np.all(np.isfinite(t)):
        raise ValueError(f"times must be finite, got {times}")
    if t.size > 1 and not np.all(np.diff(t) > 0):
        i = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise ValueError(f"times must increase strictly: times[{i}] = {t[i]:g} >= times[{i + 1}] = {t[i + 1]:g}")


class ScheduleParams(Params):
    times: list[float] = Field(default_factory=list, description="switch times, s, strictly increasing")
    values: list[float | list[float]] = Field(default_factory=list, description="value from each switch time on")
    initial: float | list[float] = Field(1.0, description="value before the first switch")

    @model_validator(mode="after")
    def _check(self):
        check_switch_times(self.times, self.values, "values")
        sizes = {np.size(v) for v in [*self.values, self.initial]}
        if len(sizes - {1}) > 1:
            raise ValueError(f"values and initial must all have one length (or be scalars), got lengths {sorted(sizes)}")
        return self

    @property
    def n(self) -> int:
        return max(np.size(v) for v in [*self.values, self.initial])


class Schedule(Component[ScheduleParams]):
    type_name = "schedule"
    y = Output(shape=lambda c: (c.p.n,), unit=None, feedthrough=())

    def setup(self):
        n = self.p.n
        self._t = np.asarray(self.p.times, dtype=float)
        self._v = np.array([np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in
                            [self.p.initial, *self.p.values]])

    def output(self, t, x, u, y):
        y.y[:] = self._v[np.searchsorted(self._t, t, side="right")]
