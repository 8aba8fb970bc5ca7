"""fig. 6 fit: recovery of known μ, a, b; CSV validation errors; the CLI."""

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from snakesim.components.contact.friction_fit import FrictionDataError, fit_friction, read_drag_tests
from snakesim.components.contact.friction_fit_cli import fit_friction as fit_cmd, snakesim_add_commands

HEADER = "normal_force,direction,drag_force\n"


def write(tmp_path, rows, name="tests.csv", header=HEADER):
    p = tmp_path / name
    p.write_text("# comment line\n" + header + "".join(rows))
    return p


def synth(mu, a, b, noise=0.0, seed=0, loads=np.arange(10.0, 81.0, 10.0), repeats=1):
    rng = np.random.default_rng(seed)
    rows = []
    for fn in loads:
        for _ in range(repeats):
            rows.append(f"{float(fn)!r},parallel,{float(mu * fn * (1 + noise * rng.standard_normal()))!r}\n")
            rows.append(f"{float(fn)!r},normal,{float(mu * (a + b * fn) * fn * (1 + noise * rng.standard_normal()))!r}\n")
    return rows


def test_noise_free_recovers_exactly(tmp_path):
    fit = fit_friction(read_drag_tests(write(tmp_path, synth(0.25, 1.8, 0.025))))
    assert fit.mu == pytest.approx(0.25, rel=1e-13)
    assert fit.ev_a == pytest.approx(1.8, rel=1e-12)
    assert fit.ev_b == pytest.approx(0.025, rel=1e-12)
    np.testing.assert_allclose(fit.ev_residuals, 0.0, atol=1e-12)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_noisy_recovers_within_standard_error(tmp_path, seed):
    fit = fit_friction(read_drag_tests(write(tmp_path, synth(0.25, 1.8, 0.025, noise=0.04, seed=seed, repeats=3))))
    assert abs(fit.mu - 0.25) < 3 * fit.se_mu
    assert abs(fit.ev_a - 1.8) < 3 * fit.se_a + 1.8 * 3 * fit.se_mu / 0.25      # a, b scale with 1/μ̂
    assert abs(fit.ev_b - 0.025) < 3 * fit.se_b + 0.025 * 3 * fit.se_mu / 0.25


def test_shipped_example_fits():
    from importlib.resources import files
    import snakesim.configs
    path = files(snakesim.configs) / "friction" / "hard-ice-drag-tests.csv"
    fit = fit_friction(read_drag_tests(path))
    assert fit.mu == pytest.approx(0.25, abs=3 * fit.se_mu)
    assert fit.ev_b > 0


@pytest.mark.parametrize("header,rows,match", [
    ("normal_force,drag_force\n", ["10,1\n"], r"tests.csv:2: missing column\(s\) 'direction'"),
    (HEADER, ["10,parallel,2.5\n", "20,normal,abc\n"], r"tests.csv:4: column 'drag_force': 'abc' is not a number"),
    (HEADER, ["ten,parallel,2.5\n"], r"tests.csv:3: column 'normal_force': 'ten' is not a number"),
    (HEADER, ["10,parallel,2.5\n", "20,sideways,3\n"], r"tests.csv:4: column 'direction': 'sideways' is not one of parallel, normal"),
    (HEADER, ["-5,parallel,2.5\n"], r"tests.csv:3: column 'normal_force': '-5' must be > 0"),
    (HEADER, ["10,parallel,2.5\n", "10,normal,5\n", "20,normal,9\n"], r"too few points to fit: 1 'parallel'.*2 'normal'"),
    (HEADER, ["10,parallel,2.5\n"] + ["10,normal,5\n"] * 3, r"too few points to fit: all 'normal' tests have the same"),
])
def test_bad_csv_errors_name_file_line_column_value(tmp_path, header, rows, match):
    p = write(tmp_path, rows, header=header)
    with pytest.raises(FrictionDataError, match=match):
        read_drag_tests(p)
    # the CLI turns it into a clean message, no traceback
    res = CliRunner().invoke(fit_cmd, [str(p)])
    assert res.exit_code != 0 and "Traceback" not in res.output and "tests.csv" in res.output


def test_missing_file_error(tmp_path):
    res = CliRunner().invoke(fit_cmd, [str(tmp_path / "nope.csv")])
    assert res.exit_code != 0 and "nope.csv" in res.output


def test_cli_writes_snippet_and_plot(tmp_path):
    data = write(tmp_path, synth(0.25, 1.8, 0.025), name="hard-ice-drag-tests.csv")
    out, png = tmp_path / "mat.yaml", tmp_path / "fit.png"
    res = CliRunner().invoke(fit_cmd, [str(data), "--out", str(out), "--plot", str(png)])
    assert res.exit_code == 0, res.output
    assert "mu   = 0.25" in res.output and "residuals" in res.output
    snippet = yaml.safe_load(out.read_text())
    assert set(snippet["materials"]) == {"hard_ice"}
    m = snippet["materials"]["hard_ice"]
    assert m["mu"] == pytest.approx(0.25) and m["ev_a"] == pytest.approx(1.8) and m["ev_b"] == pytest.approx(0.025)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_hook_adds_command():
    import click

    @click.group()
    def cli():
        pass

    snakesim_add_commands(cli)
    assert cli.commands["fit-friction"] is fit_cmd
