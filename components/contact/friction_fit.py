"""The paper's figure-6 procedure: μ and ‖e_v‖ = a + b·F_n from screw drag tests.

Data: one row per drag test, columns ``normal_force`` (N, > 0), ``direction``
(``parallel`` or ``normal`` to the threads) and ``drag_force`` (N, force to drag the screw
at constant speed). Lines starting with ``#`` and blank lines are ignored; other columns
are ignored.

    μ          = mean over parallel tests of drag/F_n            (fig. 6 top left)
    μ_⊥,i      = drag_i / F_n,i over normal tests                (fig. 6 top right)
    ‖e_v‖_i    = μ_⊥,i / μ ;  least squares ‖e_v‖ = a + b F_n    (fig. 6 bottom)

Standard errors: se(μ) = std/√n_par; se(a), se(b) from the ordinary least squares
covariance σ̂² (XᵀX)⁻¹ with σ̂² = RSS/(n_norm − 2) (the uncertainty of μ is not propagated
into a, b; it scales them by a common factor).

The result is a materials file (:func:`material_file`, snakesim.components.materials): one
Material with the fitted μ, ev_a, ev_b and a penalty k, c that the drag tests do not
measure (given, or taken from a base material; the file says which), which a terrain YAML
includes as it is: ``materials: [{include: FILE}]``.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from snakesim.components.materials import Material
from snakesim.framework import SnakesimError
from snakesim.framework.errors import ConfigError
from snakesim.framework.yaml_source import read_text

from ..csv_numbers import finite_number

COLUMNS = ("normal_force", "direction", "drag_force")
DIRECTIONS = ("parallel", "normal")
MIN_PARALLEL, MIN_NORMAL = 1, 3


class FrictionDataError(SnakesimError):
    """A drag-test CSV is wrong; the message names file, line, column and value."""


@dataclasses.dataclass(frozen=True)
class DragTests:
    source: str
    normal_force: np.ndarray   # (n,) N
    parallel: np.ndarray       # (n,) bool: dragged parallel to the threads
    drag_force: np.ndarray     # (n,) N
    lines: np.ndarray          # (n,) line numbers in the file


@dataclasses.dataclass(frozen=True)
class FrictionFit:
    mu: float
    ev_a: float
    ev_b: float
    se_mu: float
    se_a: float
    se_b: float
    fn_par: np.ndarray
    mu_par: np.ndarray         # parallel coefficients
    fn_norm: np.ndarray
    mu_norm: np.ndarray        # normal coefficients
    ev: np.ndarray             # mu_norm / mu

    @property
    def mu_residuals(self):
        return self.mu_par - self.mu

    @property
    def ev_residuals(self):
        return self.ev - (self.ev_a + self.ev_b * self.fn_norm)

    def material(self, name: str, k: float, c: float) -> Material:
        """The fitted material: μ, ev_a, ev_b from the fit; k and c given (drag tests do not
        measure them). Raises ValueError (pydantic's) if a value is out of range."""
        return Material(name=name, k=k, c=c, mu=float(self.mu), ev_a=float(self.ev_a), ev_b=float(self.ev_b))


def read_drag_tests(path) -> DragTests:
    """Parse and validate a drag-test CSV; every problem names file:line, column and value."""
    path = Path(path)
    try:
        text = read_text(path, "a drag-test CSV")       # the reading (and its messages) every text input shares
    except ConfigError as e:
        raise FrictionDataError(str(e)) from None
    rows = [(i + 1, line) for i, line in enumerate(text.splitlines()) if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise FrictionDataError(f"{path}: no header and no data (expected columns {', '.join(COLUMNS)})")
    header_line, header = rows[0]
    names = [h.strip().lower() for h in next(csv.reader([header]))]
    missing = [c for c in COLUMNS if c not in names]
    if missing:
        raise FrictionDataError(f"{path}:{header_line}: missing column(s) {', '.join(repr(m) for m in missing)}; "
                                f"header has {names}, expected {', '.join(COLUMNS)}")
    idx = {c: names.index(c) for c in COLUMNS}
    fn, par, drag, lines = [], [], [], []
    for lineno, line in rows[1:]:
        cells = [c.strip() for c in next(csv.reader([line]))]
        if len(cells) < len(names):
            raise FrictionDataError(f"{path}:{lineno}: {len(cells)} value(s), header has {len(names)} columns")

        def number(col):
            return finite_number(cells[idx[col]], f"{path}:{lineno}: column '{col}'", FrictionDataError)

        f = number("normal_force")
        if f <= 0:
            raise FrictionDataError(f"{path}:{lineno}: column 'normal_force': {cells[idx['normal_force']]!r} "
                                    f"must be > 0 N (a coefficient is drag / normal force)")
        d = cells[idx["direction"]].lower()
        if d not in DIRECTIONS:
            raise FrictionDataError(f"{path}:{lineno}: column 'direction': {cells[idx['direction']]!r} is not "
                                    f"one of {', '.join(DIRECTIONS)}")
        g = number("drag_force")
        if g < 0:
            raise FrictionDataError(f"{path}:{lineno}: column 'drag_force': {cells[idx['drag_force']]!r} must be ≥ 0 N")
        fn.append(f), par.append(d == "parallel"), drag.append(g), lines.append(lineno)
    par = np.array(par, bool)
    if par.sum() < MIN_PARALLEL or (~par).sum() < MIN_NORMAL:
        raise FrictionDataError(f"{path}: too few points to fit: {int(par.sum())} 'parallel' (need ≥ {MIN_PARALLEL}) "
                                f"and {int((~par).sum())} 'normal' (need ≥ {MIN_NORMAL}) drag tests")
    fn_norm = np.array(fn)[~par]
    if np.ptp(fn_norm) == 0:
        raise FrictionDataError(f"{path}: too few points to fit: all 'normal' tests have the same normal force "
                                f"{fn_norm[0]:g} N, so the slope of ‖e_v‖ is undetermined")
    return DragTests(str(path), np.array(fn), par, np.array(drag), np.array(lines))


def fit_friction(data: DragTests) -> FrictionFit:
    """Fig. 6: μ = mean parallel coefficient; least-squares ‖e_v‖ = a + b F_n."""
    par = data.parallel
    fn_par, fn_norm = data.normal_force[par], data.normal_force[~par]
    mu_par = data.drag_force[par] / fn_par
    mu_norm = data.drag_force[~par] / fn_norm
    mu = float(mu_par.mean())
    se_mu = float(mu_par.std(ddof=1) / math.sqrt(mu_par.size)) if mu_par.size > 1 else float("nan")
    ev = mu_norm / mu
    X = np.column_stack([np.ones_like(fn_norm), fn_norm])
    coef, *_ = np.linalg.lstsq(X, ev, rcond=None)
    dof = ev.size - 2
    rss = float(np.sum((ev - X @ coef) ** 2))
    cov = (rss / dof) * np.linalg.inv(X.T @ X) if dof > 0 else np.full((2, 2), np.nan)
    return FrictionFit(mu, float(coef[0]), float(coef[1]), se_mu, float(math.sqrt(cov[0, 0])),
                       float(math.sqrt(cov[1, 1])), fn_par, mu_par, fn_norm, mu_norm, ev)


def format_fit(fit: FrictionFit, data: DragTests) -> str:
    out = [f"drag tests: {data.source} ({fit.fn_par.size} parallel, {fit.fn_norm.size} normal)",
           f"  mu   = {fit.mu:.6g} ± {fit.se_mu:.2g}   (mean parallel drag / normal force)",
           f"  ev_a = {fit.ev_a:.6g} ± {fit.se_a:.2g}",
           f"  ev_b = {fit.ev_b:.6g} ± {fit.se_b:.2g} 1/N   (‖e_v‖ = ev_a + ev_b·F_n)",
           f"  rms residual: mu {np.sqrt(np.mean(fit.mu_residuals ** 2)):.3g}, "
           f"‖e_v‖ {np.sqrt(np.mean(fit.ev_residuals ** 2)):.3g}",
           "  residuals:", "    line  direction  F_n [N]   coef      fit       residual"]
    lines_par, lines_norm = data.lines[data.parallel], data.lines[~data.parallel]
    for ln, f, m, r in zip(lines_par, fit.fn_par, fit.mu_par, fit.mu_residuals):
        out.append(f"    {ln:4d}  parallel   {f:8.3f}  {m:8.5f}  {fit.mu:8.5f}  {r:+.5f}  (mu)")
    for ln, f, e, r in zip(lines_norm, fit.fn_norm, fit.ev, fit.ev_residuals):
        out.append(f"    {ln:4d}  normal     {f:8.3f}  {e:8.5f}  {e - r:8.5f}  {r:+.5f}  (‖e_v‖)")
    lo, hi = fit.fn_norm.min(), fit.fn_norm.max()
    ev_lo, ev_hi = fit.ev_a + fit.ev_b * lo, fit.ev_a + fit.ev_b * hi
    out.append(f"  ‖e_v‖ over the tested range [{lo:g}, {hi:g}] N: {ev_lo:.4g} .. {ev_hi:.4g}")
    if min(ev_lo, ev_hi, fit.ev_a) <= 0:
        out.append("  WARNING: the fit gives ‖e_v‖ ≤ 0 on [0, max tested F_n]; contact components reject it "
                   "unless their fn_max is lowered")
    return "\n".join(out)


def _yaml_float(x: float) -> str:
    """Full-precision float that every YAML reader reads as a float (YAML 1.1 needs a '.' in 1e-05)."""
    r = repr(float(x))
    mant, e, exp = r.partition("e")
    return f"{mant}.0e{exp}" if e and "." not in mant else r


def material_file(material: Material, fit: FrictionFit, source: str, k_from: str, c_from: str,
                  file_name: str = "FILE.yaml") -> str:
    """A materials file (snakesim.components.materials.read_material_file reads it) holding the
    fitted material; comments say what was fitted and where k and c came from. Hand-written
    YAML: stable key order, full precision."""
    m = material
    lo, hi = fit.fn_norm.min(), fit.fn_norm.max()
    return (f"# materials file written by `snakesim fit-friction {source}` (paper fig. 6 procedure).\n"
            f"# A terrain YAML includes it as it is (path relative to the terrain file):\n"
            f"#   materials:\n#     - {{include: {file_name}}}\n"
            f"# mu, ev_a, ev_b: fitted (standard errors {fit.se_mu:.2g}, {fit.se_a:.2g}, {fit.se_b:.2g} 1/N), "
            f"normal-direction tests at {lo:g} .. {hi:g} N\n"
            f"# k: not measured by the drag tests; {k_from}\n"
            f"# c: not measured by the drag tests; {c_from}\n"
            f"materials:\n"
            f"  - name: {json.dumps(m.name)}\n"
            f"    k: {_yaml_float(m.k)}    # N/m\n"
            f"    c: {_yaml_float(m.c)}    # N·s/m\n"
            f"    mu: {_yaml_float(m.mu)}\n"
            f"    ev_a: {_yaml_float(m.ev_a)}\n"
            f"    ev_b: {_yaml_float(m.ev_b)}    # 1/N\n")


def plot_fit(fit: FrictionFit, path) -> None:
    """Three panels as in fig. 6: μ_∥ vs F_n, μ_⊥ vs F_n, ‖e_v‖ vs F_n with the linear fit."""
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(9, 7), layout="constrained")
    gs = fig.add_gridspec(2, 2)
    ax1, ax2, ax3 = fig.add_subplot(gs[0, 0]), fig.add_subplot(gs[0, 1]), fig.add_subplot(gs[1, :])
    ax1.plot(fit.fn_par, fit.mu_par, "o")
    ax1.axhline(fit.mu, color="C1", label=f"μ = {fit.mu:.3f}")
    ax1.set(title="parallel to the threads", xlabel="normal force [N]", ylabel="friction coefficient")
    ax1.legend()
    ax2.plot(fit.fn_norm, fit.mu_norm, "o", color="C2")
    ax2.set(title="normal to the threads", xlabel="normal force [N]", ylabel="friction coefficient")
    f = np.linspace(0.0, fit.fn_norm.max() * 1.05, 50)
    ax3.plot(fit.fn_norm, fit.ev, "o", color="C2", label="μ_⊥ / μ")
    ax3.plot(f, fit.ev_a + fit.ev_b * f, color="C1",
             label=f"‖e_v‖ = {fit.ev_a:.3f} + {fit.ev_b:.4g}·F_n")
    ax3.set(title="‖e_v‖", xlabel="normal force [N]", ylabel="‖e_v‖")
    ax3.legend()
    fig.savefig(path, dpi=110)
    plt.close(fig)
