"""``--lidar-rate`` / ``--stereo-rate``: the head sensors' rates (defaults 10 Hz and 5 Hz); a rate that
is not a positive number is an error naming the option and what is valid."""

from __future__ import annotations

import pytest

from snakesim.components.perception.attach import CAMERA_RATE, LIDAR_RATE, attach_lidar, attach_stereo
from snakesim.framework import ConfigError
from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry


def scene():
    reg = default_registry()
    return resolve("surface-screw-traverse", search_path=reg.assembly_paths()), reg


def test_rates_default_and_given():
    r, reg = scene()
    attach_lidar(r, "spinning-32", reg)
    attach_stereo(r, "64x48", reg, rate=10)
    assert r.components["lidar"].rate == LIDAR_RATE and r.components["stereo"].rate == 10.0
    r, reg = scene()
    attach_lidar(r, "spinning-32", reg, rate=20)
    attach_stereo(r, "64x48", reg)
    assert r.components["lidar"].rate == 20.0 and r.components["stereo"].rate == CAMERA_RATE


@pytest.mark.parametrize("attach, option, rate", [(attach_stereo, "--stereo-rate", 0),
                                                  (attach_lidar, "--lidar-rate", -5.0),
                                                  (attach_stereo, "--stereo-rate", float("inf"))])
def test_a_bad_rate_is_named(attach, option, rate):
    r, reg = scene()
    with pytest.raises(ConfigError, match=f"{option}.*not a rate; give a positive number of Hz"):
        attach(r, "spinning-32" if attach is attach_lidar else "64x48", reg, rate=rate)
