"""Placement attraction springs (paper fig. 9) drawn under world/debug/attraction.

The u-channel floor is a half-round of radius R = 0.2 m about the line y = 0, z = 0.2 m
(terrains/u-channel.yaml). A sample point p below that line at distance ρ from it is
φ = R − ρ inside the free space, so its spring pulls k φ straight away from the line:
the arrow from p is force_scale · k (R − ρ) · (p − axis)/ρ, and there is none once the
settle has latched.
"""

import numpy as np
import pytest

from snakesim.components.placement import SettlePhase
from snakesim.components.viz import entities as E
from snakesim.components.viz.attach import attach_viewer
from snakesim.components.viz.target import VizTarget
from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry

SCENE = "placement-u-channel"
K = 5000.0              # N/m, placement-scene.yaml's k_attract
SCALE = 0.002           # m per N, the sink's default force_scale
R, AXIS_Z = 0.2, 0.2    # m, the U's floor radius and axis height
P = "placement-scene/"


@pytest.fixture(scope="module")
def placed(tmp_path_factory):
    """One placement run into the U-channel, saved with --viz save: settles (~0.4 s) and latches."""
    from click.testing import CliRunner

    from snakesim.framework.cli import cli, install_plugin_cli

    install_plugin_cli()
    out = tmp_path_factory.mktemp("attraction") / "placement.rrd"
    res = CliRunner().invoke(cli, ["run", SCENE, "--duration", "0.8", "--quiet", "--viz", "save", str(out)],
                             catch_exceptions=False)
    assert res.exit_code == 0, res.output
    return out


def test_attraction_arrows_pull_the_screws_onto_the_floor_then_vanish_at_the_latch(placed, read_rrd):
    rec = read_rrd(placed)
    assert "/" + E.ATTRACTION in rec.entities and not E.is_physical(E.ATTRACTION)
    assert {"Arrows3D:colors", "Arrows3D:radii"} <= rec.static_columns("/" + E.ATTRACTION)
    t, vec = rec.columns("/" + E.ATTRACTION, "Arrows3D:vectors")
    _, org = rec.columns("/" + E.ATTRACTION, "Arrows3D:origins")
    tp, phase = rec.columns("/" + E.series_path(P + "settle.phase"), "Scalars:scalars")
    phase = np.interp(t, tp, np.ravel(phase))
    settling = phase < SettlePhase.SETTLING + 0.5              # interpolated to the arrow frames
    assert settling.any() and (~settling).any(), "the run should cover settling and the latch"
    pulled = 0
    for a, o, s in zip(vec, org, settling):
        a, o = np.reshape(a, (-1, 3)), np.reshape(o, (-1, 3))
        assert len(a) == len(o)
        if not s:
            assert len(a) == 0                         # latched: the springs are gone
            continue
        pulled += len(a)
        radial = (o - [0.0, 0.0, AXIS_Z]) * [0.0, 1.0, 1.0]            # from the floor's axis (along x)
        rho = np.linalg.norm(radial, axis=1)
        assert np.all(o[:, 2] < AXIS_Z) and np.all(rho < R)          # pulled points lie inside the U's floor
        expected = SCALE * K * (R - rho)[:, None] * radial / rho[:, None]
        # float32 in the recording; first-order SDF exact on a cylinder
        np.testing.assert_allclose(a, expected, atol=1e-5 + 1e-5 * np.abs(expected).max())
    assert pulled > 0, "no attraction arrows while settling"
    # the straight guess starts a few mm above the floor: the first frame pulls every screw
    assert len(np.reshape(vec[0], (-1, 3))) == 4


def test_attraction_is_found_by_its_type_before_the_contacts_rule(tmp_path):
    reg = default_registry()
    r = resolve(SCENE, search_path=reg.assembly_paths(), sim_overrides={"duration": 0.01})
    # settle listed first: its AttractionSet has points and forces too, yet must not be taken for contacts
    first = P + "settle"
    r.components = {first: r.components[first], **{k: v for k, v in r.components.items() if k != first}}
    found = attach_viewer(r, VizTarget("save", str(tmp_path / "a.rrd")), reg)
    assert found.attraction == first and found.contacts == P + "contact"
    wired = {(s, d) for s, d, _ in r.connections}
    assert (first + ".attraction", "viz.attraction") in wired and (P + "contact.contact_set", "viz.contacts") in wired
