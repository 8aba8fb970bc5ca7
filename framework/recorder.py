"""In-memory signal log with preallocated rows, and its CSV form.

Columns: ``t``, then one per element of each recorded port, named
``component.port`` (scalar), ``component.port[i]`` / ``[i,j]`` (arrays) or
``component.port.name`` when the port declares element names. Values are
written with 17 significant digits, which round-trips float64 exactly, so the
same run gives a bit-identical file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .wiring import PortRef


def column_names(ref: PortRef, shape: tuple, names) -> list[str]:
    base = f"{ref.comp}.{ref.port}"
    if shape == ():
        return [base]
    if names is not None and len(names) == int(np.prod(shape)):
        return [f"{base}.{n}" for n in names]
    return [f"{base}[{','.join(map(str, idx))}]" for idx in np.ndindex(*shape)]


class Recorder:
    def __init__(self, refs: list[PortRef], plan, n_rows: int):
        self.refs = refs
        self.columns = ["t"]
        self.views, self.slices = [], []
        col = 1
        for ref in refs:
            buf = plan.out_buffers[ref]
            comp = plan.components[ref.comp]
            names = comp.outputs[ref.port].signal.element_names(comp)
            self.columns += column_names(ref, buf.shape, names)
            self.views.append(buf.reshape(-1))      # a view: the buffer is never reallocated
            self.slices.append(slice(col, col + buf.size))
            col += buf.size
        self.data = np.zeros((max(n_rows, 1), col))
        self.n = 0

    def record(self, t: float) -> None:
        row = self.data[self.n]
        row[0] = t
        for sl, v in zip(self.slices, self.views):
            row[sl] = v
        self.n += 1

    @property
    def rows(self) -> np.ndarray:
        return self.data[: self.n]

    def __getitem__(self, key: str) -> np.ndarray:
        """One column by name, or every column of a port: ``log['pend.theta']``."""
        if key in self.columns:
            return self.rows[:, self.columns.index(key)]
        for ref, sl in zip(self.refs, self.slices):
            if f"{ref.comp}.{ref.port}" == key:
                return self.rows[:, sl]
        raise KeyError(f"'{key}' was not recorded; recorded: {', '.join(f'{r.comp}.{r.port}' for r in self.refs)}")

    def write_csv(self, path: Path) -> None:
        with open(path, "w", newline="") as fh:
            fh.write(",".join(self.columns) + "\n")
            np.savetxt(fh, self.rows, fmt="%.17g", delimiter=",")
