"""Tests of the demo plugin, without installing it.

The component alone, with snakesim's Harness (fix inputs, read outputs and
the derivative), then its scene run in-process with the plugin module
registered by hand, as its entry point would register it once installed.
tests/packaging/test_plugin.py covers the installed plugin end to end.
"""

import numpy as np
import pytest
from pydantic import ValidationError

from snakesim.framework import Harness
from snakesim.framework.registry import Registry, make_plugin_manager
from snakesim.framework.session import load_session
from snakesim_demo_plugin import lowpass
from snakesim_demo_plugin.lowpass import LowPass


def test_derivative_is_error_over_tau():
    h = Harness(LowPass, {"tau": 0.5, "n": 3, "y0": [0.0, 1.0, 2.0]})
    h.inputs.u = [1.0, 1.0, 1.0]
    np.testing.assert_allclose(h.derivative(), [2.0, 0.0, -2.0])


def test_output_is_state_only():
    h = Harness(LowPass, {"y0": 0.25})
    h.inputs.u = 100.0                   # no feedthrough: the input does not reach y
    assert h.outputs()["y"] == pytest.approx([0.25])
    assert LowPass.outputs["y"].feedthrough_inputs(list(LowPass.inputs)) == ()


def test_bad_params_are_rejected():
    with pytest.raises(ValidationError):
        LowPass("f", {"tau": 0.0})
    with pytest.raises(ValidationError):
        LowPass("f", {"n": 2, "y0": [1.0, 2.0, 3.0]})


def registry_with_plugin() -> Registry:
    """Built-ins plus this plugin, set up exactly as an installed entry point would be."""
    pm = make_plugin_manager(load_entry_points=False)
    pm.register(lowpass, name="snakesim_demo_plugin")
    reg = Registry(pm)
    pm.hook.snakesim_register_components(registry=reg)
    pm.hook.snakesim_register_integrators(registry=reg)
    return reg


def test_step_response_scene():
    session = load_session("lowpass-step", overrides=["tau=0.2"], registry=registry_with_plugin())
    log = session.run().log
    t, y = log["t"], log["filter.y"][:, 0]
    np.testing.assert_allclose(y, 1.0 - np.exp(-t / 0.2), atol=1e-8)
