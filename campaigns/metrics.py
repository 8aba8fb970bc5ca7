"""A run's metrics: reductions of its recorded signals.

Declared in the dispersion file::

    metrics:
      theta_final: {signal: pend.theta, reduce: final}
      omega_peak:  {signal: pend.omega, reduce: max_abs}
      travel:      {signal: tail_pose.pose, reduce: distance}    # xy path length of a port with x, y

``signal`` is a recorded column (``tail_pose.pose.x``) or a recorded port
(every column of it; the metric's columns are then ``NAME.<element>``).
Without a ``metrics`` section every recorded port of at most
``DEFAULT_MAX_ELEMENTS`` elements gives ``final``, ``min``, ``max`` and ``mean``
of each column, and every port with x and y elements (a planar or 3-D pose)
also its ``distance`` (xy path length, m) and ``displacement`` (net xy, m):
final pose and distance travelled. Larger ports (joint vectors, contact
forces) are left out by default: declare the reductions you need.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from snakesim.framework.errors import ConfigError

REDUCTIONS = ("final", "initial", "min", "max", "mean", "max_abs", "rms", "change", "distance", "displacement")
DEFAULT_REDUCTIONS = ("final", "min", "max", "mean")
DEFAULT_MAX_ELEMENTS = 6


@dataclass(frozen=True)
class Metric:
    """``name`` = ``reduce`` of the recorded ``signal`` (column or port)."""

    name: str
    signal: str
    reduce: str


def parse_metrics(raw, file: str) -> tuple[Metric, ...] | None:
    """Check the file's ``metrics`` section; ``None`` means the defaults."""
    if raw is None:
        return None
    if not isinstance(raw, dict) or not raw:
        raise ConfigError("'metrics' must be a mapping of name -> {signal, reduce}", file, "metrics")
    out = []
    for name, spec in raw.items():
        where = spec.where() if hasattr(spec, "where") else file
        if not isinstance(spec, dict) or set(spec) - {"signal", "reduce"} or "signal" not in spec:
            raise ConfigError(f"a metric is {{signal: COMPONENT.PORT, reduce: R}}, got {spec!r}", where,
                              f"metrics.{name}")
        reduce = spec.get("reduce", "final")
        if reduce not in REDUCTIONS:
            raise ConfigError(f"unknown reduction {reduce!r}; valid: {', '.join(REDUCTIONS)}",
                              spec.where("reduce") if hasattr(spec, "where") else file, f"metrics.{name}.reduce")
        out.append(Metric(str(name), str(spec["signal"]), reduce))
    return tuple(out)


def _xy(columns: list[str]) -> tuple[int, int] | None:
    names = [c.rsplit(".", 1)[-1] for c in columns]
    return (names.index("x"), names.index("y")) if "x" in names and "y" in names else None


def _reduce(values: np.ndarray, how: str) -> float:
    if values.size == 0:
        return float("nan")
    return float({"final": lambda v: v[-1], "initial": lambda v: v[0], "min": np.min, "max": np.max,
                  "mean": np.mean, "max_abs": lambda v: np.max(np.abs(v)), "rms": lambda v: np.sqrt(np.mean(v * v)),
                  "change": lambda v: v[-1] - v[0]}[how](values))


def _planar(rows: np.ndarray, how: str) -> float:
    """Distance travelled (path length) or net displacement in xy, from an (n, 2) array of positions."""
    if len(rows) < 2:
        return 0.0
    if how == "distance":
        return float(np.sum(np.hypot(*np.diff(rows, axis=0).T)))
    return float(np.hypot(*(rows[-1] - rows[0])))


def port_columns(log) -> dict[str, list[str]]:
    """Recorded port name -> its column names, in recording order."""
    out = {}
    for ref, sl in zip(log.refs, log.slices):
        out[f"{ref.comp}.{ref.port}"] = log.columns[sl]
    return out


def check_metrics(metrics, log) -> None:
    """Raise a ConfigError naming the recorded signals if a metric's signal was not recorded."""
    ports = port_columns(log)
    for m in metrics or ():
        if m.signal in log.columns[1:] or m.signal in ports:
            if m.reduce in ("distance", "displacement") and (m.signal not in ports or _xy(ports[m.signal]) is None):
                raise ConfigError(f"{m.reduce} needs a recorded port with x and y elements; '{m.signal}' has none",
                                  "metrics", f"metrics.{m.name}.signal")
            continue
        raise ConfigError(f"'{m.signal}' was not recorded; recorded ports: {', '.join(ports) or 'none'}",
                          "metrics", f"metrics.{m.name}.signal")


def default_metrics(log) -> tuple[Metric, ...]:
    out = []
    for port, cols in port_columns(log).items():
        if len(cols) > DEFAULT_MAX_ELEMENTS:
            continue
        for col in cols:
            out += [Metric(f"{col}.{r}", col, r) for r in DEFAULT_REDUCTIONS]
        if _xy(cols) is not None:
            out += [Metric(f"{port}.{r}", port, r) for r in ("distance", "displacement")]
    return tuple(out)


def evaluate(metrics, log) -> dict[str, float]:
    """The metrics' values for one run's recorder (columns of a port metric: ``NAME.<element>``)."""
    metrics = default_metrics(log) if metrics is None else metrics
    ports = port_columns(log)
    rows = log.rows
    out: dict[str, float] = {}
    for m in metrics:
        if m.reduce in ("distance", "displacement"):
            cols = ports[m.signal]
            ix, iy = _xy(cols)
            sl = [log.columns.index(cols[ix]), log.columns.index(cols[iy])]
            out[m.name] = _planar(rows[:, sl], m.reduce)
        elif m.signal in log.columns[1:]:
            out[m.name] = _reduce(rows[:, log.columns.index(m.signal)], m.reduce)
        else:
            for col in ports[m.signal]:
                suffix = col[len(m.signal):].lstrip(".")
                out[f"{m.name}.{suffix}" if len(ports[m.signal]) > 1 else m.name] = \
                    _reduce(rows[:, log.columns.index(col)], m.reduce)
    return out
