"""Stop conditions compiled against the plan's output buffers (``stop:`` in an assembly)."""

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

    def hit(self) -> bool:
        idx = self.index
        if isinstance(idx, np.ndarray) and idx.size == 1:   # the usual "com z above": no temporaries
            x = self.view[idx[0]]
            return bool(x > self.value if self.op == "above" else x < self.value if self.op == "below"
                        else abs(x) > self.value)
        v = self.view[idx]
        if self.op == "above":
            return bool(np.any(v > self.value))
        if self.op == "below":
            return bool(np.any(v < self.value))
        return bool(np.any(np.abs(v) > self.value))


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
            out.append(StopCondition(label, flat, index, op, float(v), spec.reason or label))
    return out
