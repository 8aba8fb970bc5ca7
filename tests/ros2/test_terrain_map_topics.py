"""``--terrain-map`` on ROS 2 and in the run folder: the OccupancyGrid and GridMap a run records to MCAP, read back
with mcap-ros2-support's decoder (from the file's own schemas, not snakesim's types), put the obstacle course's
block and corridor where the terrain file has them; the slope layer of a tilted plane is its angle to the
component's documented bound; terrain_map.npz and .png agree with the last messages."""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest
from click.testing import CliRunner

from snakesim.framework.cli import cli, install_plugin_cli

pytest.importorskip("mcap")
pytest.importorskip("mcap_ros2")

RES = 0.1
#: terrains/obstacle-course.yaml's second block: centre, full size, yaw (it rests on the ice)
BLOCK = ((2.4, -0.8, 0.2), (0.5, 0.4, 0.4), -0.5)

SCENE = """
sim: {duration: %(duration)s, dt: 0.01, record_rate: 10}
components:
  terrain: {type: terrain, params: {name: %(terrain)s}}
  robot: {type: multibody, params: {design: eels-1.0, modules: 2, gravity: [0, 0, 0],
                                    base_position: [%(x)s, 0.0, 0.3]}}
"""


def _scene(tmp_path, terrain, x, duration):
    path = tmp_path / "scene.yaml"
    path.write_text(textwrap.dedent(SCENE % {"terrain": terrain, "x": x, "duration": duration}))
    return path


def _maps(path) -> dict:
    """topic -> [(log_time ns, decoded message, channel metadata)], decoded from the file's schemas."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    got: dict = {}
    with open(path, "rb") as f:
        for _s, ch, msg, dec in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                topics=["/terrain_map/costmap", "/terrain_map/elevation"]):
            got.setdefault(ch.topic, []).append((msg.log_time, dec, ch.metadata))
    return got


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


def _layer(gm, name) -> np.ndarray:
    """A GridMap layer back as [row +y, column +x], from grid_map's storage as its layout says it."""
    k = list(gm.layers).index(name)
    arr = gm.data[k]
    assert [d.label for d in arr.layout.dim] == ["column_index", "row_index"]
    cols, rows = arr.layout.dim[0].size, arr.layout.dim[1].size
    m = np.asarray(arr.data, dtype=float).reshape(cols, rows).T      # column-major: M[i, j], i along -x, j along -y
    return m.T[::-1, ::-1]


def _centres(origin, n):
    c = (np.arange(n) + 0.5) * RES
    return np.meshgrid(origin[0] + c, origin[1] + c)                    # [row, col]: row y, col x


def _in_block(x, y, shrink=0.0):
    (cx, cy, _cz), (sx, sy, _sz), yaw = BLOCK
    dx, dy = x - cx, y - cy
    u = math.cos(yaw) * dx + math.sin(yaw) * dy                           # block frame
    v = -math.sin(yaw) * dx + math.cos(yaw) * dy
    return (np.abs(u) < sx / 2 - shrink) & (np.abs(v) < sy / 2 - shrink)


@pytest.mark.slow
def test_course_maps_in_the_mcap_and_the_run_folder(dds_domain, tmp_path):
    rate, extent = 5.0, 6.0
    scene = _scene(tmp_path, "obstacle-course", 3.0, 0.65)
    bag, out, domain = tmp_path / "run.mcap", tmp_path / "out", dds_domain()
    install_plugin_cli()
    # a subscriber on the wire that asks for the latched QoS (DDS matches it only with a writer offering it)
    from snakesim.components.ros2.map_messages import occupancy_grid_type
    from snakesim.components.ros2.terrain_map_attach import MAP_QOS
    from snakesim.components.ros2.transport import Ros2Participant

    dds = Ros2Participant(domain)
    try:
        reader = dds.reader("/terrain_map/costmap", occupancy_grid_type(), MAP_QOS)
        r = CliRunner().invoke(cli, ["run", str(scene), "--terrain-map", "--terrain-map-extent", str(extent),
                                     "--terrain-map-rate", str(rate), "--ros2-mcap", str(bag),
                                     "--ros2-domain", str(domain), "--out", str(out), "--quiet"],
                               catch_exceptions=False)
        assert r.exit_code == 0, r.output
        on_wire = reader.take(N=100)
    finally:
        dds.close()
    got = _maps(bag)
    grids, gmaps = got["/terrain_map/costmap"], got["/terrain_map/elevation"]
    # one message per sample, logged and stamped at the sample's time k / rate (from t = 0)
    stamps = [log for log, _m, _md in grids]
    assert len(stamps) >= 3 and stamps == [round(k / rate * 1e9) for k in range(len(stamps))]
    assert [log for log, _m, _md in gmaps] == stamps
    assert all(_stamp(m) == log and m.info.map_load_time == m.header.stamp for log, m, _md in grids)
    # latched: reliable (1), transient local (1), keep last 1
    qos = grids[0][2]["offered_qos_profiles"]
    assert "depth: 1\n" in qos and "reliability: 1\n" in qos and "durability: 1\n" in qos
    _log, grid, _md = grids[-1]
    n = round(extent / RES)
    assert (grid.header.frame_id, grid.info.width, grid.info.height) == ("world", n, n)
    assert grid.info.resolution == pytest.approx(RES, rel=1e-7)                  # float32 in the message
    # the map is centred on the root link (at rest at x = 3, y = 0), its corner snapped to the resolution
    o = grid.info.origin
    assert (o.position.x, o.position.y, o.position.z) == pytest.approx((0.0, -3.0, 0.0), abs=1e-9)
    assert (o.orientation.x, o.orientation.y, o.orientation.z, o.orientation.w) == (0.0, 0.0, 0.0, 1.0)
    cost = np.asarray(grid.data, dtype=np.int8).reshape(n, n)                   # row-major, rows along +y
    # what the wire carried (keep last 1: at least the last map) is what the file holds
    assert on_wire and _stamp(on_wire[-1]) == stamps[-1]
    np.testing.assert_array_equal(np.asarray(on_wire[-1].data, dtype=np.int8).reshape(n, n), cost)
    x, y = _centres((o.position.x, o.position.y), n)
    # the block: its top at 0.4 m (from the GridMap, safe-step bound 1e-4 m), lethal along its rim
    _log, gm, _md = gmaps[-1]
    assert gm.header.frame_id == "world" and list(gm.layers) == ["elevation", "slope"]
    assert gm.info.length_x == gm.info.length_y == pytest.approx(n * RES)
    assert (gm.info.pose.position.x, gm.info.pose.position.y) == pytest.approx((3.0, 0.0), abs=1e-9)
    elevation = _layer(gm, "elevation")
    inside = _in_block(x, y)
    assert inside.sum() > 10
    np.testing.assert_allclose(elevation[inside], 0.4, atol=1e-4 + 1e-6)
    # a cell inside with an 8-neighbour on the ice (outside the block grown by the footprint's rounding): a 0.4 m
    # step, above max_step = 0.1: lethal
    rim = inside & ~_in_block(x, y, shrink=RES * math.sqrt(2))
    assert rim.sum() > 8 and (cost[rim] == 100).all()
    # the corridor |y| < 0.4 m is clear (one cell kept from its edges): flat ice, free
    corridor = np.abs(y) < 0.3
    assert (cost[corridor] == 0).all()
    np.testing.assert_allclose(elevation[corridor], 0.0, atol=1e-4 + 1e-6)
    # the run folder: the latest sample, as the last messages carry it
    from snakesim.components.sensors.terrain_map_files import load_terrain_map

    saved = load_terrain_map(out / "terrain_map.npz")
    assert float(saved["t"]) * 1e9 == pytest.approx(stamps[-1], abs=1)
    np.testing.assert_array_equal(saved["cost"], cost)
    np.testing.assert_allclose(saved["elevation"], elevation, rtol=1e-6, equal_nan=True)   # float32 on the wire
    np.testing.assert_allclose(saved["origin"], [0.0, -3.0, 0.0], atol=1e-12)
    assert float(saved["resolution"]) == RES and saved["link"] == "tail"
    np.testing.assert_allclose(saved["path"][0], [3.0, 0.0, 0.3], atol=1e-9)
    png = (out / "terrain_map.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


def _record_only(scene, bag, extent):
    """A session with the terrain map and its MCAP recorder only (the DDS sinks --ros2 adds left out)."""
    from snakesim.components.ros2.terrain_map_attach import attach_terrain_map_mcap
    from snakesim.components.sensors.terrain_map_cli import attach_terrain_map
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry
    from snakesim.framework.session import Session

    reg = default_registry()
    resolved = resolve(str(scene), search_path=reg.assembly_paths())
    attach_terrain_map(resolved, params={"extent": extent, "resolution": RES, "tolerance": 1e-5}, rate=10.0,
                       registry=reg)
    rec = attach_terrain_map_mcap(resolved, str(bag), reg)
    drop = [n for n in resolved.components if resolved.where.get(n) == "--ros2"]
    for name in drop:
        del resolved.components[name]
    resolved.connections[:] = [c for c in resolved.connections if c[1].split(".", 1)[0] not in drop]
    return Session(resolved, reg), rec


def test_slope_layer_of_a_tilted_plane_is_its_angle(tmp_path):
    """terrains/tilted-plane-20deg: the slope layer is 20° everywhere; the elevation lies above the plane by at
    most tolerance / cos θ (the component's bound), so a one-sided difference is off by at most
    tolerance / (cos θ · resolution) in gradient and, atan being 1-Lipschitz, in slope."""
    theta, tol = math.radians(20.0), 1e-5
    bag = tmp_path / "plane.mcap"
    s, _rec = _record_only(_scene(tmp_path, "tilted-plane-20deg", 0.0, 0.25), bag, 2.0)
    s.run()
    got = _maps(bag)
    _log, gm, _md = got["/terrain_map/elevation"][-1]
    slope, elevation = _layer(gm, "slope"), _layer(gm, "elevation")
    assert slope.shape == (20, 20) and np.isfinite(slope).all()
    np.testing.assert_allclose(slope, theta, atol=tol / (math.cos(theta) * RES) + 1e-6)   # + float32
    x, _y = _centres((gm.info.pose.position.x - 1.0, gm.info.pose.position.y - 1.0), 20)
    err = elevation - math.tan(theta) * x
    assert err.min() >= -1e-6 and err.max() <= tol / math.cos(theta) + 1e-6
    cost = np.asarray(got["/terrain_map/costmap"][-1][1].data).reshape(20, 20)
    assert (cost == round(100 * theta / 0.5)).all()     # 100 · slope / max_slope (default 0.5 rad): 70
