"""Signal log filled in fixed-size chunks, streamed to its CSV form as they fill.

Columns: ``t``, then one per element of each recorded port, named
``component.port`` (scalar), ``component.port[i]`` / ``[i][j]`` (arrays; no comma, so the CSV header splits as the rows do) or
``component.port.name`` when the port declares element names. Values are
written with 17 significant digits, which round-trips float64 exactly, so the
same run gives a bit-identical file (chunked or not: ``savetxt`` formats row by row).

Nothing is preallocated for the whole run: rows go into chunks of :data:`CHUNK_ROWS`
rows, a new one allocated only when the last is full. With a CSV stream open
(:meth:`Recorder.stream_to`, a run with an output folder) rows are appended to
``signals.csv`` (header first) and flushed when a chunk is full and, in between, at least every
:data:`FLUSH_SECONDS` of wall time (all rows but the newest, which an open input set from Python may
still take again: :meth:`Recorder.rerecord`), so a run killed midway keeps its rows up to about a
second before the kill; each flush formats its rows whole, then writes once (no torn row). Chunks
stay in memory too: after a
run, ``log.rows``, ``log['port']``, ``RunResult[...]`` and campaign metrics read the
whole recording. The memory limit (:func:`.limits.memory_limit_bytes`) is therefore a
run-time stop, not an up-front refusal: when one more chunk would pass it, ``record()``
keeps the row, says so and :attr:`Recorder.limit_reached` is set; the simulator ends the
run there (not a blow-up: the signals so far are kept and written).

Every recorded row is checked for non-finite values as it is written (one dot product;
the exact test only when that is not finite): ``record()`` returns what was not finite
(component, port, element, value) and drops the row, so the log never holds inf, nor nan
except in ports that declare NaN a value (``Output(may_be_nan=True)``: "not defined yet").
"""

from __future__ import annotations

from pathlib import Path

import io
import math
import time

import numpy as np

from .errors import ConfigError, SnakesimError
from .limits import fmt_bytes, memory_limit_bytes
from .wiring import PortRef


def column_names(ref: PortRef, shape: tuple, names) -> list[str]:
    base = f"{ref.comp}.{ref.port}"
    if shape == ():
        return [base]
    if names is not None and len(names) == int(np.prod(shape)):
        return [f"{base}.{n}" for n in names]
    # [i][j], not [i,j]: a comma in a name would split the CSV header's column
    return [f"{base}{''.join(f'[{i}]' for i in idx)}" for idx in np.ndindex(*shape)]


#: rows per chunk (8192 rows of 10 columns: 640 kB) ...
CHUNK_ROWS = 8192
#: ... and at most this many bytes per chunk (wide recordings get fewer rows a chunk)
CHUNK_BYTES = 16e6
#: s of wall time between flushes of a streamed recording's rows (a killed run loses about this much)
FLUSH_SECONDS = 1.0


class Recorder:
    def __init__(self, refs: list[PortRef], plan, n_rows: int | None = None, duration: float | None = None,
                 chunk_rows: int | None = None):
        """``n_rows`` (the most rows the run can record) caps the chunk, so a short run allocates no more
        than it records; ``duration`` only phrases the memory-limit hint; ``chunk_rows`` defaults to
        :data:`CHUNK_ROWS`."""
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
        self.nan_ok = np.array(nan_ok, dtype=bool)     # columns where NaN means "not defined yet"
        self.duration = duration
        self.max_rows = None if n_rows is None else max(1, int(n_rows))
        self.limit = memory_limit_bytes()
        chunk_rows = CHUNK_ROWS if chunk_rows is None else chunk_rows
        rows = min(int(chunk_rows), int(CHUNK_BYTES // (8 * col)), int(self.limit // (8 * col)),
                   self.max_rows or chunk_rows)
        if rows < 1:
            raise ConfigError(f"recording {col - 1} signal columns needs {fmt_bytes(8.0 * col)} a row; the memory "
                              f"limit is {fmt_bytes(self.limit)} (half the physical memory, or "
                              f"SNAKESIM_MEMORY_LIMIT): record fewer ports", None, "record")
        self.chunk_rows = rows
        self.limit_reached: str | None = None     # the stop message once the next chunk would pass the limit
        self.chunks: list[np.ndarray] = []         # full chunks
        self._chunk = np.empty((rows, col))        # the chunk being filled
        self._i = 0                                # rows in it
        self._rows, self._rows_n = None, -1        # cached concatenation, and the row count it holds
        self._fh = None                            # the CSV stream, while open
        self._path: Path | None = None
        self._written = 0                          # full chunks already in the stream
        self._streamed_i = 0                       # rows of the chunk being filled already in the stream
        self._next_flush = math.inf                # wall-clock time (monotonic) of the next timed flush

    def record(self, t: float) -> str | None:
        """Append the recorded ports' values at ``t``; None, or (a non-finite value) what it was, the row
        not kept, or (the memory limit reached: :attr:`limit_reached`) the stop message, the row kept."""
        row = self._chunk[self._i]
        row[0] = t
        for sl, v in zip(self.slices, self.views):
            row[sl] = v
        if not math.isfinite(row.dot(row)) and (~np.isfinite(row) & ~(self.nan_ok & np.isnan(row))).any():
            return self._non_finite(row)
        self._i += 1
        if self._i == self.chunk_rows:
            return self._next_chunk(t)
        if time.monotonic() >= self._next_flush:
            self._flush_recent()
        return None

    def rerecord(self, t: float) -> None:
        """Take the last row again (its time ``t``): the ports were evaluated anew at that time (an open
        input set before the run moved on). Non-finite values are left to the next row's check."""
        if self._i:
            row = self._chunk[self._i - 1]
        elif self.chunks:
            row = self.chunks[-1][-1]
        else:
            return
        if row[0] != t:
            return
        for sl, v in zip(self.slices, self.views):
            row[sl] = v
        self._rows_n = -1

    def _next_chunk(self, t: float) -> str | None:
        """The current chunk is full: keep it (streamed when a stream is open) and start the next, unless one
        more would pass the memory limit (then the message, and no new chunk)."""
        self.chunks.append(self._chunk)
        self._i = 0
        self._flush()
        cols = len(self.columns)
        if self.max_rows is not None and self.n >= self.max_rows:      # the run records no more
            self._chunk, self._i = self._chunk[:0], 0
            return None
        need = 8.0 * (len(self.chunks) + 1) * self.chunk_rows * cols
        if need > self.limit:
            fit = self.limit / (8.0 * cols)
            d = self.duration
            rate = float(f"{0.95 * fit / d:.2g}") if d else 0.0     # rounded down: it fits
            hint = (f"set sim.record_rate to at most {rate:g} Hz, " if rate else "lower sim.record_rate, ") + \
                "record fewer ports or shorten the duration"
            kept = f"; the rows so far are in {self._path}" if self._fh is not None else \
                " (no --out: give --out DIR to keep them on disk)"
            self.limit_reached = (
                f"recording reached the memory limit at t = {t:.6g} s: {self.n} rows of {cols - 1} signal columns "
                f"take {fmt_bytes(8.0 * self.n * cols)}, the limit is {fmt_bytes(self.limit)} (half the physical "
                f"memory, or SNAKESIM_MEMORY_LIMIT){kept}; {hint}")
            self._chunk, self._i = self._chunk[:0], 0    # no room: a further record() would fail loudly
            return self.limit_reached
        self._chunk = np.empty((self.chunk_rows, cols))
        self._i = 0
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
    def n(self) -> int:
        """Rows recorded."""
        return len(self.chunks) * self.chunk_rows + self._i

    @property
    def rows(self) -> np.ndarray:
        """Every recorded row, (n, columns): the chunks concatenated once, cached until the next record."""
        n = self.n
        if self._rows_n != n:
            parts = self.chunks + ([self._chunk[: self._i]] if self._i else [])
            if not parts:
                self._rows = np.empty((0, len(self.columns)))
            elif len(parts) == 1:
                self._rows = parts[0]          # a view: rows already recorded never change
            else:      # one array, and the chunks become views of it: the memory is held once, not twice
                self._rows = np.concatenate(parts)
                cr = self.chunk_rows
                self.chunks = [self._rows[k * cr:(k + 1) * cr] for k in range(len(self.chunks))]
            self._rows_n = n
        return self._rows

    def __getitem__(self, key: str) -> np.ndarray:
        """One column by name, or every column of a port: ``log['pend.theta']``."""
        if key in self.columns:
            return self.rows[:, self.columns.index(key)]
        for ref, sl in zip(self.refs, self.slices):
            if f"{ref.comp}.{ref.port}" == key:
                return self.rows[:, sl]
        raise KeyError(f"'{key}' was not recorded; recorded: {', '.join(f'{r.comp}.{r.port}' for r in self.refs)}")

    # -- the CSV form ----------------------------------------------------------------------------------
    def stream_to(self, path: Path) -> None:
        """Open ``path`` (replacing it), write the header and every full chunk so far; later full chunks are
        appended as they fill. :meth:`write_csv` to the same path finishes it (the partial chunk, close)."""
        self.close()
        self._path = Path(path)
        self._fh = open(self._path, "w", newline="")
        self._fh.write(",".join(self.columns) + "\n")
        self._written, self._streamed_i = 0, 0
        self._flush()
        self._flush_recent()

    def _write_rows(self, rows: np.ndarray) -> None:
        """Append ``rows`` to the stream: formatted whole, then one write and a flush, so a process killed
        while formatting leaves no torn row (savetxt straight into the file wrote row by row)."""
        if not len(rows):
            return
        text = io.StringIO()
        np.savetxt(text, rows, fmt="%.17g", delimiter=",")
        try:
            self._fh.write(text.getvalue())
            self._fh.flush()      # in the OS's hands: a killed process keeps it
        except OSError as e:      # e.g. a full disk mid-run
            raise SnakesimError(f"could not write the run's signals to {self._path}: {e.strerror or e}") from None

    def _flush(self) -> None:
        """The full chunks not yet in the stream (the rest of a chunk partly streamed by a timed flush)."""
        if self._fh is None:
            return
        while self._written < len(self.chunks):
            self._write_rows(self.chunks[self._written][self._streamed_i:])
            self._written += 1
            self._streamed_i = 0

    def _flush_recent(self) -> None:
        """The timed flush: the chunk being filled up to, not including, its newest row."""
        if self._fh is None:
            return
        upto = self._i - 1
        if upto > self._streamed_i:
            self._write_rows(self._chunk[self._streamed_i:upto])
            self._streamed_i = upto
        self._next_flush = time.monotonic() + FLUSH_SECONDS

    def close(self) -> None:
        """Close the stream (its file holds the header and the rows flushed so far)."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None
            self._next_flush = math.inf

    def write_csv(self, path: Path) -> None:
        """The whole recording as CSV; to the streamed file, only what it lacks (the last, partial chunk)."""
        if self._fh is not None and self._path is not None and Path(path).resolve() == self._path.resolve():
            self._flush()
            self._write_rows(self._chunk[self._streamed_i: self._i])
            self.close()
            return
        with open(path, "w", newline="") as fh:
            fh.write(",".join(self.columns) + "\n")
            for part in self.chunks + ([self._chunk[: self._i]] if self._i else []):
                np.savetxt(fh, part, fmt="%.17g", delimiter=",")


#: bytes a value takes in signals.csv (17 significant digits, sign, exponent, separator)
CSV_BYTES_PER_VALUE = 24


def recording_estimate(plan, duration: float) -> dict:
    """What a run of ``duration`` s will record, known before anything is allocated: ``steps`` (base steps),
    ``rows`` (one each ``record_every`` steps, at ``record_rate`` Hz), ``columns`` (signal columns, t not
    counted), ``bytes`` in memory (float64), ``csv_bytes`` (signals.csv, about), the memory ``limit``, and
    ``fit_rate``: the highest record rate (Hz) whose recording fits the limit. Refuses (ConfigError)
    only what cannot run at all: more than :data:`.limits.MAX_STEPS` steps."""
    from .limits import step_count

    steps = step_count(duration, plan.dt)
    rows = steps // plan.record_every + 1
    cols = 1 + sum(int(np.size(plan.out_buffers[ref])) if isinstance(plan.out_buffers[ref], np.ndarray) else 1
                   for ref in plan.record_refs)
    limit = memory_limit_bytes()
    return {"steps": steps, "rows": rows, "columns": cols - 1, "record_rate": 1.0 / (plan.dt * plan.record_every),
            "bytes": 8.0 * rows * cols, "csv_bytes": float(CSV_BYTES_PER_VALUE) * rows * cols, "limit": limit,
            "fit_rate": float(f"{0.95 * limit / (8.0 * cols) / duration:.2g}")}


def recording_warning(est: dict, duration: float) -> str | None:
    """The warning for a recording (``recording_estimate``) that cannot fit the memory limit: the run would
    stop with failure ``memory_limit`` (the rows so far kept) at about the time it names; None when it fits."""
    if est["bytes"] <= est["limit"]:
        return None
    t_stop = duration * est["limit"] / est["bytes"]
    return (f"the recording would take ~{fmt_bytes(est['bytes'])} ({est['rows']:.4g} rows at sim.record_rate = "
            f"{est['record_rate']:.4g} Hz x {est['columns']} signal columns), over the memory limit "
            f"{fmt_bytes(est['limit'])} (half the physical memory, or SNAKESIM_MEMORY_LIMIT): the run would stop "
            f"there (failure memory_limit) at about t = {t_stop:.3g} s of {duration:g} s; set sim.record_rate to "
            f"at most {est['fit_rate']:g} Hz, record fewer ports or shorten the duration")
