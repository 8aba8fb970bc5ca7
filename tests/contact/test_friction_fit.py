"""fig. 6 fit: recovery of known μ, a, b; CSV validation errors; the CLI."""

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from snakesim.components.contact.friction_fit import FrictionDataError, _yaml_float, fit_friction, read_drag_tests
from snakesim.components.materials import Material, read_material_file
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


def test_cli_writes_material_file_and_plot(tmp_path):
    data = write(tmp_path, synth(0.25, 1.8, 0.025), name="hard-ice-drag-tests.csv")
    out, png = tmp_path / "mat.yaml", tmp_path / "fit.png"
    res = CliRunner().invoke(fit_cmd, [str(data), "--out", str(out), "--plot", str(png), "--k", "2e5", "--c", "500"])
    assert res.exit_code == 0, res.output
    assert "mu   = 0.25" in res.output and "residuals" in res.output
    text = out.read_text()
    assert "# k: not measured by the drag tests; given with --k" in text
    assert "# c: not measured by the drag tests; given with --c" in text
    assert "{include: mat.yaml}" in text
    raw = yaml.safe_load(text)          # plain YAML too, every number a float
    assert [m["name"] for m in raw["materials"]] == ["hard_ice"]
    (m,) = read_material_file(out)
    assert (m.name, m.k, m.c) == ("hard_ice", 2e5, 500.0)
    assert m.mu == pytest.approx(0.25, rel=1e-13) and m.ev_a == pytest.approx(1.8, rel=1e-12)
    assert m.ev_b == pytest.approx(0.025, rel=1e-12)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_k_and_c_from_a_base_material_or_the_defaults(tmp_path):
    data = write(tmp_path, synth(0.25, 1.8, 0.025), name="ice-drag-tests.csv")
    out = tmp_path / "ice.yaml"
    res = CliRunner().invoke(fit_cmd, [str(data), "--out", str(out), "--base", "u-channel:dirty-ice", "--c", "7"])
    assert res.exit_code == 0, res.output
    (m,) = read_material_file(out)
    assert (m.name, m.k, m.c) == ("ice", 1.5e5, 7.0)                   # u-channel's dirty-ice k, --c
    assert "# k: not measured by the drag tests; from material 'dirty-ice' of terrain u-channel (--base)" in out.read_text()
    res = CliRunner().invoke(fit_cmd, [str(data), "--out", str(out)])
    assert res.exit_code == 0, res.output
    (m,) = read_material_file(out)
    assert (m.k, m.c) == (Material().k, Material().c)
    assert "snakesim's default Material value" in out.read_text()
    res = CliRunner().invoke(fit_cmd, [str(data), "--out", str(out), "--base", "u-channel:granite"])
    assert res.exit_code != 0 and "no material 'granite'" in res.output and "ice, dirty-ice" in res.output
    res = CliRunner().invoke(fit_cmd, [str(data), "--out", str(out), "--k", "-3"])
    assert res.exit_code != 0 and "Traceback" not in res.output
    assert "material 'ice': k = -3 N/m must be > 0" in res.output


def test_small_numbers_stay_floats_in_plain_yaml():
    assert _yaml_float(1e-05) == "1.0e-05" and yaml.safe_load(_yaml_float(1e-05)) == 1e-05
    assert _yaml_float(2.5e-05) == "2.5e-05" and _yaml_float(0.25) == "0.25" and _yaml_float(-1e20) == "-1.0e+20"
    assert yaml.safe_load(_yaml_float(-1e20)) == -1e20


def test_hook_adds_command():
    import click

    @click.group()
    def cli():
        pass

    snakesim_add_commands(cli)
    assert cli.commands["fit-friction"] is fit_cmd
