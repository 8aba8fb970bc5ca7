"""Dispersion files: what to vary, how it is distributed, and the samples of a campaign.

A dispersion file is YAML::

    seed: 7                                   # optional (default 0); --seed overrides
    dispersions:                              # each key is a path `snakesim run --set` accepts
      damping:                       {dist: uniform, low: 0.01, high: 0.2}
      components.pend.params.length: {dist: normal, mean: 1.0, std: 0.05}
      components.pend.params.mass:   {dist: log_uniform, low: 0.5, high: 2.0}
      components.pend.params.theta0: {dist: truncated_normal, mean: 0.2, std: 0.1, low: 0.05, high: 0.4}
      sim.integrator:                {dist: choice, values: [rk4, dopri5], weights: [3, 1]}
      components.pend.params.gravity: {dist: grid, values: [1.62, 3.71, 9.81]}
      components.pend.params.omega0: {dist: latin_hypercube, low: -0.1, high: 0.1}
    metrics: ...                              # optional, see metrics.py
    success: [ok]                             # optional: statuses that count as success
    curves:                                   # optional: curves.png, one panel per entry, y against x
      - {x: components.pend.params.length, y: theta_final}   # each a dispersed path or a declared metric

Every continuous distribution and ``choice`` is an inverse CDF ``ppf(u)`` of a
uniform ``u`` in (0, 1). A random draw takes ``u`` from a generator keyed by
(seed, run index, parameter index) — numpy's SeedSequence with that spawn key
— so run i gets the same value whatever the number of workers or the order
runs finish in, and adding a parameter does not change the others' draws.
``sampling: lhs`` (or ``dist: latin_hypercube``, a uniform one) takes ``u`` from
a Latin hypercube over all N runs instead: stratum ``perm[i]`` of N, computed
once up front, so each of the N equal-probability strata is hit exactly once.
``grid`` parameters form a full factorial (row-major in file order); run i takes
point ``i mod G``. Both designs depend on N; random draws do not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from snakesim.framework.errors import ConfigError
from snakesim.framework.yaml_source import LocatedDict, load_yaml

DISTRIBUTIONS = ("uniform", "normal", "log_uniform", "truncated_normal", "choice", "grid", "latin_hypercube")
SAMPLINGS = ("random", "lhs")
TOP_KEYS = ("seed", "dispersions", "metrics", "success", "curves")
_U_BITS = 53          # u = (integer + 0.5) / 2**53: never exactly 0 or 1, so ppf is always finite


@dataclass(frozen=True)
class Dispersion:
    """One dispersed parameter: its ``--set`` path, distribution and arguments.

    ``args`` holds the distribution's numbers (``low``/``high``/``mean``/``std``)
    or ``values``/``weights`` for ``choice`` and ``grid``.
    """

    path: str
    dist: str
    args: dict
    sampling: str = "random"
    where: str | None = None            # file:line of the entry, for errors

    # -- the inverse CDF ------------------------------------------------------
    def ppf(self, u: np.ndarray) -> list:
        """Values at probabilities ``u`` (array in (0, 1)) as plain Python values."""
        a, d = self.args, self.dist
        if d in ("uniform", "latin_hypercube"):
            x = a["low"] + u * (a["high"] - a["low"])
        elif d == "normal":
            x = stats.norm.ppf(u, loc=a["mean"], scale=a["std"])
        elif d == "log_uniform":
            lo, hi = math.log(a["low"]), math.log(a["high"])
            x = np.exp(lo + u * (hi - lo))
        elif d == "truncated_normal":
            if a["std"] == 0:
                x = np.full_like(u, a["mean"])
            else:
                lo, hi = (a["low"] - a["mean"]) / a["std"], (a["high"] - a["mean"]) / a["std"]
                x = stats.truncnorm.ppf(u, lo, hi, loc=a["mean"], scale=a["std"])
                x = np.clip(x, a["low"], a["high"])      # ppf rounding must not leave the bounds
        elif d == "choice":
            cum = np.cumsum(a["weights"]) / np.sum(a["weights"])
            idx = np.minimum(np.searchsorted(cum, u, side="right"), len(a["values"]) - 1)
            return [a["values"][int(i)] for i in idx]
        else:
            raise ValueError(f"{d} has no inverse CDF")
        return [float(v) for v in np.asarray(x, dtype=float)]


@dataclass(frozen=True)
class DispersionFile:
    """A parsed dispersion file: the dispersions in file order and the campaign's settings."""

    path: str
    seed: int
    dispersions: tuple[Dispersion, ...]
    metrics: dict | None = None          # raw metric declarations (metrics.parse_metrics checks them)
    success: tuple[str, ...] = ("ok",)
    text: str = ""                        # the file as written (kept with the campaign for resume)
    curves: tuple[tuple[str, str], ...] = ()   # (x, y) column pairs for curves.png (report.py)

    @property
    def paths(self) -> list[str]:
        return [d.path for d in self.dispersions]


# -- parsing -------------------------------------------------------------------

def _num(entry, key, path, where, file):
    v = entry.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ConfigError(f"'{key}' must be a finite number, got {v!r}", where(key), f"dispersions.{path}.{key}")
    return float(v)


def _need(entry, keys, path, where, dist):
    missing = [k for k in keys if k not in entry]
    if missing:
        raise ConfigError(f"{dist} needs {', '.join(keys)}; missing {', '.join(missing)}",
                          where(None), f"dispersions.{path}")


def parse_dispersion(path: str, entry, file: str) -> Dispersion:
    """Check one ``path: {dist: ..., ...}`` entry; every error names file:line, key, value and what is valid."""
    where = (lambda k: entry.where(k) if isinstance(entry, LocatedDict) else file)
    if not isinstance(entry, dict) or "dist" not in entry:
        raise ConfigError(f"each dispersion is a mapping with 'dist' (one of {', '.join(DISTRIBUTIONS)}), "
                          f"got {entry!r}", where(None), f"dispersions.{path}")
    dist = entry["dist"]
    if dist not in DISTRIBUTIONS:
        raise ConfigError(f"unknown distribution {dist!r}; valid: {', '.join(DISTRIBUTIONS)}",
                          where("dist"), f"dispersions.{path}.dist")
    sampling = entry.get("sampling", "lhs" if dist == "latin_hypercube" else "random")
    if sampling not in SAMPLINGS or (dist == "grid" and "sampling" in entry):
        raise ConfigError(f"sampling {sampling!r} is not valid here; valid: "
                          f"{'none (a grid is its own design)' if dist == 'grid' else ', '.join(SAMPLINGS)}",
                          where("sampling"), f"dispersions.{path}.sampling")
    allowed = {"uniform": ("low", "high"), "latin_hypercube": ("low", "high"), "log_uniform": ("low", "high"),
               "normal": ("mean", "std"), "truncated_normal": ("mean", "std", "low", "high"),
               "choice": ("values", "weights"), "grid": ("values", "low", "high", "num", "scale")}[dist]
    extra = [k for k in entry if k not in (*allowed, "dist", "sampling")]
    if extra:
        raise ConfigError(f"unknown key '{extra[0]}' for {dist}; valid: dist, {', '.join(allowed)}"
                          + ("" if dist == "grid" else ", sampling"), where(extra[0]), f"dispersions.{path}.{extra[0]}")
    args: dict = {}
    key = f"dispersions.{path}"
    if dist in ("choice", "grid") and ("values" in entry or dist == "choice"):
        values = entry.get("values")
        if not isinstance(values, list) or not values:
            raise ConfigError(f"'values' must be a non-empty list, got {values!r}", where("values"), f"{key}.values")
        args["values"] = list(values)
        if dist == "grid" and any(k in entry for k in ("low", "high", "num", "scale")):
            raise ConfigError("a grid takes either 'values' or 'low', 'high', 'num' (and 'scale'), not both",
                              where(None), key)
        weights = entry.get("weights")
        if weights is None:
            args["weights"] = [1.0] * len(values)
        else:
            if (not isinstance(weights, list) or len(weights) != len(values)
                    or any(isinstance(w, bool) or not isinstance(w, (int, float)) or not (w >= 0) or math.isinf(w)
                           for w in weights) or sum(weights) <= 0):
                raise ConfigError(f"'weights' must be {len(values)} non-negative finite numbers (one per value) "
                                  f"with a positive sum, got {weights!r}", where("weights"), f"{key}.weights")
            args["weights"] = [float(w) for w in weights]
    elif dist == "grid":
        _need(entry, ("low", "high", "num"), path, where, dist)
        lo, hi = _num(entry, "low", path, where, file), _num(entry, "high", path, where, file)
        num = entry["num"]
        if isinstance(num, bool) or not isinstance(num, int) or num < 1:
            raise ConfigError(f"'num' must be an integer >= 1, got {num!r}", where("num"), f"{key}.num")
        scale = entry.get("scale", "linear")
        if scale not in ("linear", "log"):
            raise ConfigError(f"'scale' must be linear or log, got {scale!r}", where("scale"), f"{key}.scale")
        if lo > hi:
            raise ConfigError(f"low ({lo:g}) > high ({hi:g}); valid: low <= high", where("high"), f"{key}.high")
        if scale == "log" and lo <= 0:
            raise ConfigError(f"a log grid needs low > 0, got low = {lo:g}", where("low"), f"{key}.low")
        pts = np.geomspace(lo, hi, num) if scale == "log" else np.linspace(lo, hi, num)
        args["values"] = [float(v) for v in pts]
    else:
        need = {"uniform": ("low", "high"), "latin_hypercube": ("low", "high"), "log_uniform": ("low", "high"),
                "normal": ("mean", "std"), "truncated_normal": ("mean", "std", "low", "high")}[dist]
        _need(entry, need, path, where, dist)
        args = {k: _num(entry, k, path, where, file) for k in need}
        if "std" in args and args["std"] < 0:
            raise ConfigError(f"std must be >= 0 (a standard deviation), got {args['std']:g}",
                              where("std"), f"{key}.std")
        if "low" in args and args["low"] > args["high"]:
            raise ConfigError(f"low ({args['low']:g}) > high ({args['high']:g}); valid: low <= high",
                              where("high"), f"{key}.high")
        if dist == "log_uniform" and args["low"] <= 0:
            raise ConfigError(f"log_uniform needs low > 0, got low = {args['low']:g}", where("low"), f"{key}.low")
    return Dispersion(path=path, dist=dist, args=args, sampling=sampling, where=where(None))


def load_dispersions(path: str | Path) -> DispersionFile:
    """Read and check a dispersion file (errors name the file, line, key and what is valid)."""
    path = Path(path)
    data = load_yaml(path)
    file = str(path)
    if not isinstance(data, dict):
        raise ConfigError("a dispersion file must be a YAML mapping with 'dispersions'", file)
    bad = [k for k in data if k not in TOP_KEYS]
    if bad:
        raise ConfigError(f"unknown top-level key '{bad[0]}'; valid: {', '.join(TOP_KEYS)}", data.where(bad[0]), bad[0])
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"'seed' must be a non-negative integer, got {seed!r}", data.where("seed"), "seed")
    raw = data.get("dispersions")
    if not isinstance(raw, dict) or not raw:
        raise ConfigError("'dispersions' must be a non-empty mapping of --set path -> {dist: ...}",
                          data.where("dispersions") if "dispersions" in data else file, "dispersions")
    disps = tuple(parse_dispersion(str(k), v, file) for k, v in raw.items())
    success = data.get("success", ["ok"])
    from .runner import STATUSES
    if isinstance(success, str):
        success = [success]
    if not isinstance(success, list) or not success or any(s not in STATUSES for s in success):
        raise ConfigError(f"'success' lists run statuses, got {success!r}; valid: {', '.join(STATUSES)}",
                          data.where("success"), "success")
    curves = parse_curves(data, [d.path for d in disps], data.get("metrics"), file)
    return DispersionFile(path=file, seed=seed, dispersions=disps, metrics=data.get("metrics"),
                          success=tuple(success), text=path.read_text(), curves=curves)


def parse_curves(data, paths: list[str], metrics, file: str) -> tuple[tuple[str, str], ...]:
    """The file's ``curves``: a list of {x, y}, each a dispersed path or a declared metric's name (a curve
    plots what the file names, so it needs a ``metrics`` section to name the metrics)."""
    raw = data.get("curves")
    if raw is None:
        return ()
    where = data.where("curves")
    if not isinstance(raw, list) or not raw:
        raise ConfigError(f"'curves' is a list of {{x: NAME, y: NAME}}, got {raw!r}", where, "curves")
    names = [*paths, *(metrics or {})]
    out = []
    for i, c in enumerate(raw):
        at = c.where() if hasattr(c, "where") else where
        if not isinstance(c, dict) or set(c) != {"x", "y"}:
            raise ConfigError(f"a curve is {{x: NAME, y: NAME}}, got {c!r}", at, f"curves[{i}]")
        for axis in ("x", "y"):
            if c[axis] not in names:
                raise ConfigError(f"curve {axis} '{c[axis]}' is neither a dispersed path nor a declared metric; "
                                  f"valid: {', '.join(map(str, names))}", at, f"curves[{i}].{axis}")
        out.append((str(c["x"]), str(c["y"])))
    return tuple(out)


# -- sampling ------------------------------------------------------------------

def _uniforms(seed: int, run: int, param: int) -> float:
    """The u in (0, 1) of one random draw, from a stream keyed by (seed, run, parameter)."""
    rng = np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=(run, param)))
    return (float(rng.integers(0, 2 ** _U_BITS)) + 0.5) / 2 ** _U_BITS


def _lhs_column(seed: int, param: int, n: int) -> np.ndarray:
    """A Latin hypercube column: u_i in stratum perm[i] of n, each stratum exactly once."""
    rng = np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=(2 ** 32 - 1, param)))
    perm = rng.permutation(n)
    jitter = (rng.integers(0, 2 ** _U_BITS, size=n).astype(float) + 0.5) / 2 ** _U_BITS
    return (perm + jitter) / n


def grid_size(disps) -> int:
    return int(np.prod([len(d.args["values"]) for d in disps if d.dist == "grid"] or [1]))


#: bytes a Latin-hypercube column holds per run while it is drawn and kept (permutation, jitter, values)
LHS_BYTES_PER_RUN = 64
#: bytes a run's values take in the list ``sample`` returns (a dict of Python values a run)
SAMPLE_BYTES_PER_RUN = 400


def _check_sample_memory(n: int, per_run: float, what: str) -> None:
    """Refuse, before anything is allocated, ``n`` runs' ``what`` when it would pass the memory limit."""
    from snakesim.framework.limits import fmt_bytes, memory_limit_bytes

    need, limit = n * per_run, memory_limit_bytes()
    if need > limit:
        raise ConfigError(f"{n} runs: {what} would take ~{fmt_bytes(need)} ({per_run:g} B a run), over the memory "
                          f"limit {fmt_bytes(limit)} (half the physical memory, or SNAKESIM_MEMORY_LIMIT); at most "
                          f"{int(limit // per_run)} runs fit", "-n")


class Samples:
    """The N runs' values, drawn when a run is asked for (``samples[i]``): a campaign of any N starts at
    once and holds only the runs in flight. Run i equals :func:`sample_run` (random draws, grid points);
    Latin-hypercube columns are a design over all N, drawn up front (refused when they would not fit)."""

    def __init__(self, df: DispersionFile, n: int, seed: int | None = None):
        if isinstance(n, bool) or not isinstance(n, int) or n <= 0:
            raise ConfigError(f"the number of runs must be a positive integer, got {n!r}", "-n")
        self.df, self.n = df, n
        self.seed = df.seed if seed is None else seed
        lhs = [(j, d) for j, d in enumerate(df.dispersions) if d.dist != "grid" and d.sampling == "lhs"]
        if lhs:
            _check_sample_memory(n, LHS_BYTES_PER_RUN * len(lhs), "the Latin-hypercube design")
        self._lhs = {d.path: d.ppf(_lhs_column(self.seed, j, n)) for j, d in lhs}

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(self.n))]
        if i < 0:
            i += self.n
        if not 0 <= i < self.n:
            raise IndexError(f"run {i} of {self.n}")
        row = sample_run(self.df, i, self.seed)
        for path, col in self._lhs.items():
            row[path] = col[i]
        return row

    def __iter__(self):
        return (self[i] for i in range(self.n))


def sample(df: DispersionFile, n: int, seed: int | None = None) -> list[dict]:
    """The N runs' parameter values, ``[{path: value, ...}, ...]`` in file order (run i = row i), all at
    once (refused when they would not fit in memory; a campaign draws them lazily: :class:`Samples`)."""
    if isinstance(n, bool) or not isinstance(n, int) or n <= 0:
        raise ConfigError(f"the number of runs must be a positive integer, got {n!r}", "-n")
    _check_sample_memory(n, SAMPLE_BYTES_PER_RUN + LHS_BYTES_PER_RUN * len(df.dispersions), "drawing every sample")
    seed = df.seed if seed is None else seed
    cols: dict[str, list] = {}
    grids = [(j, d) for j, d in enumerate(df.dispersions) if d.dist == "grid"]
    sizes = [len(d.args["values"]) for _, d in grids]
    for j, d in enumerate(df.dispersions):
        if d.dist == "grid":
            continue
        u = _lhs_column(seed, j, n) if d.sampling == "lhs" else np.array([_uniforms(seed, i, j) for i in range(n)])
        cols[d.path] = d.ppf(u)
    if grids:
        # full factorial, row-major in file order (the last grid parameter varies fastest)
        idx = np.array(np.unravel_index(np.arange(n) % int(np.prod(sizes)), sizes)).T
        for k, (_, d) in enumerate(grids):
            cols[d.path] = [d.args["values"][int(i)] for i in idx[:, k]]
    return [{d.path: cols[d.path][i] for d in df.dispersions} for i in range(n)]


def sample_run(df: DispersionFile, run: int, seed: int | None = None) -> dict:
    """Run ``run``'s values alone, ``{path: value}`` in file order, without drawing the others: what
    :func:`sample` gives as row ``run`` for any N > ``run`` (a random draw is keyed by (seed, run,
    parameter), a grid point is ``run mod G``). A Latin-hypercube entry is a design over all N runs, so
    here it is a random draw from its distribution (the stratification needs N); what a Gymnasium
    environment's episode ``run`` uses (snakesim.gym)."""
    if isinstance(run, bool) or not isinstance(run, int) or run < 0:
        raise ConfigError(f"the run index must be an integer >= 0, got {run!r}", "run")
    seed = df.seed if seed is None else seed
    out: dict = {}
    grids = [d for d in df.dispersions if d.dist == "grid"]
    if grids:
        sizes = [len(d.args["values"]) for d in grids]
        idx = np.unravel_index(run % int(np.prod(sizes)), sizes)
        out.update({d.path: d.args["values"][int(i)] for d, i in zip(grids, idx)})
    for j, d in enumerate(df.dispersions):
        if d.dist != "grid":
            out[d.path] = d.ppf(np.array([_uniforms(seed, run, j)]))[0]
    return {d.path: out[d.path] for d in df.dispersions}


def set_item(path: str, value) -> str:
    """``path=value`` as ``--set`` reads it back (floats exactly: repr round-trips float64)."""
    import yaml

    if isinstance(value, float):
        text = repr(value) if math.isfinite(value) else (".nan" if math.isnan(value) else
                                                        (".inf" if value > 0 else "-.inf"))
    elif isinstance(value, (bool, int)) or value is None:
        text = yaml.safe_dump(value).removesuffix("\n...\n").strip()
    else:
        text = yaml.safe_dump(value, default_flow_style=True, width=10 ** 9).removesuffix("\n...\n").strip()
    return f"{path}={text}"
