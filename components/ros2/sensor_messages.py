"""Perception samples as ROS 2 messages: LidarScan -> sensor_msgs/PointCloud2, CameraFrame ->
sensor_msgs/Image (image, depth and labels) and sensor_msgs/CameraInfo, serialised by rosbags' CDR codec
(the maintained standard definitions; numpy arrays go through as one copy).

PointCloud2 (REP 117/118 conventions): every beam keeps its slot (an organised cloud of
height = channels, width = columns for a grid, else height 1); a beam without a return has
NaN x, y, z, so ``is_dense`` is false. Fields, little-endian, point_step 28:

    x, y, z     float32   m, lidar frame at the beam's firing instant    offsets 0, 4, 8
    intensity   float32   diffuse return          offset 12
    ring        uint16    channel index           offset 16
    status      uint8     0 return, 1 no return, 2 too close, 3 dropout, 4 weak (lidar.py)   offset 18
    t           float32   s, when the beam fired, relative to the header stamp (<= 0; 0 without
                          motion distortion), as Ouster's and Velodyne's drivers' per-point time   offset 20
    label       uint16    what the beam hit (perception/labels.py: 0 nothing, 1 + material terrain,
                          1000 + link row robot, 2000 + i obstacle)   offset 24

Image: ``mono8`` (grey) or ``rgb8`` (colour), the camera's linear values saturated to [0, 1]
and scaled to 0..255 (what an 8-bit sensor with that exposure reports); depth ``32FC1`` in m
along the optical axis, NaN where nothing is hit (REP 118); labels ``mono16``, each pixel what its
ray hit (the label scheme above, 0 where nothing is). CameraInfo: the model's
``camera_info()`` (pinhole: plumb_bob, fisheye: equidistant, CAHV as a pinhole); models with
no ROS equivalent (CAHVOR, CAHVORE) publish no CameraInfo. A stereo pair follows ROS's
convention (sensor_msgs/CameraInfo): the images are rectified already (parallel axes, one
model), so R = I, K and D are the model's and P = [K | t] with t = 0 for the left camera and
t = (-fx·B, 0, 0) for the right one, B the baseline (m): P[3] = -fx·B.

Stamps are the sample's simulated time; frame_id the sensor's frame in the tf tree
(``frame_id``, :mod:`.sensor_frames`; default the sample's frame name).
"""

from __future__ import annotations

import numpy as np

POINT_STEP = 28
#: PointField datatypes (sensor_msgs/PointField constants)
UINT8, UINT16, FLOAT32 = 2, 4, 7
_CLOUD_FIELDS = (("x", 0, FLOAT32), ("y", 4, FLOAT32), ("z", 8, FLOAT32), ("intensity", 12, FLOAT32),
                 ("ring", 16, UINT16), ("status", 18, UINT8), ("t", 20, FLOAT32), ("label", 24, UINT16))
_CLOUD_DTYPE = np.dtype({"names": ["x", "y", "z", "intensity", "ring", "status", "t", "label"],
                         "formats": ["<f4", "<f4", "<f4", "<f4", "<u2", "u1", "<f4", "<u2"],
                         "offsets": [0, 4, 8, 12, 16, 18, 20, 24], "itemsize": POINT_STEP})

POINT_CLOUD2, IMAGE, CAMERA_INFO = "sensor_msgs/msg/PointCloud2", "sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo"


def _header(ts, t: float, frame: str):
    ns = int(round(max(t, 0.0) * 1e9))
    Time, Header = ts.types["builtin_interfaces/msg/Time"], ts.types["std_msgs/msg/Header"]
    return Header(stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id=frame)


def point_cloud2(ts, scan, frame_id: str | None = None) -> bytes:
    """CDR bytes of a PointCloud2 of ``scan`` (a LidarScan), in ``frame_id`` (default ``scan.frame``)."""
    n = len(scan.range)
    rows, cols = scan.shape if scan.shape is not None else (1, n)
    pts = np.zeros(n, dtype=_CLOUD_DTYPE)          # zeros: the padding bytes too (a bag's bytes are reproducible)
    pts["x"], pts["y"], pts["z"] = scan.points[:, 0], scan.points[:, 1], scan.points[:, 2]
    pts["intensity"], pts["ring"], pts["status"] = scan.intensity, scan.ring, scan.status
    if scan.time is not None:
        pts["t"] = scan.time
    if scan.label is not None:
        pts["label"] = scan.label
    PointField = ts.types["sensor_msgs/msg/PointField"]
    msg = ts.types[POINT_CLOUD2](
        header=_header(ts, scan.t, frame_id or scan.frame), height=rows, width=cols,
        fields=[PointField(name=nm, offset=off, datatype=dt, count=1) for nm, off, dt in _CLOUD_FIELDS],
        is_bigendian=False, point_step=POINT_STEP, row_step=POINT_STEP * cols,
        data=pts.view(np.uint8).reshape(-1), is_dense=False)
    return bytes(ts.serialize_cdr(msg, POINT_CLOUD2))


def image(ts, frame, frame_id: str | None = None) -> bytes:
    """CDR bytes of the 8-bit Image of ``frame`` (a CameraFrame), in ``frame_id`` (default ``frame.frame``)."""
    img = frame.image
    h, w = img.shape[:2]
    rgb = img.ndim == 3
    data = np.rint(np.clip(img, 0.0, 1.0) * 255.0).astype(np.uint8)
    msg = ts.types[IMAGE](header=_header(ts, frame.t, frame_id or frame.frame), height=h, width=w,
                          encoding="rgb8" if rgb else "mono8", is_bigendian=0, step=w * (3 if rgb else 1),
                          data=data.reshape(-1))
    return bytes(ts.serialize_cdr(msg, IMAGE))


def depth_image(ts, frame, frame_id: str | None = None) -> bytes:
    """CDR bytes of the 32FC1 depth Image of ``frame`` (m, NaN where nothing is hit)."""
    h, w = frame.depth.shape
    data = np.ascontiguousarray(frame.depth, dtype="<f4")
    msg = ts.types[IMAGE](header=_header(ts, frame.t, frame_id or frame.frame), height=h, width=w, encoding="32FC1",
                          is_bigendian=0, step=4 * w, data=data.view(np.uint8).reshape(-1))
    return bytes(ts.serialize_cdr(msg, IMAGE))


def label_image(ts, frame, frame_id: str | None = None) -> bytes:
    """CDR bytes of the mono16 label Image of ``frame`` (perception/labels.py; all 0 for a frame without labels)."""
    h, w = frame.depth.shape
    label = frame.label if frame.label is not None else np.zeros((h, w), np.uint16)
    data = np.ascontiguousarray(label, dtype="<u2")
    msg = ts.types[IMAGE](header=_header(ts, frame.t, frame_id or frame.frame), height=h, width=w, encoding="mono16",
                          is_bigendian=0, step=2 * w, data=data.view(np.uint8).reshape(-1))
    return bytes(ts.serialize_cdr(msg, IMAGE))


def camera_info_fields(model, baseline: float = 0.0) -> dict | None:
    """{distortion_model, d, k, r, p} of ``model`` for a camera ``baseline`` m right of the first camera
    of its stereo pair (0: the left one, or a single camera): P[3] = -fx'·B with fx' = P[0]; None when
    the model has no ROS equivalent."""
    info = model.camera_info()
    if info is None:
        return None
    p = [float(v) for v in info["p"]]
    p[3], p[7] = -p[0] * float(baseline), 0.0              # Tx = -fx'·B, Ty = 0 (a horizontal pair)
    return {**info, "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], "p": p}


def camera_info(ts, frame, frame_id: str | None = None, baseline: float = 0.0) -> bytes | None:
    """CDR bytes of the CameraInfo of ``frame``'s model (a stereo right camera ``baseline`` m from the
    left: :func:`camera_info_fields`), or None when it has no ROS equivalent."""
    info = camera_info_fields(frame.model, baseline)
    if info is None:
        return None
    Roi = ts.types["sensor_msgs/msg/RegionOfInterest"]
    msg = ts.types[CAMERA_INFO](
        header=_header(ts, frame.t, frame_id or frame.frame), height=frame.model.height, width=frame.model.width,
        distortion_model=info["distortion_model"], d=np.asarray(info["d"], dtype=np.float64),
        k=np.asarray(info["k"], dtype=np.float64), r=np.asarray(info["r"], dtype=np.float64),
        p=np.asarray(info["p"], dtype=np.float64), binning_x=0, binning_y=0,
        roi=Roi(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
    return bytes(ts.serialize_cdr(msg, CAMERA_INFO))
