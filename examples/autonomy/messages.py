"""The standard ROS 2 messages this node speaks, declared here with cyclonedds.idl (no ROS, no snakesim).

Each class mirrors its .msg file in ROS 2 Humble (common_interfaces, geometry2, rosgraph_msgs): the
same fields in the same order with the same types, and the DDS type name rmw_cyclonedds gives it,
``<pkg>::msg::dds_::<Type>_``, so any ROS 2 node on the domain (and snakesim) matches and decodes them.
Plain CDR (XCDR1) on the wire, as rmw_cyclonedds writes it: see :data:`QOS_DEFAULT`.

PointCloud2's ``data`` (``uint8[]``) would decode byte by byte into a Python list through cyclonedds'
generic machinery (0.6 MB a 32x1024 scan: tenths of a second); :meth:`PointCloud2.deserialize` reads the
CDR by hand instead and hands ``data`` over as one ``bytes`` object (numpy views it without a copy).
"""

import struct
from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types as T
from cyclonedds.qos import Policy, Qos
from cyclonedds.util import duration


def _qos(depth: int, reliable: bool = True, transient_local: bool = False) -> Qos:
    return Qos(Policy.Reliability.Reliable(duration(milliseconds=100)) if reliable else Policy.Reliability.BestEffort,
               Policy.History.KeepLast(depth),
               Policy.Durability.TransientLocal if transient_local else Policy.Durability.Volatile,
               Policy.DataRepresentation(use_cdrv0_representation=True))


QOS_DEFAULT = _qos(10)                                   # rclcpp::QoS(10)
QOS_SENSOR = _qos(5)                                     # snakesim's lidar/camera writers: keep last 5
QOS_TF = _qos(100)                                       # tf2's dynamic broadcaster
QOS_TF_STATIC = _qos(100, transient_local=True)   # latched; deep: several writers (robot, sensors) each send one
QOS_CLOCK = _qos(1, reliable=False)                      # rclcpp::ClockQoS


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: T.int32 = 0
    nanosec: T.uint32 = 0

    def seconds(self) -> float:
        return self.sec + 1e-9 * self.nanosec

    @staticmethod
    def of(t: float) -> "Time":
        ns = int(round(max(t, 0.0) * 1e9))
        return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class Clock(IdlStruct, typename="rosgraph_msgs::msg::dds_::Clock_"):
    clock: Time = field(default_factory=Time)


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header = field(default_factory=Header)
    name: T.sequence[str] = field(default_factory=list)
    position: T.sequence[T.float64] = field(default_factory=list)
    velocity: T.sequence[T.float64] = field(default_factory=list)
    effort: T.sequence[T.float64] = field(default_factory=list)


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: T.float64 = 0.0
    y: T.float64 = 0.0
    z: T.float64 = 0.0


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: T.float64 = 0.0
    y: T.float64 = 0.0
    z: T.float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: T.float64 = 0.0
    y: T.float64 = 0.0
    z: T.float64 = 0.0
    w: T.float64 = 1.0


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose = field(default_factory=Pose)
    covariance: T.array[T.float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist = field(default_factory=Twist)
    covariance: T.array[T.float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: T.sequence[TransformStamped] = field(default_factory=list)


@dataclass
class PointField(IdlStruct, typename="sensor_msgs::msg::dds_::PointField_"):
    name: str = ""
    offset: T.uint32 = 0
    datatype: T.uint8 = 0
    count: T.uint32 = 0


@dataclass
class PointCloud2(IdlStruct, typename="sensor_msgs::msg::dds_::PointCloud2_"):
    header: Header = field(default_factory=Header)
    height: T.uint32 = 0
    width: T.uint32 = 0
    fields: T.sequence[PointField] = field(default_factory=list)
    is_bigendian: bool = False
    point_step: T.uint32 = 0
    row_step: T.uint32 = 0
    data: T.sequence[T.uint8] = field(default_factory=list)
    is_dense: bool = False

    @classmethod
    def deserialize(cls, data: bytes, has_header: bool = True, use_version_2=None) -> "PointCloud2":
        """Plain CDR (XCDR1, either byte order) read by hand: ``data`` stays one bytes object."""
        buf = memoryview(data)
        base = 4 if has_header else 0
        e = "<" if (not has_header or buf[1] & 1) else ">"     # encapsulation id 0x0001: little-endian
        pos = base

        def align(n):
            nonlocal pos
            pos += (-(pos - base)) % n

        def u32():
            nonlocal pos
            align(4)
            (v,) = struct.unpack_from(e + "I", buf, pos)
            pos += 4
            return v

        def i32():
            nonlocal pos
            align(4)
            (v,) = struct.unpack_from(e + "i", buf, pos)
            pos += 4
            return v

        def u8():
            nonlocal pos
            v = buf[pos]
            pos += 1
            return v

        def string():
            nonlocal pos
            n = u32()
            s = bytes(buf[pos:pos + n - 1]).decode()
            pos += n
            return s

        stamp = Time(sec=i32(), nanosec=u32())
        header = Header(stamp=stamp, frame_id=string())
        height, width = u32(), u32()
        fields = []
        for _ in range(u32()):
            name = string()
            offset = u32()
            datatype = u8()
            fields.append(PointField(name=name, offset=offset, datatype=datatype, count=u32()))
        is_bigendian = bool(u8())
        point_step, row_step = u32(), u32()
        n = u32()
        payload = bytes(buf[pos:pos + n])
        pos += n
        return cls(header=header, height=height, width=width, fields=fields, is_bigendian=is_bigendian,
                   point_step=point_step, row_step=row_step, data=payload, is_dense=bool(u8()))
