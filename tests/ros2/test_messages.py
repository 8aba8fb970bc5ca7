"""The ROS 2 message types: rosbags' standard definitions, and bytes any ROS 2 node decodes."""

import dataclasses
import math

import numpy as np
import pytest

M = pytest.importorskip("snakesim.components.ros2.messages")


def _ros_fields(store, name):
    return [f for f, _ in store.fielddefs[name][1]]


@pytest.mark.parametrize("ros_name", sorted(M.USED))
def test_fields_and_dds_name_are_rosbags_standard_definition(ros_name):
    cls = M.USED[ros_name]
    assert [f.name for f in dataclasses.fields(cls)] == _ros_fields(M.typestore(), ros_name)
    pkg, _, typ = ros_name.split("/")
    assert cls.__idl_typename__ == f"{pkg}::msg::dds_::{typ}_"


def _filled(cls, rng, depth=0):
    """An instance with non-trivial values in every field (strings, sequences of 3, nested)."""
    from cyclonedds.idl import IdlStruct

    kw = {}
    for f in dataclasses.fields(cls):
        v = getattr(cls(), f.name)
        if isinstance(v, IdlStruct):
            kw[f.name] = _filled(type(v), rng, depth + 1)
        elif isinstance(v, str):
            kw[f.name] = f"{f.name}_ü{rng.integers(100)}"
        elif isinstance(v, bool):
            kw[f.name] = True
        elif isinstance(v, float):
            kw[f.name] = float(rng.normal())
        elif isinstance(v, int):
            kw[f.name] = int(rng.integers(1, 100))
        elif isinstance(v, list) and v:                       # fixed array
            kw[f.name] = [float(x) for x in rng.normal(size=len(v))]
        elif isinstance(v, list):                              # sequence: its element type from the annotation
            ann = cls.__annotations__[f.name]
            inner = getattr(ann, "subtype", None) or ann.__metadata__[0].subtype
            if isinstance(inner, type) and issubclass(inner, IdlStruct):
                kw[f.name] = [_filled(inner, rng, depth + 1) for _ in range(3)]
            elif inner is str:
                kw[f.name] = ["a", "bc", "def"]
            elif getattr(inner, "__origin__", None) is int:        # e.g. uint8[]
                kw[f.name] = [int(x) for x in rng.integers(0, 100, size=3)]
            else:
                kw[f.name] = [float(x) for x in rng.normal(size=3)]
    return cls(**kw)


def _same(ours, theirs, path="msg"):
    if dataclasses.is_dataclass(ours):
        for f in dataclasses.fields(ours):
            _same(getattr(ours, f.name), getattr(theirs, f.name), f"{path}.{f.name}")
    elif isinstance(ours, list):
        assert len(ours) == len(theirs), path
        for i, (a, b) in enumerate(zip(ours, theirs)):
            _same(a, b, f"{path}[{i}]")
    elif isinstance(ours, float):
        assert math.isclose(ours, float(theirs), rel_tol=0, abs_tol=0) or (ours == theirs), path
    else:
        assert ours == theirs, path


@pytest.mark.parametrize("ros_name", sorted(M.USED))
def test_cyclonedds_bytes_decode_with_rosbags_cdr(ros_name):
    msg = _filled(M.USED[ros_name], np.random.default_rng(1))
    raw = msg.serialize()
    assert raw[:2] in (b"\x00\x01", b"\x00\x00"), "plain CDR (XCDR1), as ROS 2 writes it"
    decoded = M.typestore().deserialize_cdr(raw, ros_name)
    _same(msg, decoded)
    # and back: rosbags' bytes are ours
    again = M.USED[ros_name].deserialize(bytes(M.typestore().serialize_cdr(decoded, ros_name)))
    _same(msg, again)


def test_defaults_and_time():
    assert M.Quaternion().w == 1.0 and M.Imu().orientation.w == 1.0
    t = M.time_msg(12.3456789)
    assert (t.sec, t.nanosec) == (12, 345678900)


def test_any_other_standard_message_on_demand():
    pc = M.ros_type("sensor_msgs/msg/PointCloud2")
    assert pc.__idl_typename__ == "sensor_msgs::msg::dds_::PointCloud2_"
    with pytest.raises(KeyError, match="not in rosbags"):
        M.ros_type("nope_msgs/msg/Nothing")


def test_patched_template_is_what_rosbags_decodes():
    from snakesim.components.ros2.template import CdrTemplate

    names = [f"joint_{i}" for i in range(7)]
    tpl = CdrTemplate.of(M.JointState(name=names),
                         {"position": (lambda m, v: setattr(m, "position", list(v)), 7),
                          "velocity": (lambda m, v: setattr(m, "velocity", list(v)), 7)},
                         [lambda m, tm: setattr(m.header, "stamp", tm)])
    q, v = np.linspace(-1, 1, 7), np.arange(7.0) * 0.1
    tpl.set_floats("position", q)
    tpl.set_floats("velocity", v)
    tpl.set_stamp(5, 250_000_000)
    d = M.typestore().deserialize_cdr(bytes(tpl.buf), "sensor_msgs/msg/JointState")
    assert list(d.name) == names and (d.header.stamp.sec, d.header.stamp.nanosec) == (5, 250_000_000)
    np.testing.assert_array_equal(d.position, q)
    np.testing.assert_array_equal(d.velocity, v)
    assert len(d.effort) == 0


SERVICES = sorted(M.SRV_TEXT)


@pytest.mark.parametrize("srv", SERVICES)
@pytest.mark.parametrize("part", ["Request", "Response"])
def test_service_types_carry_rmw_cyclonedds_request_header_then_the_std_srvs_fields(srv, part):
    """rmw_cyclonedds' wire form: the 8-byte client guid and 8-byte sequence number, then the message's fields
    as plain CDR; the fields are std_srvs' (.srv text), and the bytes after the header decode with rosbags."""
    req, rsp = M.service_types(srv)
    cls = req if part == "Request" else rsp
    pkg, _, typ = srv.split("/")
    assert cls.__idl_typename__ == f"{pkg}::srv::dds_::{typ}_{part}_"
    ros_name = f"{srv}_{part}"
    names = [f.name for f in dataclasses.fields(cls)]
    assert names[:2] == ["header_guid", "header_seq"]
    assert names[2:] == _ros_fields(M.typestore(), ros_name)
    body = {f.name: getattr(_filled(cls, np.random.default_rng(3)), f.name) for f in dataclasses.fields(cls)[2:]}
    msg = cls(header_guid=0x0123456789ABCDEF, header_seq=-7 if part == "Response" else 42, **body)
    raw = msg.serialize()
    assert raw[:4] == b"\x00\x01\x00\x00"
    assert int.from_bytes(raw[4:12], "little") == 0x0123456789ABCDEF
    assert int.from_bytes(raw[12:20], "little", signed=True) == msg.header_seq
    # the 16-byte header keeps 8-byte alignment: the rest is exactly the ROS message's CDR body
    decoded = M.typestore().deserialize_cdr(raw[:4] + raw[20:], ros_name)
    for name, value in body.items():
        assert getattr(decoded, name) == value, name
    assert cls.deserialize(raw) == msg


def test_service_text_is_std_srvs():
    """The derived definitions, as rosbags generates them back (what an MCAP schema would carry)."""
    assert M.typestore().generate_msgdef("std_srvs/srv/SetBool_Request", ros_version=2)[0] == "bool data\n"
    assert M.typestore().generate_msgdef("std_srvs/srv/Trigger_Response", ros_version=2)[0] == \
        "bool success\nstring message\n"
    assert [f for f, _ in M.typestore().fielddefs["std_srvs/srv/Empty_Request"][1]] == \
        ["structure_needs_at_least_one_member"]
    with pytest.raises(KeyError, match="not defined here"):
        M.service_types("std_srvs/srv/Nope")
