"""The viewer's plots name their series as the recorded port names its elements: the default scene's tail
pose reads x, y, yaw in rerun's legend (the screenshots' caption), not pose[0..2]."""

from snakesim.components.monitors.planar_pose import PlanarPose
from snakesim.components.multibody.component import Multibody
from snakesim.components.viz import entities as E
from snakesim.components.viz.attach import declared_names


def test_declared_names_are_the_ports_fixed_names_only():
    classes = {"tail_pose": PlanarPose, "robot": Multibody}
    assert declared_names(classes, "tail_pose.pose") == ["x", "y", "yaw"]
    assert declared_names(classes, "robot.link_poses") is None       # per link: known once the robot is built
    assert declared_names(classes, "nowhere.pose") is None and declared_names(classes, "tail_pose.nope") is None


def test_the_saved_recording_names_the_tail_pose_x_y_yaw(tmp_path, cli_runner, read_rrd):
    rrd = tmp_path / "surface.rrd"
    res = cli_runner("run", "surface-screw-traverse", "--modules", "1", "--duration", "0.04", "--quiet",
                     "--viz", "save", rrd)
    assert res.exit_code == 0, res.output
    rec = read_rrd(rrd)
    path = "/" + E.series_path("tail_pose.pose")
    names = [c.to_record_batch().column("SeriesLines:names").to_pylist() for c in rec.chunks
             if c.entity_path == path and c.is_static]
    assert names == [[["x", "y", "yaw"]]], names
    _, values = rec.columns(path, "Scalars:scalars")
    assert values and all(len(v) == 3 for v in values)           # one value per named series, every frame
