"""The ROS 2 message types snakesim publishes and accepts, as Cyclone DDS types on ROS 2's wire conventions.

Not typed by hand: every class here is generated from the standard ROS 2
definitions that ``rosbags`` ships (its ``ROS2_HUMBLE`` typestore: the .msg
files of common_interfaces, rcl_interfaces and geometry2), field by field, in
their order and with their types, nested messages resolved the same way. The
DDS type name is ROS 2's (``<pkg>::msg::dds_::<Type>_``), so any ROS 2 node on
the same domain (rmw_cyclonedds or rmw_fastrtps: plain XCDR1) decodes them;
tests/ros2/test_messages.py checks that bytes serialised by cyclonedds decode
with rosbags' own CDR codec to the same values.

Use them as dataclasses (every field has a default: zeros, empty strings and
sequences, nested defaults)::

    from snakesim.components.ros2.messages import JointState, Header, Time
    msg = JointState(header=Header(stamp=Time(sec=1, nanosec=5), frame_id=""), name=["bend_1"],
                     position=[0.1], velocity=[0.0], effort=[])

:func:`ros_type` builds any other message of the typestore on demand
(``ros_type("sensor_msgs/msg/PointCloud2")``).
"""

from __future__ import annotations

import dataclasses
from functools import lru_cache

from cyclonedds.idl import IdlMeta, IdlStruct
from cyclonedds.idl import types as T

#: the ROS 2 distribution whose message definitions are used (they agree for these messages from Humble on)
STORE = "ROS2_HUMBLE"

_BASE = {
    "bool": bool, "byte": T.uint8, "char": T.uint8, "octet": T.uint8,
    "int8": T.int8, "uint8": T.uint8, "int16": T.int16, "uint16": T.uint16,
    "int32": T.int32, "uint32": T.uint32, "int64": T.int64, "uint64": T.uint64,
    "float32": T.float32, "float64": T.float64, "string": str,
}
_ZERO = {bool: False, str: "", T.float32: 0.0, T.float64: 0.0}
#: default values the .msg files give (rosbags keeps no defaults): the identity quaternion
_DEFAULTS = {"geometry_msgs/msg/Quaternion": {"w": 1.0}}


@lru_cache(maxsize=1)
def typestore():
    """rosbags' typestore of the standard ROS 2 messages (the reference definitions and CDR codec)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(getattr(Stores, STORE))


def dds_type_name(ros_name: str) -> str:
    """'sensor_msgs/msg/JointState' -> 'sensor_msgs::msg::dds_::JointState_' (ROS 2's DDS type name)."""
    pkg, kind, name = ros_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def _base(spec):
    name, bound = spec
    if name == "string" and bound:
        return T.bounded_str[bound], ""
    if name not in _BASE:
        raise TypeError(f"ROS 2 base type '{name}' has no DDS mapping here")
    t = _BASE[name]
    return t, _ZERO.get(t, 0)


def _field(node):
    """(annotation, default factory) of one rosbags field definition."""
    from rosbags.typesys.base import Nodetype

    kind, spec = node
    if kind == Nodetype.BASE:
        t, zero = _base(spec)
        return t, (lambda z=zero: z)
    if kind == Nodetype.NAME:
        cls = ros_type(spec)
        return cls, cls
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        (inner, n) = spec
        t, make = _field(inner)
        if kind == Nodetype.ARRAY:
            return T.array[t, n], (lambda: [make() for _ in range(n)])
        return (T.sequence[t, n] if n else T.sequence[t]), list
    raise TypeError(f"unknown rosbags field kind {kind}")


@lru_cache(maxsize=None)
def ros_type(ros_name: str) -> type[IdlStruct]:
    """The IdlStruct of a standard ROS 2 message ('pkg/msg/Type'), built from rosbags' definition."""
    store = typestore()
    try:
        _consts, fields = store.fielddefs[ros_name]
    except KeyError:
        raise KeyError(f"'{ros_name}' is not in rosbags' {STORE} typestore") from None
    typename = dds_type_name(ros_name)
    cls_name = ros_name.rsplit("/", 1)[-1]
    ns = IdlMeta.__prepare__(cls_name, (IdlStruct,), typename=typename)
    if not fields:            # an empty .msg has one uint8 'structure_needs_at_least_one_member' in ROS 2's IDL
        from rosbags.typesys.base import Nodetype

        fields = [("structure_needs_at_least_one_member", (Nodetype.BASE, ("uint8", 0)))]
    given = _DEFAULTS.get(ros_name, {})
    for fname, node in fields:
        t, make = _field(node)
        if fname in given:
            make = (lambda v=given[fname]: v)
        ns["__annotations__"][fname] = t
        ns[fname] = dataclasses.field(default_factory=make)
    ns["__doc__"] = f"ROS 2 {ros_name} (DDS type {typename}), from rosbags' {STORE} definition."
    ns["__module__"] = __name__
    ns["ros_name"] = ros_name       # plain class attribute (no annotation): not a field
    cls = IdlMeta(cls_name, (IdlStruct,), ns, typename=typename)
    return dataclasses.dataclass(cls)


# -- the messages used (one name each) ---------------------------------------------------------
Time = ros_type("builtin_interfaces/msg/Time")
Duration = ros_type("builtin_interfaces/msg/Duration")
Header = ros_type("std_msgs/msg/Header")
String = ros_type("std_msgs/msg/String")
Bool = ros_type("std_msgs/msg/Bool")
Float64 = ros_type("std_msgs/msg/Float64")
UInt32 = ros_type("std_msgs/msg/UInt32")
Clock = ros_type("rosgraph_msgs/msg/Clock")
Vector3 = ros_type("geometry_msgs/msg/Vector3")
Quaternion = ros_type("geometry_msgs/msg/Quaternion")
Transform = ros_type("geometry_msgs/msg/Transform")
TransformStamped = ros_type("geometry_msgs/msg/TransformStamped")
Wrench = ros_type("geometry_msgs/msg/Wrench")
WrenchStamped = ros_type("geometry_msgs/msg/WrenchStamped")
TFMessage = ros_type("tf2_msgs/msg/TFMessage")
JointState = ros_type("sensor_msgs/msg/JointState")
Imu = ros_type("sensor_msgs/msg/Imu")
JointTrajectoryPoint = ros_type("trajectory_msgs/msg/JointTrajectoryPoint")
JointTrajectory = ros_type("trajectory_msgs/msg/JointTrajectory")

#: every type above, by ROS name (what the tests check against rosbags)
USED = {c.ros_name: c for c in (Time, Duration, Header, String, Bool, Float64, UInt32, Clock, Vector3, Quaternion,
                                Transform, TransformStamped, Wrench, WrenchStamped, TFMessage, JointState, Imu,
                                JointTrajectoryPoint, JointTrajectory)}


def time_msg(t: float, out=None):
    """Simulated time t (s, >= 0) as builtin_interfaces/Time; fills ``out`` in place when given."""
    ns = int(round(t * 1e9))
    sec, nanosec = divmod(ns, 1_000_000_000)
    if out is None:
        return Time(sec=sec, nanosec=nanosec)
    out.sec, out.nanosec = sec, nanosec
    return out
