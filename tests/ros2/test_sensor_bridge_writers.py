"""The sensor bridge opens a writer for every configured sensor topic in ``before_run`` (so ``--ros2``'s
start print and the node's announcement list them from the start); a sensor whose kind its params do not
tell still gets its writers at its first sample."""

from snakesim.components.ros2.sensor_bridge import Ros2SensorBridge


def test_writers_exist_right_after_before_run(dds_domain):
    from snakesim.components.ros2.qos_table import endpoint_rows
    from snakesim.framework import Harness

    h = Harness(Ros2SensorBridge, {"sensors": ["lidar.scan", "stereo.left", "stereo.right", "thing.out"],
                                   "bases": ["/lidar", "/stereo/left", "/stereo/right", "/thing"],   # as --ros2 names them
                                   "domain_id": dds_domain()}, rate=10.0, name="sensor_bridge")
    run = h.u.cache
    assert run.dds is None and not run.writers
    try:
        h.c.before_run(0.0, h.u)
        want = {"/lidar/points", *(f"/stereo/{side}/{t}" for side in ("left", "right")
                                   for t in ("image_raw", "depth", "labels", "camera_info"))}
        assert set(run.writers) == want                       # thing.out: unknown until its first sample
        open_topics = {row[0] for row in endpoint_rows(run.dds)}
        assert want <= open_topics, open_topics
        writers = dict(run.writers)
        h.c.before_run(0.0, h.u)                              # idempotent: the same writers
        assert run.writers == writers and run.published == 0
    finally:
        run.close()
