"""Stop conditions compiled against the plan's output buffers (``stop:`` in an assembly).

Each entry declares its ``outcome`` (``failure`` by default, or ``success``): a failure ends the run
with failure kind ``stop_rule`` (:mod:`.outcomes`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import BuildError
from .wiring import PortRef


@dataclass(frozen=True)
class StopCondition:
    label: str
    view: np.ndarray          # the flat output buffer it tests (a view, never reallocated)
    index: np.ndarray | slice
    op: str                   # above | below | abs_above
    value: float
    reason: str
    outcome: str = "failure"  # success | failure (the entry's ``outcome:``; failure kind "stop_rule")

    def __post_init__(self):
        # ``hit()``: True when the condition holds; made once for this buffer, index and bound
        object.__setattr__(self, "hit", _test(self.view, self.index, self.op, self.value))


def _test(view: np.ndarray, index, op: str, value: float):
    if isinstance(index, np.ndarray) and index.size == 1:   # the usual "com z above": one element, no temporaries
        item, i = view.item, int(index[0])
        if op == "above":
            return lambda: item(i) > value
        if op == "below":
            return lambda: item(i) < value
        return lambda: abs(item(i)) > value
    if op == "above":
        return lambda: bool(np.any(view[index] > value))
    if op == "below":
        return lambda: bool(np.any(view[index] < value))
    return lambda: bool(np.any(np.abs(view[index]) > value))


def compile_stop(spec, ref: PortRef, buf, where) -> list[StopCondition]:
    """The conditions of one ``stop:`` entry (one per bound given) on the output buffer ``buf``."""
    if not isinstance(buf, np.ndarray):
        raise BuildError(f"stop condition on {ref} ({where}): only numeric ports can be tested")
    flat = buf.reshape(-1)
    if spec.index is None:
        index = slice(None)
    else:
        index = np.atleast_1d(np.asarray(spec.index, dtype=int))
        if np.any(index >= flat.size) or np.any(index < -flat.size):
            raise BuildError(f"stop condition on {ref} ({where}): index {spec.index} out of range "
                             f"for {flat.size} elements")
    out = []
    for op in ("above", "below", "abs_above"):
        v = getattr(spec, op)
        if v is not None:
            label = f"{ref}{'' if spec.index is None else spec.index} {op.replace('_', ' ')} {v:g}"
            out.append(StopCondition(label, flat, index, op, float(v), spec.reason or label, spec.outcome))
    return out
