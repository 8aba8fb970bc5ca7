"""Contacts from any structured port of type ContactSet (matched by type, whatever the port's name):
split into normal and friction arrows."""

import numpy as np

from viz_scenes import SCENE

from snakesim.components.contact import ContactSet
from snakesim.components.viz import entities as E
from snakesim.components.viz.attach import attach_viewer
from snakesim.components.viz.target import VizTarget
from snakesim.framework import Component, Output
from snakesim.framework.assembly import ComponentSpec, resolve
from snakesim.framework.registry import build_registry
from snakesim.framework.session import Session


N_AT = lambda t: int(t * 100) % 3          # noqa: E731  (0, 1 or 2 contacts: sizes change frame to frame)


class FakeContacts(Component):
    """k = N_AT(t) contacts at (i, 0, 0), normal +z, F = (3, 0, 10) N: F_n = 10 N, friction (3, 0, 0) N."""

    type_name = "fake_contacts"
    touch = Output(type=ContactSet, feedthrough=())

    def output(self, t, x, u, y):
        k = N_AT(t)
        z3 = np.zeros((k, 3))
        y.touch = ContactSet(t, np.column_stack([np.arange(k), np.zeros(k), np.zeros(k)]).astype(float),
                             np.tile([0.0, 0.0, 1.0], (k, 1)), np.tile([3.0, 0.0, 10.0], (k, 1)), np.full(k, 10.0),
                             np.zeros(k), z3, np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64))


def test_contact_arrows_are_split_and_scaled(tmp_path, read_rrd):
    reg = build_registry()
    reg.add_component(FakeContacts)
    r = resolve(str(SCENE), search_path=reg.assembly_paths(), overrides=["robot.modules=2"],
                sim_overrides={"duration": 0.3})
    r.components["touch"] = ComponentSpec(type="fake_contacts")
    found = attach_viewer(r, VizTarget("save", str(tmp_path / "c.rrd")), reg, params={"force_scale": 0.01})
    assert found.contacts == "touch" and found.robot == "robot" and found.terrain == "terrain"
    Session(r, reg).run()
    rec = read_rrd(tmp_path / "c.rrd")
    t, pts = rec.columns("/" + E.CONTACT_POINTS, "Points3D:positions")
    _, fn = rec.columns("/" + E.CONTACT_NORMAL, "Arrows3D:vectors")
    _, ft = rec.columns("/" + E.CONTACT_FRICTION, "Arrows3D:vectors")
    assert len(t) == 10                               # every frame, empty ones too (they clear the last)
    for ti, p, a, b in zip(t, pts, fn, ft):
        k = N_AT(ti)
        assert len(p) == len(a) == len(b) == k
        np.testing.assert_allclose(np.reshape(a, (-1, 3)), np.tile([0.0, 0.0, 0.1], (k, 1)).reshape(-1, 3), atol=1e-7)
        np.testing.assert_allclose(np.reshape(b, (-1, 3)), np.tile([0.03, 0.0, 0.0], (k, 1)).reshape(-1, 3), atol=1e-7)
    assert all(not E.is_physical(e) for e in (E.CONTACT_POINTS, E.CONTACT_NORMAL, E.CONTACT_FRICTION))


def test_a_second_run_of_the_session_writes_a_fresh_recording(tmp_path, read_rrd):
    reg = build_registry()
    r = resolve("pendulum", search_path=reg.assembly_paths(), sim_overrides={"duration": 0.2})
    attach_viewer(r, VizTarget("save", str(tmp_path / "p.rrd")), reg)
    s = Session(r, reg)
    s.run()
    first = read_rrd(tmp_path / "p.rrd").columns("/plots/pend/theta", "Scalars:scalars")[0]
    s.run()
    again = read_rrd(tmp_path / "p.rrd").columns("/plots/pend/theta", "Scalars:scalars")[0]
    np.testing.assert_array_equal(first, again)     # replaced, not appended
