"""A campaign's summary: status counts, sensitivity ranking and PNG plots, from its results table.

``sensitivity.csv``           Spearman rank correlation of every metric with every numeric dispersed
                              parameter over the successful runs, ranked by |rho| (p-value, n)
``hist.png``                  a histogram per dispersed parameter and per metric (successful runs)
``scatter.png``               each metric against each dispersed parameter (successful runs)
``curves.png``                the dispersion file's ``curves``: y against x, a panel each (successful runs
                              joined in x's order; the others as red crosses)
``success_by_parameter.png``  success rate per parameter bin (10 equal-count bins; a bar per value
                              for parameters with few distinct values)
``summary.json``              counts per status, success rate, failed runs (status not in ``success``) and
                              counts per failure kind, the 20 strongest sensitivities
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .results import atomic_write

MAX_METRICS_PLOTTED = 12       # figures stay readable; the ranking keeps every metric
MAX_PARAMS_PLOTTED = 8


def _numeric(col) -> np.ndarray | None:
    """A table column as floats, or None when it is not numeric."""
    vals = col.to_pylist()
    if not all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in vals):
        return None
    return np.array([np.nan if v is None else float(v) for v in vals])


def sensitivity(table, params: list[str], metrics: list[str], ok: np.ndarray) -> list[dict]:
    """Spearman rho of each (parameter, metric) over successful runs, strongest first."""
    from scipy.stats import spearmanr

    rows = []
    for p in params:
        x = _numeric(table.column(p))
        if x is None:
            continue            # a categorical parameter: no rank order to correlate with
        for m in metrics:
            y = _numeric(table.column(m))
            sel = ok & np.isfinite(x) & np.isfinite(y)
            if sel.sum() < 3 or np.ptp(x[sel]) == 0 or np.ptp(y[sel]) == 0:
                continue
            r = spearmanr(x[sel], y[sel])
            rows.append({"parameter": p, "metric": m, "spearman_rho": float(r.statistic),
                         "p_value": float(r.pvalue), "n": int(sel.sum())})
    rows.sort(key=lambda r: -abs(r["spearman_rho"]) if math.isfinite(r["spearman_rho"]) else 0.0)
    return rows


def _bins(x: np.ndarray, nbins: int = 10):
    """(label, mask) per bin: distinct values when there are few, else equal-count bins."""
    finite = x[np.isfinite(x)]
    distinct = np.unique(finite)
    if len(distinct) <= nbins:
        return [(f"{v:.3g}", x == v) for v in distinct]
    edges = np.unique(np.quantile(finite, np.linspace(0, 1, nbins + 1)))
    out = []
    for k in range(len(edges) - 1):
        lo, hi = edges[k], edges[k + 1]
        mask = (x >= lo) & ((x <= hi) if k == len(edges) - 2 else (x < hi))
        out.append((f"{lo:.3g}..{hi:.3g}", mask))
    return out


def _save(fig, path: Path, dpi: int) -> None:
    """The figure as PNG, written whole or not at all (framework/output_files.py); the figure closed."""
    import io

    import matplotlib.pyplot as plt

    try:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi)
        atomic_write(path, buf.getvalue())
    finally:
        plt.close(fig)


def _successful(ok: np.ndarray) -> str:
    return f"successful runs ({int(ok.sum())} of {len(ok)})"


def _finish(fig, axes, used: int, path: Path, title: str | None = None) -> str:
    """Blank the panels past the ``used`` first, title, lay out and save the figure; its file name."""
    for ax in list(axes.flat)[used:]:
        ax.axis("off")
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    _save(fig, path, 110)
    return path.name


def _grid(n: int):
    cols = min(4, max(1, n))
    return (n + cols - 1) // cols, cols


def plot(table, params: list[str], metrics: list[str], ok: np.ndarray, out: Path,
         curves: tuple[tuple[str, str], ...] = ()) -> list[str]:
    """Write the PNGs (three, and curves.png for ``curves``); returns their names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    mets = metrics[:MAX_METRICS_PLOTTED]
    pars = params[:MAX_PARAMS_PLOTTED]
    series = [(p, table.column(p).to_pylist()) for p in pars] + [(m, _numeric(table.column(m))) for m in mets]
    if series:
        r, c = _grid(len(series))
        fig, axes = plt.subplots(r, c, figsize=(3.2 * c, 2.6 * r), squeeze=False)
        for ax, (name, vals) in zip(axes.flat, series):
            arr = _numeric_list(vals)
            if arr is not None:
                sel = ok & np.isfinite(arr)
                ax.hist(arr[sel], bins=min(30, max(5, int(np.sqrt(sel.sum())) + 1)), color="#4477aa")
            else:           # categorical: a bar per value
                labels, counts = np.unique([json.dumps(v) if not isinstance(v, str) else v
                                            for v, o in zip(vals, ok) if o], return_counts=True)
                ax.bar(range(len(labels)), counts, color="#4477aa", tick_label=list(labels))
            ax.set_title(name, fontsize=7)
            ax.tick_params(labelsize=6)
        written.append(_finish(fig, axes, len(series), out / "hist.png", _successful(ok)))
    num_pars = [(p, x) for p in pars if (x := _numeric(table.column(p))) is not None]
    if num_pars and mets:
        fig, axes = plt.subplots(len(mets), len(num_pars), figsize=(2.6 * len(num_pars), 2.0 * len(mets)),
                                 squeeze=False)
        for i, m in enumerate(mets):
            y = _numeric(table.column(m))
            for j, (p, x) in enumerate(num_pars):
                ax = axes[i, j]
                ax.scatter(x[ok], y[ok], s=6, color="#4477aa")
                ax.scatter(x[~ok], np.where(np.isfinite(y[~ok]), y[~ok], np.nan), s=8, marker="x", color="#cc3311")
                ax.tick_params(labelsize=5)
                if i == len(mets) - 1:
                    ax.set_xlabel(p, fontsize=6)
                if j == 0:
                    ax.set_ylabel(m, fontsize=6)
        fig.tight_layout()
        _save(fig, out / "scatter.png", 100)
        written.append("scatter.png")
    if curves:
        written.append(_curves(plt, table, curves, ok, out))
    if pars:
        r, c = _grid(len(pars))
        fig, axes = plt.subplots(r, c, figsize=(3.4 * c, 2.6 * r), squeeze=False)
        for ax, p in zip(axes.flat, pars):
            x = _numeric(table.column(p))
            if x is not None:
                groups = _bins(x)
            else:
                vals = [json.dumps(v) if not isinstance(v, str) else v for v in table.column(p).to_pylist()]
                groups = [(u, np.array([v == u for v in vals])) for u in sorted(set(vals))]
            rates = [ok[mask].mean() if mask.any() else np.nan for _, mask in groups]
            ax.bar(range(len(groups)), rates, color="#228833")
            ax.set_xticks(range(len(groups)), [g[0] for g in groups], rotation=60, fontsize=5)
            ax.set_ylim(0, 1.05)
            ax.set_title(p, fontsize=7)
            ax.set_ylabel("success rate", fontsize=6)
        written.append(_finish(fig, axes, len(pars), out / "success_by_parameter.png"))
    return written


def _curves(plt, table, curves, ok: np.ndarray, out: Path) -> str:
    """curves.png: per (x, y) column pair, y against x, the successful runs joined in x's order."""
    r, c = _grid(len(curves))
    fig, axes = plt.subplots(r, c, figsize=(4.0 * c, 3.2 * r), squeeze=False)
    for ax, (xn, yn) in zip(axes.flat, curves):
        x, y = _numeric(table.column(xn)), _numeric(table.column(yn))
        if x is None or y is None:
            ax.set_title(f"{yn} against {xn}: not numeric", fontsize=7)
            continue
        good = ok & np.isfinite(x) & np.isfinite(y)
        order = np.argsort(x[good], kind="stable")
        ax.plot(x[good][order], y[good][order], "o-", ms=4, color="#4477aa")
        ax.plot(x[~ok], np.where(np.isfinite(y[~ok]), y[~ok], np.nan), "x", color="#cc3311")
        ax.set_xlabel(xn, fontsize=7)
        ax.set_ylabel(yn, fontsize=7)
        ax.tick_params(labelsize=6)
        ax.grid(alpha=0.3)
    return _finish(fig, axes, len(curves), out / "curves.png", _successful(ok))


def _numeric_list(vals):
    if all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in vals):
        return np.array([np.nan if v is None else float(v) for v in vals])
    return None


def summarize(table, out: Path, success: tuple[str, ...] = ("ok",), plots: bool = True,
              curves: tuple[tuple[str, str], ...] = ()) -> dict:
    """Write sensitivity.csv, summary.json and (``plots``) the PNGs, curves.png for ``curves`` (x, y) column
    pairs; return the summary."""
    out = Path(out)
    meta = table.schema.metadata or {}
    params = json.loads(meta.get(b"snakesim.parameters", b"[]"))
    metrics = json.loads(meta.get(b"snakesim.metrics", b"[]"))
    status = table.column("status").to_pylist()
    ok = np.array([s in success for s in status], dtype=bool)
    counts = {s: status.count(s) for s in sorted(set(status))}
    ranking = sensitivity(table, params, metrics, ok)
    lines = ["parameter,metric,spearman_rho,p_value,n"]
    lines += [f"{r['parameter']},{r['metric']},{r['spearman_rho']:.6g},{r['p_value']:.6g},{r['n']}" for r in ranking]
    atomic_write(out / "sensitivity.csv", "\n".join(lines) + "\n")
    kinds = table.column("failure_kind").to_pylist() if "failure_kind" in table.column_names else []
    by_kind = {k: kinds.count(k) for k in sorted({k for k in kinds if isinstance(k, str)})}
    summary = {"runs": len(status), "by_status": counts, "success": list(success),
               "success_rate": float(ok.mean()) if len(ok) else float("nan"),
               "failed": int((~ok).sum()), "by_failure_kind": by_kind,
               "sensitivity_top": ranking[:20]}
    if plots and len(status):
        summary["plots"] = plot(table, params, metrics, ok, out, curves)
    atomic_write(out / "summary.json", json.dumps(summary, indent=2))
    return summary
