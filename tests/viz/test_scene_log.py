"""SceneLog batching: every link's transform column is its own row of the pose batch, whatever
the batch size, and a saved run is sent in batches of 2 s of frames."""

import math

import numpy as np

from viz_scenes import SCENE

from snakesim.components.viz import entities as E
from snakesim.components.viz.attach import attach_viewer
from snakesim.components.viz.robot_geometry import LinkMesh
from snakesim.components.viz.scene_log import SceneLog
from snakesim.components.viz.sink import SAVE_FLUSH_S
from snakesim.components.viz.target import VizTarget
from snakesim.framework.assembly import resolve
from snakesim.framework.registry import build_registry
from snakesim.framework.session import Session

LINKS = ("tail", "middle", "head")


def _pose(k: int, i: int) -> np.ndarray:
    """Frame k, link i: at (k, i, 0.5) m, turned 0.1·(k + 3i) rad about z (unit quaternion xyzw)."""
    a = 0.1 * (k + 3 * i)
    return np.array([k, i, 0.5, 0.0, 0.0, math.sin(a / 2), math.cos(a / 2)])


def _mesh(link: str) -> LinkMesh:
    tri = np.eye(3)
    return LinkMesh(link, tri, np.array([[0, 1, 2]]), np.tile([0.0, 0.0, 1.0], (3, 1)),
                    np.full((3, 4), 255, dtype=np.uint8))


def test_each_link_and_body_frame_gets_its_own_pose_row_across_batches(tmp_path, read_rrd):
    import rerun as rr

    rec = rr.RecordingStream("snakesim-test", recording_id="scene-log")
    rec.save(str(tmp_path / "s.rrd"))
    # meshes out of document order and one link without a mesh: rows must follow the names
    log = SceneLog(rec, robot="robot", link_names=LINKS, meshes=[_mesh("head"), _mesh("tail")],
                   body_frames=True, flush_frames=4)
    log.log_static()
    n = 10                                      # two full batches of 4 and a partial one of 2
    for k in range(n):
        log.add_frame(0.1 * k, np.array([_pose(k, i) for i in range(len(LINKS))]))
    log.flush()
    rec.flush()
    rec.disconnect()
    rrd = read_rrd(tmp_path / "s.rrd")
    entities = {E.link_path("robot", "head"): 2, E.link_path("robot", "tail"): 0,
                **{E.frame_path(name): i for i, name in enumerate(LINKS)}}
    assert "/" + E.link_path("robot", "middle") not in rrd.entities      # no mesh: no entity
    for path, i in entities.items():
        t, tr = rrd.columns("/" + path, "Transform3D:translation")
        _, q = rrd.columns("/" + path, "Transform3D:quaternion")
        np.testing.assert_allclose(t, 0.1 * np.arange(n), atol=1e-9)
        want = np.array([_pose(k, i) for k in range(n)])
        np.testing.assert_allclose(np.array(tr)[:, 0], want[:, :3], atol=1e-6)      # float32 in rerun
        np.testing.assert_allclose(np.array(q)[:, 0], want[:, 3:], atol=1e-6)
        chunks = [c for c in rrd.chunks if c.entity_path == "/" + path and not c.is_static]
        assert len(chunks) == math.ceil(n / 4)                              # one send_columns per batch


def test_a_saved_run_is_sent_in_batches_of_two_simulated_seconds(tmp_path, read_rrd):
    reg = build_registry()
    duration = 2.5
    r = resolve(str(SCENE), search_path=reg.assembly_paths(), overrides=["robot.modules=2"],
                sim_overrides={"duration": duration})
    found = attach_viewer(r, VizTarget("save", str(tmp_path / "b.rrd")), reg)
    Session(r, reg).run()
    rrd = read_rrd(tmp_path / "b.rrd")
    path = "/" + E.link_path(found.robot, "tail")
    t, _ = rrd.columns(path, "Transform3D:translation")
    per_batch = round(SAVE_FLUSH_S * found.rate)
    assert len(t) == math.floor(duration * found.rate + 1e-9) + 1
    chunks = [c for c in rrd.chunks if c.entity_path == path and not c.is_static]
    assert len(chunks) == math.ceil(len(t) / per_batch) == 2
