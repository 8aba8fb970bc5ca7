"""In-memory signal log with preallocated rows, and its CSV form.

Columns: ``t``, then one per element of each recorded port, named
``component.port`` (scalar), ``component.port[i]`` / ``[i,j]`` (arrays) or
``component.port.name`` when the port declares element names. Values are
written with 17 significant digits, which round-trips float64 exactly, so the
same run gives a bit-identical file.

Rows are preallocated, after checking what they take against
:func:`.limits.memory_limit_bytes` (a run that needs more is refused, naming the
record rate that would fit). Every recorded row is checked for non-finite
values as it is written (one dot product; the exact test only when that is not
finite): ``record()`` returns what was not finite (component, port, element,
value) and drops the row, so the log never holds inf, nor nan except in ports
that declare NaN a value (``Output(may_be_nan=True)``: "not defined yet").
"""

from __future__ import annotations

from pathlib import Path

import math

import numpy as np

from .errors import ConfigError
from .limits import fmt_bytes, memory_limit_bytes
from .wiring import PortRef


def column_names(ref: PortRef, shape: tuple, names) -> list[str]:
    base = f"{ref.comp}.{ref.port}"
    if shape == ():
        return [base]
    if names is not None and len(names) == int(np.prod(shape)):
        return [f"{base}.{n}" for n in names]
    return [f"{base}[{','.join(map(str, idx))}]" for idx in np.ndindex(*shape)]


class Recorder:
    def __init__(self, refs: list[PortRef], plan, n_rows: int, duration: float | None = None):
        self.refs = refs
        self.columns = ["t"]
        self.views, self.slices = [], []
        col = 1
        nan_ok = [False]
        for ref in refs:
            buf = plan.out_buffers[ref]
            comp = plan.components[ref.comp]
            port = comp.outputs[ref.port]
            nan_ok += [getattr(port, "may_be_nan", False)] * buf.size
            names = port.signal.element_names(comp)
            self.columns += column_names(ref, buf.shape, names)
            self.views.append(buf.reshape(-1))      # a view: the buffer is never reallocated
            self.slices.append(slice(col, col + buf.size))
            col += buf.size
        need, limit = 8.0 * max(n_rows, 1) * col, memory_limit_bytes()
        if need > limit:
            fit = limit / (8.0 * col)
            rate = float(f"{0.95 * fit / duration:.2g}") if duration else 0.0     # rounded down: it fits
            hint = (f"set sim.record_rate to at most {rate:g} Hz, " if rate else "") + \
                "record fewer ports or shorten the duration"
            raise ConfigError(f"recording {col - 1} signal columns for {n_rows:.4g} rows needs {fmt_bytes(need)} "
                              f"of memory; the limit is {fmt_bytes(limit)} (half the physical memory, or "
                              f"SNAKESIM_MEMORY_LIMIT): {hint}", None, "sim.record_rate")
        self.nan_ok = np.array(nan_ok, dtype=bool)     # columns where NaN means "not defined yet"
        self.data = np.zeros((max(n_rows, 1), col))
        self.n = 0

    def record(self, t: float) -> str | None:
        """Append the recorded ports' values at ``t``; None, or (a non-finite value) what it was, the row
        not kept."""
        row = self.data[self.n]
        row[0] = t
        for sl, v in zip(self.slices, self.views):
            row[sl] = v
        if not math.isfinite(row.dot(row)) and (~np.isfinite(row) & ~(self.nan_ok & np.isnan(row))).any():
            return self._non_finite(row)
        self.n += 1
        return None

    def _non_finite(self, row: np.ndarray) -> str:
        bad = np.flatnonzero(~np.isfinite(row) & ~(self.nan_ok & np.isnan(row)))
        cols = [self.columns[i] for i in bad[:3]]
        more = f" and {bad.size - 3} more" if bad.size > 3 else ""
        ports = sorted({f"{r.comp}.{r.port}" for r, sl in zip(self.refs, self.slices)
                        if np.any((bad >= sl.start) & (bad < sl.stop))})
        comps = sorted({p.split(".")[0] for p in ports})
        return (f"non-finite recorded output of component {', '.join(repr(c) for c in comps)}: "
                f"{', '.join(f'{c} = {row[i]:g}' for c, i in zip(cols, bad))}{more} (ports {', '.join(ports)})")

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
