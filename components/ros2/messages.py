"""The ROS 2 message types snakesim publishes and accepts, as Cyclone DDS types on ROS 2's wire conventions.

Not typed by hand: every class here is generated from the standard ROS 2
definitions that ``rosbags`` ships (its ``ROS2_HUMBLE`` typestore: the .msg
files of common_interfaces, rcl_interfaces and geometry2), field by field, in
their order and with their types, nested messages resolved the same way. The
DDS type name is ROS 2's (``<pkg>::msg::dds_::<Type>_``), so any ROS 2 node on
the same domain (rmw_cyclonedds or rmw_fastrtps: plain XCDR1) decodes them;
tests/ros2/test_messages.py checks that bytes serialised by cyclonedds decode
with rosbags' own CDR codec to the same values.

Services: ``rosbags`` ships no std_srvs, so the three std_srvs services used
(Empty, Trigger, SetBool) are derived here from their .srv text
(:data:`SRV_TEXT`, as in ros2/common_interfaces) with rosbags' own .msg parser
and registered in the same typestore as ``std_srvs/srv/<Type>_Request`` and
``_Response``. On the wire rmw_cyclonedds prefixes every request and reply
with its request header (``cdds_request_header_t``: the client's 64-bit
writer id ``guid`` and the 64-bit sequence number ``seq``, plain CDR before the
message's fields); :func:`service_types` builds those wrapped types, DDS type
names ``std_srvs::srv::dds_::<Type>_Request_`` / ``_Response_``.

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


#: std_srvs' .srv files (ros2/common_interfaces; comments dropped): request, then response, split at ---
SRV_TEXT = {
    "std_srvs/srv/Empty": "---\n",
    "std_srvs/srv/Trigger": "---\nbool success\nstring message\n",
    "std_srvs/srv/SetBool": "bool data\n---\nbool success\nstring message\n",
}


@lru_cache(maxsize=None)
def typestore(store_name: str = STORE):
    """rosbags' typestore of the standard ROS 2 messages (the reference definitions and CDR codec), with
    the std_srvs request and response types of :data:`SRV_TEXT` registered. ``store_name``: another
    distribution's (the node-graph types differ between Humble and Jazzy: :mod:`.node_graph`)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(getattr(Stores, store_name))
    types = {}
    for srv, text in SRV_TEXT.items():
        request, response = text.split("---\n")
        for part, body in (("Request", request), ("Response", response)):
            # rosbags' parser files a name under .../srv/msg/...; ROS 2 calls it pkg/srv/Type_Request
            types.update({k.replace("/srv/msg/", "/srv/"): v
                          for k, v in get_types_from_msg(body, f"{srv}_{part}").items()})
    store.register(types)
    return store


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


def _field(node, store_name: str = STORE):
    """(annotation, default factory) of one rosbags field definition."""
    from rosbags.typesys.base import Nodetype

    kind, spec = node
    if kind == Nodetype.BASE:
        t, zero = _base(spec)
        return t, (lambda z=zero: z)
    if kind == Nodetype.NAME:
        cls = ros_type(spec, store_name=store_name)
        return cls, cls
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        (inner, n) = spec
        t, make = _field(inner, store_name)
        if kind == Nodetype.ARRAY:
            return T.array[t, n], (lambda: [make() for _ in range(n)])
        return (T.sequence[t, n] if n else T.sequence[t]), list
    raise TypeError(f"unknown rosbags field kind {kind}")


#: the request header rmw_cyclonedds puts before a request's or reply's fields (cdds_request_header_t)
REQUEST_HEADER = (("header_guid", T.uint64), ("header_seq", T.int64))


@lru_cache(maxsize=None)
def ros_type(ros_name: str, request_header: bool = False, store_name: str = STORE) -> type[IdlStruct]:
    """The IdlStruct of a standard ROS 2 message ('pkg/msg/Type'), built from rosbags' definition;
    ``request_header``: with rmw_cyclonedds' service header first (``header_guid``, ``header_seq``);
    ``store_name``: from another distribution's definitions (default :data:`STORE`)."""
    store = typestore(store_name)
    try:
        _consts, fields = store.fielddefs[ros_name]
    except KeyError:
        raise KeyError(f"'{ros_name}' is not in rosbags' {store_name} typestore") from None
    typename = dds_type_name(ros_name)
    cls_name = ros_name.rsplit("/", 1)[-1] + ("_Wire" if request_header else "")
    ns = IdlMeta.__prepare__(cls_name, (IdlStruct,), typename=typename)
    if not fields:            # an empty .msg has one uint8 'structure_needs_at_least_one_member' in ROS 2's IDL
        from rosbags.typesys.base import Nodetype

        fields = [("structure_needs_at_least_one_member", (Nodetype.BASE, ("uint8", 0)))]
    if request_header:
        for fname, t in REQUEST_HEADER:
            ns["__annotations__"][fname] = t
            ns[fname] = dataclasses.field(default=0)
    given = _DEFAULTS.get(ros_name, {})
    for fname, node in fields:
        t, make = _field(node, store_name)
        if fname in given:
            make = (lambda v=given[fname]: v)
        ns["__annotations__"][fname] = t
        ns[fname] = dataclasses.field(default_factory=make)
    ns["__doc__"] = f"ROS 2 {ros_name} (DDS type {typename}), from rosbags' {store_name} definition."
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

Empty = ros_type("std_msgs/msg/Empty")
MultiArrayDimension = ros_type("std_msgs/msg/MultiArrayDimension")
MultiArrayLayout = ros_type("std_msgs/msg/MultiArrayLayout")
UInt8MultiArray = ros_type("std_msgs/msg/UInt8MultiArray")
Point = ros_type("geometry_msgs/msg/Point")
Pose = ros_type("geometry_msgs/msg/Pose")
PoseStamped = ros_type("geometry_msgs/msg/PoseStamped")

#: every type above, by ROS name (what the tests check against rosbags)
USED = {c.ros_name: c for c in (Time, Duration, Header, String, Bool, Float64, UInt32, Clock, Vector3, Quaternion,
                                Transform, TransformStamped, Wrench, WrenchStamped, TFMessage, JointState, Imu,
                                JointTrajectoryPoint, JointTrajectory, Empty, MultiArrayDimension, MultiArrayLayout,
                                UInt8MultiArray, Point, Pose, PoseStamped)}


def service_types(srv: str) -> tuple[type[IdlStruct], type[IdlStruct]]:
    """(request, response) of service ``srv`` ('std_srvs/srv/Empty') as rmw_cyclonedds puts them on the wire:
    DDS types ``<pkg>::srv::dds_::<Type>_Request_`` / ``_Response_`` with the request header first."""
    if srv not in SRV_TEXT:
        raise KeyError(f"service type '{srv}' is not defined here; defined: {', '.join(SRV_TEXT)}")
    return ros_type(f"{srv}_Request", request_header=True), ros_type(f"{srv}_Response", request_header=True)


def time_msg(t: float, out=None):
    """Simulated time t (s, >= 0) as builtin_interfaces/Time; fills ``out`` in place when given."""
    ns = int(round(t * 1e9))
    sec, nanosec = divmod(ns, 1_000_000_000)
    if out is None:
        return Time(sec=sec, nanosec=nanosec)
    out.sec, out.nanosec = sec, nanosec
    return out
