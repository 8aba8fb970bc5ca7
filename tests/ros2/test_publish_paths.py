"""The publisher's per-tick paths: patched bytes equal to a fresh serialisation, topics faster than the step,
and the polling sources' arrival check."""

import logging
import time

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

from snakesim.components.ros2 import messages as M  # noqa: E402
from snakesim.components.ros2.cdr_patch import MessagePatch  # noqa: E402
from snakesim.components.ros2.template import CdrTemplate  # noqa: E402


class _Capture:
    """Stands where a DDS writer is: keeps the bytes written."""

    def __init__(self):
        self.sent = []

    def write(self, buf):
        self.sent.append(bytes(buf))


def _wire(msg) -> bytes:
    raw = msg.serialize()
    return raw.ljust((len(raw) + 3) & ~3, b"\0")        # DataWriter.write pads to 4 bytes


def test_joint_state_and_clock_patches_are_a_fresh_serialisation():
    names = [f"joint_{i}" for i in range(5)]
    tpl = CdrTemplate.of(M.JointState(name=names),
                         {"position": (lambda m, v: setattr(m, "position", list(v)), 5),
                          "velocity": (lambda m, v: setattr(m, "velocity", list(v)), 5)},
                         [lambda m, tm: setattr(m.header, "stamp", tm)])
    q, v, out = np.zeros(5), np.zeros(5), _Capture()
    patch = MessagePatch(tpl, [("position", q), ("velocity", v)], out)
    assert len(patch.copies) == 2 and not patch.scatters      # sequences of doubles: slice copies
    for k, (sec, nsec) in enumerate([(0, 0), (3, 999_999_999), (2**31 - 1, 5)]):
        q[:] = np.linspace(-1, 1, 5) * (k + 1)               # the input buffers change in place, as a run's do
        v[:] = np.arange(5.0) - k
        patch.publish(sec, nsec)
        want = M.JointState(header=M.Header(stamp=M.Time(sec=sec, nanosec=nsec)), name=names,
                            position=list(q), velocity=list(v))
        assert out.sent[-1] == _wire(want)
    clock, out = CdrTemplate.of(M.Clock(), {}, [lambda m, tm: setattr(m, "clock", tm)]), _Capture()
    MessagePatch(clock, [], out).publish(7, 123)
    assert out.sent == [_wire(M.Clock(clock=M.Time(sec=7, nanosec=123)))]


@pytest.mark.parametrize("rows", [[0, 1, 2], [0, 2, 3]], ids=["contiguous rows", "rows with a gap"])
def test_tf_patch_with_a_selection_of_links_is_a_fresh_serialisation(rows):
    links = ["tail", "k", "module_00", "screw_front_link_00"]          # names of unequal lengths
    rows = np.array(rows)
    msg = M.TFMessage(transforms=[M.TransformStamped(header=M.Header(frame_id="world"), child_frame_id=links[i])
                                  for i in rows])

    def poses(m, val):
        for tr, row in zip(m.transforms, np.asarray(val).reshape(-1, 7)):
            tr.transform = M.Transform(translation=M.Vector3(*row[:3]), rotation=M.Quaternion(*row[3:]))

    tpl = CdrTemplate.of(msg, {"poses": (poses, 7 * len(rows))},
                         [(lambda m, tm, i=i: setattr(m.transforms[i].header, "stamp", tm)) for i in range(len(rows))])
    tpl.selection["poses"] = (7 * rows[:, None] + np.arange(7)).ravel()
    link_poses, out = np.zeros((len(links), 7)), _Capture()
    patch = MessagePatch(tpl, [("poses", link_poses)], out)
    link_poses[:] = np.random.default_rng(3).normal(size=link_poses.shape)
    patch.publish(12, 34)
    stamp = M.Time(sec=12, nanosec=34)
    want = M.TFMessage(transforms=[M.TransformStamped(
        header=M.Header(stamp=stamp, frame_id="world"), child_frame_id=links[i],
        transform=M.Transform(translation=M.Vector3(*link_poses[i, :3]), rotation=M.Quaternion(*link_poses[i, 3:])))
        for i in rows])
    assert out.sent == [_wire(want)]


def test_an_input_that_cannot_be_flattened_in_place_is_refused():
    tpl = CdrTemplate.of(M.JointState(name=list("abcd")), {"position": (lambda m, v: setattr(m, "position", list(v)), 4)})
    strided = np.zeros((2, 3))[:, :2]                     # flattening it copies: the patch would read a stale copy
    with pytest.raises(ValueError, match="position: the input must be contiguous"):
        MessagePatch(tpl, [("position", strided)], _Capture())


def test_ros2_keeps_the_scenes_step():
    """--ros2 adds its components at the scene's step (20 ms here): the publisher ticks at 50 Hz, never
    the scene at the topics' 100 Hz."""
    from snakesim.components.ros2.attach import attach_ros2
    from snakesim.framework.assembly import resolve
    from snakesim.framework.registry import default_registry

    reg = default_registry()
    resolved = resolve("robot-zero-g", search_path=reg.assembly_paths(), overrides=["robot.modules=2"],
                       sim_overrides={"duration": 0.2, "dt": 0.02})
    name = attach_ros2(resolved, reg, params={"domain_id": 0})
    assert resolved.sim.dt == 0.02 and resolved.components[name].rate == 50.0
    assert {s.rate for n, s in resolved.components.items() if n.startswith("ros2_")} == {50.0}


def test_topics_faster_than_the_tick_publish_every_tick_and_say_so(caplog):
    """/clock and /joint_states (100 Hz asked) at a 50 Hz tick: every tick; /tf (50 Hz) too; the real-time
    factor (1 Hz) every 50th; the log names the topics and the rate they get; a rate that is neither faster
    than the tick nor a whole number of ticks stays an error."""
    from snakesim.components.multibody.robot_model import RobotModel
    from snakesim.components.ros2.publisher import Ros2Publisher
    from snakesim.framework import SnakesimError
    from snakesim.framework.harness import Harness

    robot = RobotModel.load(design="eels-1.0", modules=2)
    with caplog.at_level(logging.WARNING, logger="snakesim.ros2"):
        pub = Harness(Ros2Publisher, {}, rate=50.0, name="ros2", uses={"robot": robot}).c
    assert pub.periods == {"clock": 1, "joint_states": 1, "tf": 1} and pub.rtf_period == 50
    assert pub.achieved_rates == {"clock": 50.0, "joint_states": 50.0, "tf": 50.0}
    assert any("clock 100 Hz, joint_states 100 Hz published at 50 Hz" in r.getMessage() for r in caplog.records)
    with pytest.raises((SnakesimError, ValueError), match=r"rates.tf \(at the component.s 50 Hz\): 30 Hz is not an integer number"):
        Harness(Ros2Publisher, {"rates": {"tf": 30.0}}, rate=50.0, name="ros2", uses={"robot": robot})


@pytest.mark.parametrize("n", [1, 6], ids=["few readers: reads", "many readers: one waitset"])
def test_arrivals_says_when_a_reader_holds_a_sample_and_leaves_it_to_take(dds_domain, n):
    from snakesim.components.ros2.transport import Arrivals, Ros2Participant

    with Ros2Participant(dds_domain()) as dds:
        readers = [dds.reader(f"/arrivals_{i}", M.UInt32) for i in range(n)]
        writer = dds.writer(f"/arrivals_{n - 1}", M.UInt32)
        arrived = Arrivals(dds, readers)
        assert (arrived.waitset is None) == (n <= Arrivals.FEW)
        assert not arrived()
        end = time.monotonic() + 5.0
        while not arrived() and time.monotonic() < end:       # discovery, then the sample
            writer.write(M.UInt32(data=7))
            time.sleep(0.02)
        got = [m.data for m in readers[-1].take(N=100) if isinstance(m, M.UInt32)]
        assert got and set(got) == {7}                        # still there for the take after the check
        assert not arrived()
