"""Dispersion files: each distribution's statistics, the designs, reproducibility and every class of bad input."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from click.testing import CliRunner
from scipy import stats

from snakesim.campaigns.campaign import prepare
from snakesim.campaigns.dispersions import load_dispersions, sample, sample_run, set_item
from snakesim.campaigns.runner import SceneSpec
from snakesim.framework.errors import ConfigError
from snakesim.framework.layering import parse_set


def _file(tmp_path, text, name="d.yaml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text).lstrip("\n"))
    return p


def _col(samples, path):
    return np.array([s[path] for s in samples])


def test_each_distribution_has_its_statistics(tmp_path):
    df = load_dispersions(_file(tmp_path, """
        seed: 11
        dispersions:
          a: {dist: uniform, low: 2.0, high: 5.0}
          b: {dist: normal, mean: 1.0, std: 0.5}
          c: {dist: log_uniform, low: 0.01, high: 100.0}
          d: {dist: truncated_normal, mean: 0.0, std: 1.0, low: -0.5, high: 1.5}
          e: {dist: choice, values: [x, y, z], weights: [1, 2, 1]}
    """))
    s = sample(df, 4000)
    a, b, c, d = (_col(s, k) for k in "abcd")
    assert a.min() >= 2 and a.max() <= 5 and stats.kstest(a, stats.uniform(2, 3).cdf).pvalue > 1e-3
    assert stats.kstest(b, stats.norm(1.0, 0.5).cdf).pvalue > 1e-3
    assert c.min() >= 0.01 and c.max() <= 100 and stats.kstest(np.log10(c), stats.uniform(-2, 4).cdf).pvalue > 1e-3
    assert d.min() >= -0.5 and d.max() <= 1.5
    assert stats.kstest(d, stats.truncnorm(-0.5, 1.5).cdf).pvalue > 1e-3
    e = list(_col(s, "e"))
    assert abs(e.count("y") / len(e) - 0.5) < 0.04 and set(e) == {"x", "y", "z"}


def test_latin_hypercube_hits_each_stratum_once_and_grid_is_a_full_factorial(tmp_path):
    df = load_dispersions(_file(tmp_path, """
        dispersions:
          u: {dist: latin_hypercube, low: 0.0, high: 10.0}
          n: {dist: normal, mean: 0.0, std: 1.0, sampling: lhs}
          g1: {dist: grid, values: [a, b]}
          g2: {dist: grid, low: 1.0, high: 100.0, num: 3, scale: log}
    """))
    n = 50
    s = sample(df, n)
    u = _col(s, "u")
    assert sorted(np.floor(u / 10 * n).astype(int)) == list(range(n))
    z = stats.norm.cdf(_col(s, "n"))
    assert sorted(np.floor(z * n).astype(int)) == list(range(n))
    pts = [(r["g1"], r["g2"]) for r in s[:6]]
    assert pts == [("a", 1.0), ("a", 10.0), ("a", 100.0), ("b", 1.0), ("b", 10.0), ("b", 100.0)]
    assert [(r["g1"], r["g2"]) for r in s[6:12]] == pts        # cycles


def test_random_draws_depend_only_on_seed_and_run_index(tmp_path):
    df = load_dispersions(_file(tmp_path, """
        seed: 5
        dispersions:
          a: {dist: uniform, low: 0.0, high: 1.0}
          b: {dist: normal, mean: 0.0, std: 1.0}
    """))
    s10, s3 = sample(df, 10), sample(df, 3)
    assert s10[:3] == s3 and sample(df, 10) == s10
    assert sample(df, 10, seed=6) != s10
    # the --set text reads back to exactly the sampled float
    for r in s10:
        for p, v in r.items():
            assert parse_set(set_item(p, v))[1] == v



def test_one_runs_values_alone_are_the_sweeps_row(tmp_path):
    """sample_run (a Gymnasium episode's values, snakesim.gym) draws run i without the others: the row
    sample() gives for any N, for random draws and grid points; a Latin-hypercube entry is a plain draw."""
    df = load_dispersions(_file(tmp_path, """
        seed: 5
        dispersions:
          a: {dist: uniform, low: 0.0, high: 1.0}
          b: {dist: log_uniform, low: 0.5, high: 2.0}
          c: {dist: choice, values: [x, y, z], weights: [1, 2, 1]}
          g: {dist: grid, values: [1, 2, 3]}
          h: {dist: grid, low: 0.0, high: 1.0, num: 2}
          n: {dist: truncated_normal, mean: 0.0, std: 1.0, low: -1.0, high: 1.0}
    """))
    rows = sample(df, 14, seed=9)
    assert [sample_run(df, i, seed=9) for i in range(14)] == rows
    assert sample_run(df, 3) == sample(df, 4)[3]
    lhs = load_dispersions(_file(tmp_path, """
        dispersions:
          l: {dist: latin_hypercube, low: 2.0, high: 3.0}
    """, "l.yaml"))
    assert 2.0 < sample_run(lhs, 0, seed=1)["l"] < 3.0
    with pytest.raises(ConfigError, match="run index"):
        sample_run(df, -1)


SCENE = SceneSpec("pendulum")


@pytest.mark.parametrize("entry, message", [
    ("dampin: {dist: uniform, low: 0, high: 1}", "'dampin' is neither a top-level key"),
    ("components.pend.params.lenght: {dist: uniform, low: 0.5, high: 1}", "Pendulum takes: length, mass"),
    ("components.pendd.params.length: {dist: uniform, low: 0.5, high: 1}", "component 'pendd' has no 'type'"),
    ("sim.dtt: {dist: uniform, low: 0.001, high: 0.002}", "unknown key 'dtt'"),
])
def test_unknown_parameter_paths_are_named_with_the_valid_ones(tmp_path, entry, message):
    f = _file(tmp_path, f"dispersions:\n  {entry}\n")
    with pytest.raises(ConfigError) as e:
        prepare(SCENE, str(f), 4)
    assert message in str(e.value) and f"{f}:2" in str(e.value)


@pytest.mark.parametrize("entry, message", [
    ("{dist: normal, mean: 1, std: -0.1}", "std must be >= 0"),
    ("{dist: truncated_normal, mean: 1, std: -1, low: 0, high: 2}", "std must be >= 0"),
    ("{dist: uniform, low: 2, high: 1}", "low (2) > high (1)"),
    ("{dist: truncated_normal, mean: 1, std: 1, low: 3, high: 2}", "low (3) > high (2)"),
    ("{dist: log_uniform, low: 0, high: 1}", "log_uniform needs low > 0"),
    ("{dist: choice, values: []}", "'values' must be a non-empty list"),
    ("{dist: choice, values: [1, 2], weights: [1]}", "'weights' must be 2 non-negative"),
    ("{dist: grid, low: 1, high: 2, num: 0}", "'num' must be an integer >= 1"),
    ("{dist: gaussian, mean: 1, std: 1}", "unknown distribution 'gaussian'; valid: uniform, normal"),
    ("{dist: uniform, low: 0}", "uniform needs low, high; missing high"),
    ("{dist: uniform, low: 0, high: 1, sigma: 2}", "unknown key 'sigma' for uniform"),
])
def test_impossible_distributions_name_file_key_value_and_what_is_valid(tmp_path, entry, message):
    f = _file(tmp_path, f"dispersions:\n  damping: {entry}\n")
    with pytest.raises(ConfigError) as e:
        load_dispersions(f)
    assert message in str(e.value) and str(f) in str(e.value) and "dispersions.damping" in str(e.value)


@pytest.mark.parametrize("n", [0, -3])
def test_n_must_be_positive(tmp_path, n):
    f = _file(tmp_path, "dispersions:\n  damping: {dist: uniform, low: 0, high: 1}\n")
    with pytest.raises(ConfigError, match=f"positive integer, got {n}"):
        prepare(SCENE, str(f), n)


def test_cli_reports_bad_input_before_any_run(tmp_path):
    from snakesim.framework.cli import cli, install_plugin_cli

    install_plugin_cli()
    f = _file(tmp_path, "dispersions:\n  damping: {dist: normal, mean: 0.1, std: -1}\n")
    r = CliRunner().invoke(cli, ["sweep", "pendulum", "--dispersions", str(f), "-n", "3", "--out", str(tmp_path / "o")])
    assert r.exit_code != 0 and "std must be >= 0" in r.output
    assert not (tmp_path / "o").exists()
    f = _file(tmp_path, "dispersions:\n  damping: {dist: uniform, low: 0, high: 1}\n", "ok.yaml")
    r = CliRunner().invoke(cli, ["sweep", "pendulum", "--dispersions", str(f), "-n", "0"])
    assert r.exit_code != 0 and "positive integer, got 0" in r.output


def test_unreachable_scheduler_is_a_clear_error_after_a_short_timeout(tmp_path):
    import socket
    import time

    from snakesim.campaigns.backends import dask_scheduler
    from snakesim.campaigns.results import CampaignError

    with socket.socket() as s:            # a loopback port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.perf_counter()
    with pytest.raises(CampaignError, match=f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port} within 1 s"):
        dask_scheduler(f"tcp://127.0.0.1:{port}", connect_timeout=1.0)
    assert time.perf_counter() - t0 < 10
    with pytest.raises(CampaignError, match="not a scheduler address; valid: tcp://HOST:PORT"):
        dask_scheduler("localhost:8786")


def test_a_dispersion_an_explicit_flag_would_override_is_refused(tmp_path):
    f = _file(tmp_path, "dispersions:\n  sim.duration: {dist: uniform, low: 1, high: 2}\n")
    with pytest.raises(ConfigError, match="would be overridden by --duration 3"):
        prepare(SceneSpec("pendulum", sim=(("duration", 3.0),)), str(f), 2)


CURVES_HEAD = """
dispersions:
  damping: {dist: uniform, low: 0.01, high: 0.2}
metrics:
  theta_final: {signal: pend.theta, reduce: final}
"""


def test_curves_name_a_dispersed_path_and_a_metric(tmp_path):
    df = load_dispersions(_file(tmp_path, CURVES_HEAD + "curves:\n  - {x: damping, y: theta_final}\n"))
    assert df.curves == (("damping", "theta_final"),)
    assert load_dispersions(_file(tmp_path, CURVES_HEAD, "none.yaml")).curves == ()


@pytest.mark.parametrize("curves, message", [
    ("curves: {x: damping, y: theta_final}", "'curves' is a list of {x: NAME, y: NAME}"),
    ("curves: []", "'curves' is a list of {x: NAME, y: NAME}"),
    ("curves:\n  - {x: damping}", "a curve is {x: NAME, y: NAME}"),
    ("curves:\n  - {x: damping, y: omega_peak}",
     "curve y 'omega_peak' is neither a dispersed path nor a declared metric; valid: damping, theta_final"),
])
def test_bad_curves_name_the_file_key_and_what_is_valid(tmp_path, curves, message):
    path = _file(tmp_path, CURVES_HEAD + curves + "\n")
    with pytest.raises(ConfigError) as e:
        load_dispersions(path)
    assert message in str(e.value) and str(path) in str(e.value), str(e.value)
