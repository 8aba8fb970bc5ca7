"""An independent ROS 2 client of snakesim's tf tree, robot description, IMU and camera topics.

No snakesim import: its DDS types are built here from rosbags' standard ROS 2 (Humble) definitions (what
any ROS 2 node's generated types are: field names, order and types, DDS type name
``pkg::msg::dds_::Type_``), and every sample's CDR bytes are decoded with rosbags' own codec.

    python frames_subscriber.py DOMAIN SECONDS  ->  JSON on stdout once the run is over
"""

import dataclasses
import json
import re
import sys
import time

from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.idl import IdlMeta, IdlStruct
from cyclonedds.idl import types as T
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.base import Nodetype

XML = ('<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
       '<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>'
       '<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
       '</Discovery></Domain></CycloneDDS>')
TS = get_typestore(Stores.ROS2_HUMBLE)
BASE = {"bool": bool, "byte": T.uint8, "char": T.uint8, "octet": T.uint8, "int8": T.int8, "uint8": T.uint8,
        "int16": T.int16, "uint16": T.uint16, "int32": T.int32, "uint32": T.uint32, "int64": T.int64,
        "uint64": T.uint64, "float32": T.float32, "float64": T.float64, "string": str}
_TYPES = {}


def dds_type(name: str):
    """The cyclonedds IdlStruct of ROS 2 message ``name`` ('pkg/msg/Type') from rosbags' definition."""
    if name in _TYPES:
        return _TYPES[name]

    def annotation(node):
        kind, spec = node
        if kind == Nodetype.BASE:
            base, bound = spec
            return T.bounded_str[bound] if base == "string" and bound else BASE[base]
        if kind == Nodetype.NAME:
            return dds_type(spec)
        inner, n = spec
        if kind == Nodetype.ARRAY:
            return T.array[annotation(inner), n]
        return T.sequence[annotation(inner), n] if n else T.sequence[annotation(inner)]

    pkg, kind, short = name.split("/")
    typename = f"{pkg}::{kind}::dds_::{short}_"
    ns = IdlMeta.__prepare__(short, (IdlStruct,), typename=typename)
    for fname, node in TS.fielddefs[name][1]:
        ns["__annotations__"][fname] = annotation(node)
    cls = _TYPES[name] = dataclasses.dataclass(IdlMeta(short, (IdlStruct,), ns, typename=typename))
    return cls


def main(domain: int, seconds: float) -> None:
    dom = Domain(domain, XML)  # noqa: F841  (kept alive)
    dp = DomainParticipant(domain)
    deep = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(1000))
    latched = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(100),
                  Policy.Durability.TransientLocal)          # tf2_ros::StaticListenerQoS
    topics = {"tf": ("/tf", "tf2_msgs/msg/TFMessage", deep),
              "tf_static": ("/tf_static", "tf2_msgs/msg/TFMessage", latched),
              "description": ("/robot_description", "std_msgs/msg/String", latched),
              "imu": ("/imu", "sensor_msgs/msg/Imu", deep),
              "points": ("/lidar/points", "sensor_msgs/msg/PointCloud2", deep),
              "left_image": ("/stereo/left/image_raw", "sensor_msgs/msg/Image", deep),
              "right_image": ("/stereo/right/image_raw", "sensor_msgs/msg/Image", deep),
              "left_info": ("/stereo/left/camera_info", "sensor_msgs/msg/CameraInfo", deep),
              "right_info": ("/stereo/right/camera_info", "sensor_msgs/msg/CameraInfo", deep)}
    readers = {k: (DataReader(dp, Topic(dp, "rt" + topic, dds_type(name)), qos), name)
               for k, (topic, name, qos) in topics.items()}
    out = {"edges": {"tf": [], "tf_static": []}, "frame_ids": {}, "meshes": [], "imu": None, "info": {}}
    print(json.dumps({"ready": True}), flush=True)
    end = time.monotonic() + seconds
    quiet = None
    while time.monotonic() < end:
        got = False
        for key, (reader, name) in readers.items():
            for sample in reader.take(N=1000):
                if not isinstance(sample, IdlStruct):
                    continue                       # InvalidSample: the writer went away
                m = TS.deserialize_cdr(sample.serialize(), name)
                got = True
                if key in ("tf", "tf_static"):
                    edges = out["edges"][key]
                    for tr in m.transforms:
                        e = [tr.header.frame_id, tr.child_frame_id]
                        if e not in edges:
                            edges.append(e)
                elif key == "description":
                    out["meshes"] = re.findall(r'<mesh\b[^>]*\bfilename="([^"]*)"', m.data)
                else:
                    out["frame_ids"].setdefault(key, [])
                    if m.header.frame_id not in out["frame_ids"][key]:
                        out["frame_ids"][key].append(m.header.frame_id)
                    if key == "imu":
                        out["imu"] = {k: [float(v) for v in getattr(m, k)] for k in
                                      ("orientation_covariance", "angular_velocity_covariance",
                                       "linear_acceleration_covariance")}
                    elif key.endswith("info"):
                        out["info"][key] = {"k": [float(v) for v in m.k], "p": [float(v) for v in m.p],
                                            "r": [float(v) for v in m.r], "d": [float(v) for v in m.d],
                                            "model": m.distortion_model, "width": m.width, "height": m.height}
        if got:
            quiet = None
        elif out["info"]:
            quiet = quiet or time.monotonic()
            if time.monotonic() - quiet > 2.0:
                break                                  # the run is over
        time.sleep(0.01)
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), float(sys.argv[2]))
