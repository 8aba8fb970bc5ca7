"""A run's metrics: reductions of its recorded signals, or numbers its components reported.

Declared in the dispersion file::

    metrics:
      theta_final: {signal: pend.theta, reduce: final}
      omega_peak:  {signal: pend.omega, reduce: max_abs}
      travel:      {signal: tail_pose.pose, reduce: distance}    # xy path length of a port with x, y
      slip:        {report: carriage.slip}                       # summary.json reports.carriage.slip
      sink0:       {report: contact.mean_sinkage_m.0}            # an element of a list (index)
      rut_L:       {report: contact.rut.rut_volume_m3}           # a nested key

A metric is one of the two kinds: ``{signal, reduce}`` or ``{report}``.
``report`` is a dotted path into the run's ``summary["reports"]`` (what the
components' ``report`` methods returned at the end of the run,
framework/run_reports.py): component name, then dict keys, with integers
indexing lists. The number found there is the metric (a bool counts 0/1);
``None``, a report's "no value" (a slip never measured), is NaN. Before any
run, campaign.py checks that the path's component is in the scene and reports;
a path the run's reports do not have, or one that stops on a mapping, list or
string, is that run's error (``metrics: ...``), naming the path and the keys
there. Reports are never among the default metrics.

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

import numbers
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


@dataclass(frozen=True)
class ReportMetric:
    """``name`` = the number at the dotted ``report`` path in the run's ``summary["reports"]``."""

    name: str
    report: str

    @property
    def component(self) -> str:
        return self.report.split(".", 1)[0]


KINDS = "{signal: COMPONENT.PORT, reduce: R} or {report: COMPONENT.KEY[.KEY or .INDEX ...]}"


class MetricError(ValueError):
    """A report metric's path does not lead to a number in this run's reports (the run's error)."""


def _where(spec, file: str, key: str | None = None) -> str:
    """file:line of the metric (or of one of its keys) where the YAML loader kept it."""
    if not hasattr(spec, "where"):
        return file
    return spec.where(key) if key is not None else spec.where()


def _parse_report(name: str, spec, file: str) -> ReportMetric:
    if "reduce" in spec:
        raise ConfigError(f"'reduce' does not go with 'report': a report metric is the reported number itself; "
                          f"a metric is exactly one of {KINDS}", _where(spec, file, "reduce"), f"metrics.{name}.reduce")
    path = spec["report"]
    parts = path.split(".") if isinstance(path, str) else []
    if len(parts) < 2 or not all(p.strip() for p in parts):
        raise ConfigError(f"'report' must be a dotted path COMPONENT.KEY[.KEY or .INDEX ...] into the run's "
                          f"summary reports, got {path!r}", _where(spec, file, "report"), f"metrics.{name}.report")
    return ReportMetric(str(name), path)


def parse_metrics(raw, file: str) -> tuple[Metric | ReportMetric, ...] | None:
    """Check the file's ``metrics`` section; ``None`` means the defaults."""
    if raw is None:
        return None
    if not isinstance(raw, dict) or not raw:
        raise ConfigError(f"'metrics' must be a mapping of name -> {KINDS}", file, "metrics")
    out = []
    for name, spec in raw.items():
        if not isinstance(spec, dict):
            raise ConfigError(f"a metric is exactly one of {KINDS}, got {spec!r}", file, f"metrics.{name}")
        unknown = sorted(map(str, set(spec) - {"signal", "reduce", "report"}))
        if unknown or ("signal" in spec) == ("report" in spec):
            why = (f"unknown key '{unknown[0]}'" if unknown else
                   "both 'signal' and 'report'" if "signal" in spec else "neither 'signal' nor 'report'")
            raise ConfigError(f"{why}; a metric is exactly one of {KINDS}, got {dict(spec)!r}",
                              _where(spec, file), f"metrics.{name}")
        if "report" in spec:
            out.append(_parse_report(name, spec, file))
            continue
        reduce = spec.get("reduce", "final")
        if reduce not in REDUCTIONS:
            raise ConfigError(f"unknown reduction {reduce!r}; valid: {', '.join(REDUCTIONS)}",
                              _where(spec, file, "reduce"), f"metrics.{name}.reduce")
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
    for m in signal_metrics(metrics):
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


def signal_metrics(metrics) -> list[Metric]:
    """The ``{signal, reduce}`` metrics of a declaration (report metrics are checked against the scene)."""
    return [m for m in metrics or () if isinstance(m, Metric)]


def _keys(node) -> str:
    return ", ".join(map(str, node)) or "none"


def report_value(reports, path: str) -> float:
    """The number at the dotted ``path`` of a run's ``summary["reports"]`` (None: NaN); a MetricError naming
    the path and what is there otherwise."""
    node, walked = reports or {}, "reports"
    if not node:
        raise MetricError(f"report '{path}': the run's summary has no reports (no component reported)")
    for part in path.split("."):
        if isinstance(node, np.ndarray):
            node = node.tolist()                 # what summary.json holds: a list (a 0-d array: its number)
        if isinstance(node, dict):
            keys = {str(k): k for k in node}
            if part not in keys:
                failed = f" (its report failed: {node['error']})" if set(node) == {"error"} else ""
                raise MetricError(f"report '{path}': {walked} has no '{part}'{failed}; keys there: {_keys(node)}")
            node = node[keys[part]]
        elif isinstance(node, (list, tuple)):
            try:
                i = int(part)
                node = node[i]
            except (ValueError, IndexError):
                raise MetricError(f"report '{path}': {walked} is {_what(node)}; '{part}' is not one of its "
                                  f"{_indices(node)}") from None
        else:
            raise MetricError(f"report '{path}': {walked} is {_what(node)}, it has no '{part}'")
        walked += f".{part}"
    if isinstance(node, np.ndarray) and node.ndim == 0:
        node = node.item()
    if node is None:
        return float("nan")
    if isinstance(node, (numbers.Real, np.bool_)):
        return float(node)
    if isinstance(node, (dict, list, tuple, np.ndarray)):
        inside = f"keys there: {_keys(node)}" if isinstance(node, dict) else f"add one of its {_indices(node)}"
        raise MetricError(f"report '{path}': {walked} is {_what(node)}, not a number; {inside}")
    raise MetricError(f"report '{path}': {walked} is {_what(node)}, not a number")


def _indices(node) -> str:
    return f"indices 0..{len(node) - 1}" if len(node) else "indices (it is empty)"


def _what(node) -> str:
    if isinstance(node, dict):
        return "a mapping"
    if isinstance(node, (list, tuple, np.ndarray)):
        return f"a list of {len(node)}"
    return f"a {type(node).__name__} ({node!r:.40})"


def evaluate(metrics, log, summary: dict | None = None) -> dict[str, float]:
    """The metrics' values for one run's recorder and summary (a report metric reads ``summary["reports"]``;
    columns of a port metric: ``NAME.<element>``)."""
    metrics = default_metrics(log) if metrics is None else metrics
    ports = port_columns(log)
    rows = log.rows
    out: dict[str, float] = {}
    for m in metrics:
        if isinstance(m, ReportMetric):
            out[m.name] = report_value((summary or {}).get("reports"), m.report)
        elif m.reduce in ("distance", "displacement"):
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
