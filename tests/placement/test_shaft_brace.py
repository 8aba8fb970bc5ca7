"""The shaft_brace shape kind and the scan scene (components/placement/shaft_brace.py,
assemblies/scan-moulin-brace-down.yaml; issue 30).

Fast: the kind is registered (placed_multibody validates it by kind, unknown kinds list it), a shaft too wide
for the brace fails naming the depth, the width measured and what the brace spans.
Slow (the scene): the placement is a static equilibrium the contact model agrees with (each bracing screw's
load at t = 0 is the placement's N_k, reached by pressing it N_k/k into the wall), the robot holds >= 10 s
within the evaluation's 5 mm, descends >= 1 m, no body sinks into a wall deeper than the largest bracing load
would press it (per-sample springs: depth <= N_max/k), summary.json carries the evaluation; two short runs
are bit-identical.
"""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.contact.body_samples import BodySampleOptions, body_samples
from snakesim.components.multibody.pose_quaternions import rotation_matrices
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.placement import PlacementError, Shape, ShaftBrace
from snakesim.components.placement.placed_multibody import PlacedMultibodyParams
from snakesim.components.placement.shaft_brace import place_in_shaft
from snakesim.components.terrain import load_terrain
from snakesim.framework.session import load_session

SCENE = "scan-moulin-brace-down"
BRACE = {0: 1, 2: -1, 3: 1}


def test_shape_kind_is_registered():
    p = PlacedMultibodyParams(design="eels-1.5", modules=4,
                              shape={"kind": "shaft_brace", "terrain": "moulin-slot", "depth": 3.0, "xy": [0, 0],
                                     "brace": {"screws": BRACE}})
    assert isinstance(p.shape, ShaftBrace) and p.shape.brace.screws == BRACE
    assert isinstance(PlacedMultibodyParams(design="eels-1.5", modules=4, shape={"kind": "straight"}).shape, Shape)
    with pytest.raises(ValueError, match="valid kinds are .*shaft_brace"):
        PlacedMultibodyParams(design="eels-1.5", modules=4, shape={"kind": "spiral"})
    with pytest.raises(ValueError, match="screws"):
        ShaftBrace(terrain="moulin-slot", depth=3.0, xy=(0, 0), brace={"screws": {0: 2}})


def test_too_wide_a_shaft_names_depth_width_and_span(tmp_path):
    wide = tmp_path / "wide.yaml"
    wide.write_text("kind: parallel_walls\ngap: 0.6\nmaterials:\n  - {name: ice, k: 1.0e5, c: 1.0e3, mu: 1.5}\n")
    spec = ShaftBrace(terrain=str(wide), depth=1.0, xy=(0.0, 0.0), brace={"screws": BRACE, "starts": 2})
    with pytest.raises(PlacementError, match=r"depth 1 m.*width measured 0\.6000 m.*short of their walls.*spans about"):
        place_in_shaft(RobotModel.load(design="eels-1.5", modules=4), spec)


@pytest.fixture(scope="module")
def scene():
    s = load_session(SCENE)
    r = s.run()
    return s, r


@pytest.mark.slow
def test_placed_state_is_the_contacts_equilibrium(scene):
    s, r = scene
    robot = s.plan.components["robot"]
    pl = place_in_shaft(robot.robot, robot.p.shape)
    assert sum(pl.loads.values()) == pytest.approx(robot.p.shape.preload, rel=1e-6)
    F0 = r["contact.screw_normal_force"][0]
    for k, n in pl.loads.items():                     # the screw contact's k·depth at the placed state
        assert F0[k] == pytest.approx(n, rel=0.1), (k, F0[k], n)
    assert F0[1] == 0.0                               # the free screw clear of both walls
    # static from the first step: the tail's height moves by less than the hold band over the first 2 s
    z = r["robot.link_poses"][:, 2]
    assert np.ptp(z[r["t"] <= 2.0]) < 0.005
    # the controller holds the same placement: base shape, torque pattern, the loads along the surveyed normal
    brace = s.plan.components["brace"].p
    np.testing.assert_allclose(brace.base, pl.q)
    assert brace.torque_pattern == pl.torque_pattern(robot.robot)
    assert brace.load_screws == [0, 2, 3] and brace.climb_signs["screw_front_02"] == -1.0
    np.testing.assert_allclose(s.plan.components["wall_loads"].p.normal, pl.survey.normal)


@pytest.mark.slow
def test_holds_then_descends_a_metre_without_a_body_in_a_wall(scene):
    s, r = scene
    ev = r.summary["reports"]["evaluation"]
    assert ev["contact"]["made"] and ev["hold"]["achieved"] and ev["hold"]["longest_s"] >= 10.0
    assert ev["vertical_distance"]["down_m"] >= 1.0
    assert not ev["failure"]["failed"]
    placed = s.plan.components["robot"]
    robot, terrain = placed.robot, load_terrain(placed.p.shape.terrain)
    k = terrain.materials[0].k
    # no link through a wall: a body pressed on a wall as hard as the most loaded bracing screw (N_max) would
    # sink N_max/k at one sample (per-sample springs F = k d); every non-screw link's deepest body sample over
    # the run stays within that (+ 0.5 mm: the record's sampling), where a link through a wall is cm deep
    N_max = max(place_in_shaft(robot, placed.p.shape).loads.values())
    S = body_samples(robot, BodySampleOptions())
    link = np.repeat(S.piece_link, np.diff(S.start))
    poses = r["robot.link_poses"][::5].reshape(-1, robot.nl, 7)
    depth = np.zeros(robot.nl)
    for P in poses:
        world = P[link, :3] + np.einsum("nij,nj->ni", rotation_matrices(P[link, 3:]), S.points)
        np.maximum.at(depth, link, -terrain.distance(world))
    for row in np.unique(link):
        assert depth[row] <= N_max / k + 5e-4, (robot.links[row], depth[row], N_max / k)
    assert r.summary["reports"]["clearance"]["inside"] == {}


@pytest.mark.slow
def test_deterministic():
    a = load_session(SCENE, sim_overrides={"duration": 0.3}).run()
    b = load_session(SCENE, sim_overrides={"duration": 0.3}).run()
    for key in ("robot.link_poses", "contact.screw_normal_force", "pid.tau", "brace.amplitude"):
        assert np.array_equal(a[key], b[key]), key
