"""A separate ROS 2 subscriber of snakesim's sensor topics, written against cyclonedds alone.

It takes each sample with a reader of the standard type (cyclonedds' codec) and decodes the sample's
CDR bytes again with rosbags' standard definitions (the maintained codec), so what it reports is what
any ROS 2 node decodes; it shares no serialisation code with snakesim's bridge (rosbags' serialiser).

    python sensor_subscriber.py DOMAIN SECONDS BASE_LIDAR BASE_CAMERA  ->  JSON on stdout
"""

import json
import sys
import time

import numpy as np
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from rosbags.typesys import Stores, get_typestore

from snakesim.components.ros2.messages import ros_type

XML = ('<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
       '<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>'
       '<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
       '</Discovery></Domain></CycloneDDS>')


def main(domain: int, seconds: float, lidar: str, camera: str) -> None:
    ts = get_typestore(Stores.ROS2_HUMBLE)
    dom = Domain(domain, XML)  # noqa: F841  (kept alive)
    dp = DomainParticipant(domain)
    qos = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(100))
    topics = {"points": (f"{lidar}/points", "sensor_msgs/msg/PointCloud2"),
              "image": (f"{camera}/image_raw", "sensor_msgs/msg/Image"),
              "depth": (f"{camera}/depth", "sensor_msgs/msg/Image"),
              "info": (f"{camera}/camera_info", "sensor_msgs/msg/CameraInfo")}
    readers = {k: (DataReader(dp, Topic(dp, "rt" + topic, ros_type(name)), qos), name)
               for k, (topic, name) in topics.items()}
    out = {k: [] for k in topics}
    print(json.dumps({"ready": True}), flush=True)
    end = time.monotonic() + seconds
    quiet = None
    while time.monotonic() < end:
        got = False
        for key, (reader, name) in readers.items():
            for sample in reader.take(N=100):
                if not hasattr(sample, "header"):
                    continue                       # InvalidSample: the writer went away
                m = ts.deserialize_cdr(sample.serialize(), name)
                stamp = m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
                rec = {"t": stamp, "frame": m.header.frame_id}
                if key == "points":
                    cloud = np.frombuffer(m.data.tobytes(), dtype=np.dtype(
                        {"names": ["x", "y", "z", "intensity", "ring", "status"],
                         "formats": ["<f4", "<f4", "<f4", "<f4", "<u2", "u1"],
                         "offsets": [f.offset for f in m.fields], "itemsize": m.point_step}))
                    ret = cloud["status"] == 0
                    rec.update(height=m.height, width=m.width, fields=[f.name for f in m.fields],
                               returns=int(ret.sum()), finite_returns=bool(np.isfinite(cloud["x"][ret]).all()),
                               nan_misses=bool(np.isnan(cloud["x"][~ret]).all()),
                               min_z=float(np.nanmin(cloud["z"])) if ret.any() else None)
                elif key in ("image", "depth"):
                    rec.update(height=m.height, width=m.width, encoding=m.encoding, step=m.step, bytes=len(m.data))
                    if key == "depth":
                        d = np.frombuffer(m.data.tobytes(), dtype="<f4")
                        rec.update(depth_min=float(np.nanmin(d)) if np.isfinite(d).any() else None)
                else:
                    rec.update(k=[float(v) for v in m.k], model=m.distortion_model, height=m.height, width=m.width)
                out[key].append(rec)
                got = True
        if got:
            quiet = None
        elif any(out.values()):
            quiet = quiet or time.monotonic()
            if time.monotonic() - quiet > 2.0:
                break
        time.sleep(0.01)
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), float(sys.argv[2]), sys.argv[3], sys.argv[4])
