"""A short run saved with --viz and read back with rerun's own reader; replay of its --out folder."""

import math

import numpy as np
import pytest

from viz_scenes import SCENE

from snakesim.components.viz import entities as E
from snakesim.components.viz.attach import viewer_period
from snakesim.components.multibody.robot_model import RobotModel

DT, DURATION = 0.001, 0.2
PERIOD = viewer_period(DT, [])                  # 33 steps: 30.3 Hz
SETS = ["--set", "robot.modules=2", "--duration", DURATION, "--quiet"]


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    """One run of the moulin scene with --viz save and --out (shared by the tests below)."""
    from click.testing import CliRunner

    from snakesim.framework.cli import cli, install_plugin_cli

    install_plugin_cli()
    d = tmp_path_factory.mktemp("live")
    res = CliRunner().invoke(cli, ["run", str(SCENE), *map(str, SETS), "--viz", "save", str(d / "live.rrd"),
                                   "--out", str(d / "out")], catch_exceptions=False)
    assert res.exit_code == 0, res.output
    (d / "terminal.txt").write_text(res.output)
    return d


def test_save_says_what_it_wrote(live):
    """`--viz save FILE` names the file it wrote and how to open it (it used to be silent)."""
    rrd = live / "live.rrd"
    assert rrd.stat().st_size > 0
    assert f"wrote {rrd}" in (live / "terminal.txt").read_text()


def _links():
    return RobotModel.load(design="eels-1.0", modules=2, head=True).links


def _links_with_visuals():
    import xml.etree.ElementTree as ET

    from snakesim.robots import load_robot

    root = ET.fromstring(load_robot("eels-1.0", modules=2, head=True).urdf)
    return [ln.get("name") for ln in root.findall("link") if ln.find("visual") is not None]


def test_rrd_has_robot_terrain_tether_and_series(live, read_rrd):
    rec = read_rrd(live / "live.rrd")
    assert [s.application_id for s in rec.stores] == ["snakesim"]
    ents = rec.entities
    meshed = {e.rsplit("/", 1)[0] for e in ents if e.endswith("/visual")}
    # every URDF link with a visual has a static mesh under its transform (sensor frames have none)
    assert meshed == {"/" + E.link_path("robot", n) for n in _links_with_visuals()}
    assert len(meshed) < len(_links())
    for link in meshed:
        assert {"Mesh3D:vertex_positions", "Mesh3D:triangle_indices"} <= rec.static_columns(link + "/visual")
    assert "Mesh3D:vertex_positions" in rec.static_columns("/" + E.TERRAIN)
    for signal in ("robot.link_poses", "robot.joint_q", "robot.q", "tether.tension"):
        assert "/" + E.series_path(signal) in ents
    assert "/" + E.TETHERS in ents and "/" + E.REAL_TIME_FACTOR in ents
    # physical vs ornamental: nothing but plots outside world/physical in this scene (no contacts, no frames)
    assert all(E.is_physical(e) or e.startswith("/plots/") or e == "/world" for e in ents)


def test_frames_cover_the_run_at_the_viewer_rate(live, read_rrd):
    rec = read_rrd(live / "live.rrd")
    n_frames = int(DURATION / (PERIOD * DT) + 1e-9) + 1          # t = 0, P·dt, ... <= duration
    expected = np.arange(n_frames) * PERIOD * DT
    for entity in ("/" + E.link_path("robot", "tail"), "/" + E.series_path("robot.joint_q"), "/" + E.TETHERS):
        times, _ = rec.columns(entity, "Transform3D:translation" if "physical/robot" in entity else
                               "Scalars:scalars" if entity.startswith("/plots") else "LineStrips3D:strips")
        np.testing.assert_allclose(times, expected, atol=1e-9)


def test_link_transforms_are_the_multibody_link_poses(live, read_rrd):
    """Each link entity carries its own row of link_poses (the same numbers signals.csv recorded)."""
    rec = read_rrd(live / "live.rrd")
    cols = (live / "out" / "signals.csv").read_text().splitlines()[0].split(",")
    data = np.loadtxt(live / "out" / "signals.csv", delimiter=",", skiprows=1)
    for link in ("tail", "module_01", "head"):
        t, tr = rec.columns("/" + E.link_path("robot", link), "Transform3D:translation")
        _, q = rec.columns("/" + E.link_path("robot", link), "Transform3D:quaternion")
        rows = np.rint(t / DT).astype(int)
        xyz = data[rows][:, [cols.index(f"robot.link_poses.{link}.{c}") for c in ("x", "y", "z")]]
        quat = data[rows][:, [cols.index(f"robot.link_poses.{link}.{c}") for c in ("qx", "qy", "qz", "qw")]]
        # stored as float32 by rerun: 1e-6 relative
        np.testing.assert_allclose(np.array(tr)[:, 0], xyz, atol=1e-6 * (1 + np.abs(xyz).max()))
        np.testing.assert_allclose(np.array(q)[:, 0], quat, atol=1e-6)


def test_tether_line_runs_from_the_tail_to_the_anchor(live, read_rrd):
    rec = read_rrd(live / "live.rrd")
    _, strips = rec.columns("/" + E.TETHERS, "LineStrips3D:strips")
    _, tail = rec.columns("/" + E.link_path("robot", "tail"), "Transform3D:translation")
    for frame, origin in zip(strips, tail):
        tie, anchor = np.array(frame[0])
        np.testing.assert_allclose(tie, origin[0], atol=1e-5)           # offset (0, 0, 0): the tail origin
        np.testing.assert_allclose(anchor, [0.0, 0.0, 0.6], atol=1e-6)


def test_replay_of_the_out_folder_has_the_same_entities(live, read_rrd, cli_runner):
    res = cli_runner("replay", live / "out")
    assert res.exit_code == 0, res.output
    replayed = read_rrd(live / "out" / "replay.rrd")
    assert replayed.entities == read_rrd(live / "live.rrd").entities
    # every recorded row, not just the viewer's frames
    t, _ = replayed.columns("/" + E.link_path("robot", "head"), "Transform3D:translation")
    np.testing.assert_allclose(t, np.arange(round(DURATION / DT) + 1) * DT, atol=1e-9)
    t, v = replayed.columns("/" + E.series_path("robot.joint_q"), "Scalars:scalars")
    header = (live / "out" / "signals.csv").read_text().splitlines()[0].split(",")
    assert len(t) == round(DURATION / DT) + 1
    assert len(v[0]) == sum(c.startswith("robot.joint_q.") for c in header)    # one line per joint


def test_replay_computes_poses_from_q_when_link_poses_were_not_recorded(live):
    """Forward kinematics of the recorded q through the robot component reproduces the recorded poses."""
    from snakesim.components.viz.replay import _robot_poses, build_robot, load_run
    from snakesim.framework.registry import default_registry

    cfg, columns, data, _ = load_run(live / "out")
    params = cfg["components"]["robot"]["params"]
    comp = build_robot("robot", default_registry().component("multibody"), params)
    links = _links()
    assert comp.robot.links == links
    poses, t, note = _robot_poses(comp, columns, data, ["robot.q"])
    assert note is None and poses.shape == (len(data), len(links), 7)
    recorded, _, _ = _robot_poses(comp, columns, data, ["robot.link_poses"])
    np.testing.assert_allclose(poses, recorded, atol=1e-12)
    # neither recorded: the initial pose and a note saying what to record
    poses, t, note = _robot_poses(comp, columns, data, [])
    assert poses.shape == (1, len(links), 7) and "record" in note
    np.testing.assert_allclose(poses[0], recorded[0], atol=1e-12)


def test_replay_errors_name_the_folder_and_what_is_missing(tmp_path, cli_runner):
    res = cli_runner("replay", tmp_path / "nowhere")
    assert res.exit_code != 0 and "is not a folder" in res.output
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "signals.csv").write_text("t\n0\n")
    res = cli_runner("replay", tmp_path / "run")
    assert res.exit_code != 0 and "no config.yaml" in res.output and "--out" in res.output


def test_viewer_period_keeps_the_tick_pattern_short():
    assert viewer_period(0.001, []) == 33 and viewer_period(0.1, []) == 1
    # periods 128 and 27 steps: 33 would need lcm 38016 patterns; 32 keeps 3456 (<= 4096)
    n = viewer_period(0.001, [1 / (128 * 0.001), 1 / (27 * 0.001)])
    assert n == 32 and math.lcm(n, 128, 27) <= 4096
