"""Memory (issue 13): `check` builds the unoptimised baselines only when asked, no Pinocchio Data for a
multibody on its link tree (forward dynamics and M without one: Data's nv³ tensors), at most one
per multibody otherwise, and the BLAS thread pinning of the entry point."""

from __future__ import annotations

import json

from click.testing import CliRunner

from snakesim.components.multibody import model as mb_model
from snakesim.framework.blas_threads import VARIABLES, pin_blas_threads
from snakesim.framework.cli import cli, install_plugin_cli


def _check(*args):
    install_plugin_cli()
    before = mb_model.DATA_MADE[0]
    res = CliRunner().invoke(cli, ["check", "robot-zero-g", "--modules", "3", "--json", *args])
    assert res.exit_code == 0, res.output
    return json.loads(res.output)["component_reports"]["robot"], mb_model.DATA_MADE[0] - before


def test_check_builds_no_baseline_unless_asked():
    rep, made = _check()
    assert made == 0                        # none: the multibody integrates on its link tree, no Data
    assert not rep["timed"] and "cost_us" not in rep
    assert rep["after"]["dof"] == 6 + 3 * 3


def test_check_baseline_builds_and_times_them():
    rep, made = _check("--baseline")
    # the robot's Data, the aba and crba baselines', and the optimised mimic_crba model timed against them
    assert made == 4
    assert rep["timed"] and set(rep["cost_us"]) == {"aba", "crba"}
    assert rep["cost_us"]["aba"]["unoptimised_dof"] > rep["cost_us"]["aba"]["optimised_dof"]


def test_check_text_says_how_to_get_the_timing():
    install_plugin_cli()
    res = CliRunner().invoke(cli, ["check", "robot-zero-g", "--modules", "2"])
    assert res.exit_code == 0, res.output
    assert "snakesim check --baseline" in res.output


def test_blas_threads_default_one_override_and_explicit_values_kept():
    env = {}
    assert pin_blas_threads(env) == "1" and all(env[v] == "1" for v in VARIABLES)
    env = {"SNAKESIM_BLAS_THREADS": "4", "OPENBLAS_NUM_THREADS": "2"}
    assert pin_blas_threads(env) == "4"
    assert env["OPENBLAS_NUM_THREADS"] == "2" and env["OMP_NUM_THREADS"] == "4"   # explicit one kept
    env = {"SNAKESIM_BLAS_THREADS": "auto"}
    assert pin_blas_threads(env) is None and set(env) == {"SNAKESIM_BLAS_THREADS"}
    try:
        pin_blas_threads({"SNAKESIM_BLAS_THREADS": "many"})
    except ValueError as e:
        assert "SNAKESIM_BLAS_THREADS" in str(e)
    else:
        raise AssertionError("a bad count must be refused")


def test_the_entry_point_pins_before_numpy_loads():
    import os
    import subprocess
    import sys
    code = ("import sys; from snakesim.framework.cli import main; sys.argv = ['snakesim', '--help']\n"
            "try:\n    main()\nexcept SystemExit:\n    pass\n"
            "import os; print(os.environ.get('OPENBLAS_NUM_THREADS'), os.environ.get('OMP_NUM_THREADS'))")
    env = {k: v for k, v in os.environ.items() if k not in VARIABLES and k != "SNAKESIM_BLAS_THREADS"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split()[-2:] == ["1", "1"]
