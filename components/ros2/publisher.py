"""ROS 2 publisher sink: the robot's state on the ROS 2 wire protocol (Cyclone DDS, no ROS installation).

A sink (``is_sink``) at the fastest of its topic rates; each topic publishes
every ``period_of(rate, 1 / component rate)`` of its ticks (so per-topic rates
must divide the component's). ``snakesim run --ros2`` adds and wires it
(:mod:`.attach`); in YAML::

    ros: {type: ros2_publisher, rate: 100, params: {domain_id: 7, rates: {joint_states: 100, tf: 50}}}
    connections: [robot.joint_q -> ros.joint_positions, robot.joint_v -> ros.joint_velocities,
                  robot.link_poses -> ros.link_poses]

Topics (QoS: :mod:`.transport`; types: :mod:`.messages`):

    /clock              rosgraph_msgs/Clock        simulated time (rates.clock)
    /joint_states       sensor_msgs/JointState     robot.joints (every DOF joint, URDF names), position, velocity;
                                                   effort when params.effort (joint_efforts wired)
    /tf                 tf2_msgs/TFMessage         every link's pose as a transform from params.world_frame
                                                   (a star: parent world_frame for every link, not the URDF
                                                   chain), child_frame_id = link name; links on /tf_static
                                                   left out (one parent per frame, as tf2 requires)
    /tf_static          tf2_msgs/TFMessage         when params.tf_static: every URDF fixed joint's child
                                                   link relative to its parent link (the joint origin),
                                                   once, transient local (latched), stamped at the first tick
    /sim/real_time_factor  std_msgs/Float64        sim s per wall s over the last window (rates.real_time_factor,
                                                   default 1 Hz; from the second window on)
    /robot_description  std_msgs/String            robot.urdf with its meshes as file:// URIs (or package://
                                                   params.mesh_package/..., :mod:`.robot_description`), once,
                                                   transient local (latched)
    /imu                sensor_msgs/Imu            when params.imu_frame: frame_id that link; covariances from
                                                   the IMU's noise (:func:`imu_covariances`): diag σ² per axis,
                                                   element 0 = -1 for a quantity not wired
    /fts/<cut joint>    geometry_msgs/WrenchStamped  one per sensor of params.wrench_cuts (frame_id: its link)
    ros_discovery_info  rmw_dds_common/ParticipantEntitiesInfo  node /snakesim with these writers, latched
                                                   (params.node_graph, ros_distro: :mod:`.node_graph`)

Stamps are simulated time. The messages are serialised once and patched in
place each tick (:mod:`.template`): a publish allocates nothing per joint or
link. The DDS participant is opened on the first tick (not at build, so
``snakesim check`` opens none) and closed with the component.

uses robot: RobotModel (optional): joint and link names, the URDF
in   joint_positions[nj] rad, joint_velocities[nj] rad/s, joint_efforts[nj] N·m,
     link_poses[nl, 7] [x, y, z, qx, qy, qz, qw] world, imu_angular_rate[3], imu_specific_force[3],
     imu_orientation[4], sensor_wrenches[n, 6]   (all optional; matched by role by --ros2)
out  none
"""

from __future__ import annotations

import dataclasses

import time
import weakref

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.port_roles import (IMU_ANGULAR_RATE, IMU_ORIENTATION, IMU_SPECIFIC_FORCE, JOINT_EFFORTS,
                                            JOINT_POSITIONS, JOINT_VELOCITIES, LINK_POSES, SENSOR_WRENCHES)
from snakesim.framework import Component, Input, Uses
from snakesim.framework.rates import period_of

from .template import CdrTemplate, RawWriter
from .transport import ClosedAfterRun, DdsEndpoint

TOPICS = ("clock", "joint_states", "tf", "imu", "wrench", "real_time_factor")
RTF_TOPIC = "/sim/real_time_factor"
RTF_RATE = 1.0          # Hz, default rate of /sim/real_time_factor
DEFAULT_RATES = {"clock": 100.0, "joint_states": 100.0, "tf": 50.0, "imu": 100.0, "wrench": 100.0}
#: sensor_msgs/Imu's three measured quantities, in message order
IMU_QUANTITIES = ("orientation", "angular_velocity", "linear_acceleration")
#: variance published for a quantity measured without noise (σ = 0): an all-zero covariance means
#: "unknown" to ROS (sensor_msgs/Imu), so an exact one is given as this (σ = 1e-6 in its units)
EXACT_VARIANCE = 1e-12


def imu_covariances(orientation: float, angular_velocity: float, linear_acceleration: float,
                    provides=IMU_QUANTITIES) -> dict[str, list[float]]:
    """sensor_msgs/Imu's three row-major 3×3 covariances from per-axis standard deviations (rad, rad/s,
    m/s²): diag(σ², σ², σ²) (EXACT_VARIANCE where σ = 0, since zeros mean "unknown"); a quantity not in
    ``provides`` gets -1 in element 0 and zeros elsewhere, as the message definition asks."""
    out = {}
    for key, sigma in zip(IMU_QUANTITIES, (orientation, angular_velocity, linear_acceleration)):
        cov = [0.0] * 9
        if key in provides:
            cov[0] = cov[4] = cov[8] = float(sigma) ** 2 if sigma > 0 else EXACT_VARIANCE
        else:
            cov[0] = -1.0
        out[key] = cov
    return out


class Ros2PublisherParams(DdsEndpoint):
    rates: dict[str, float] = Field(default_factory=dict,
                                    description=f"Hz per topic ({', '.join(TOPICS)}); default {DEFAULT_RATES}; "
                                                "0 turns a topic off")
    world_frame: str = Field("world", description="parent frame of every link in /tf")
    effort: bool = Field(False, description="publish JointState.effort from joint_efforts (wired)")
    robot_description: bool = Field(True, description="publish robot.urdf on /robot_description (latched)")
    tf_static: bool = Field(True, description="publish the URDF's fixed joints on /tf_static (latched) and "
                                              "leave their child links out of /tf")
    imu_frame: str | None = Field(None, description="publish /imu with this frame_id (IMU inputs wired)")
    imu_gyro_noise: float = Field(0.0, ge=0, description="rad/s, standard deviation per axis (covariance σ²)")
    imu_accel_noise: float = Field(0.0, ge=0, description="m/s², standard deviation per axis (covariance σ²)")
    imu_orientation_noise: float = Field(0.0, ge=0, description="rad, standard deviation per axis of the "
                                                                "orientation (covariance σ²)")
    imu_provides: list[str] = Field(default_factory=lambda: list(IMU_QUANTITIES),
                                    description=f"the IMU quantities wired ({', '.join(IMU_QUANTITIES)}); "
                                                "the others get covariance element 0 = -1 (not provided)")
    mesh_package: str | None = Field(None, description="publish /robot_description's meshes as "
                                                        "package://MESH_PACKAGE/... (default: file:// URIs)")
    mesh_package_path: str | None = Field(None, description="the folder package://MESH_PACKAGE/ stands for "
                                                            "(default: the folder holding the robot's meshes/)")
    wrench_cuts: list[str] = Field(default_factory=list,
                                   description="force-torque sensor cuts (as force_torque_sensors.cuts): one "
                                               "/fts/<joint> WrenchStamped each, from sensor_wrenches")


def _nj(c):
    return (c.nj,)


class Ros2Publisher(ClosedAfterRun, Component[Ros2PublisherParams]):
    type_name = "ros2_publisher"
    is_sink = True

    robot = Uses(RobotModel, required=False, doc="joint and link names, the URDF")

    joint_positions = Input(shape=_nj, unit="rad", default=0.0, role=JOINT_POSITIONS)
    joint_velocities = Input(shape=_nj, unit="rad/s", default=0.0, role=JOINT_VELOCITIES)
    joint_efforts = Input(shape=_nj, unit="N*m", default=0.0, role=JOINT_EFFORTS)
    link_poses = Input(shape=lambda c: (c.nl, 7), unit=None, default=0.0, role=LINK_POSES)
    imu_angular_rate = Input(shape=(3,), unit="rad/s", default=0.0, role=IMU_ANGULAR_RATE)
    imu_specific_force = Input(shape=(3,), unit="m/s**2", default=0.0, role=IMU_SPECIFIC_FORCE)
    imu_orientation = Input(shape=(4,), unit="1", default=0.0, role=IMU_ORIENTATION)
    sensor_wrenches = Input(shape=lambda c: (len(c.wrench_joints), 6), unit=None, default=0.0, role=SENSOR_WRENCHES)

    def setup(self):
        p, robot = self.p, self.robot
        unknown = sorted(set(p.rates) - set(TOPICS))
        if unknown:
            raise ValueError(f"{self.name}: rates: unknown topics {unknown}; topics: {', '.join(TOPICS)}")
        if any(r < 0 for r in p.rates.values()):
            raise ValueError(f"{self.name}: rates must be >= 0 Hz (0: off)")
        bad = sorted(set(p.imu_provides) - set(IMU_QUANTITIES))
        if bad:
            raise ValueError(f"{self.name}: imu_provides: unknown {bad}; quantities: {', '.join(IMU_QUANTITIES)}")
        if p.mesh_package_path is not None and not p.mesh_package:
            raise ValueError(f"{self.name}: mesh_package_path needs mesh_package (the package://NAME/ it stands for)")
        self.joints = robot.joints if robot is not None else ()
        self.links = robot.links if robot is not None else ()
        self.nj, self.nl = len(self.joints), len(self.links)
        if p.wrench_cuts and robot is not None:
            self.wrench_joints, self.wrench_links = robot.cuts(p.wrench_cuts)
        else:
            self.wrench_joints, self.wrench_links = [], []
        rates = {**DEFAULT_RATES, **p.rates}
        rtf = rates.pop("real_time_factor", RTF_RATE)
        self.static = ([j for j in robot.tree.joints if j.type == "fixed"]
                       if p.tf_static and robot is not None and self.nl else [])
        static_links = {j.child for j in self.static}
        #: rows of link_poses published on /tf (links on /tf_static are not)
        self.tf_rows = np.array([i for i, ln in enumerate(self.links) if ln not in static_links], dtype=np.intp)
        on = {"clock": True, "joint_states": self.nj > 0, "tf": self.nl > 0, "imu": p.imu_frame is not None,
              "wrench": bool(self.wrench_joints)}
        self.topic_rates = {k: r for k, r in rates.items() if on[k] and r > 0}
        if self.rate is None:                    # the sink's tick: the fastest topic
            self.rate = max(self.topic_rates.values(), default=1.0)
        tick = 1.0 / self.rate
        # a topic faster than the component's tick (the default 100 Hz on a scene stepping 20 ms: the tick
        # is held to whole base steps) is published at every tick, stamped with that tick's time: its
        # achieved rate is the tick's, said once (the run's step is the scene's; nothing is made to step
        # faster for a topic)
        self.periods = {k: 1 if r > self.rate * (1 + 1e-9) else
                        period_of(r, tick, f"{self.name}: rates.{k} (at the component's {self.rate:g} Hz):")
                        for k, r in self.topic_rates.items()}
        #: Hz each topic is published at (the asked rate, or the tick's where the tick is slower)
        self.achieved_rates = {k: self.rate / n for k, n in self.periods.items()}
        slow = {k: r for k, r in self.topic_rates.items() if self.achieved_rates[k] < r * (1 - 1e-9)}
        if slow and self.type_name == "ros2_publisher":
            import logging

            logging.getLogger("snakesim.ros2").warning(
                "%s: %s published at %g Hz, every tick of %g s (the scene's step is coarser than %s; stamps "
                "are the ticks' simulated times)", self.name, ", ".join(f"{k} {r:g} Hz" for k, r in slow.items()),
                self.rate, tick, "their periods" if len(slow) > 1 else "its period")
        # not a templated topic (not in topic_rates): a low-rate Float64 computed from the wall clock
        self.rtf_period = (period_of(rtf, tick, f"{self.name}: rates.real_time_factor (at the component's "
                                                f"{self.rate:g} Hz):") if rtf > 0 else 0)

    def make_cache(self, x, u, y) -> "PublisherRun":
        """This run's message templates (their bytes are patched each publish) and DDS state."""
        return PublisherRun(templates=self._make_templates(), published=dict.fromkeys(self.topic_rates, 0))

    # -- templates: the messages of this robot, serialised once ----------------------------
    def _make_templates(self) -> dict:
        from . import messages as M        # cyclonedds and rosbags load when a publisher is built, not at plugin load

        p = self.p
        out = {}

        def stamp(msg, tm):
            msg.header.stamp = tm

        out["clock"] = ("/clock", M.Clock, CdrTemplate.of(M.Clock(), {}, [lambda m, tm: setattr(m, "clock", tm)]))
        if "joint_states" in self.topic_rates:
            msg = M.JointState(name=list(self.joints))
            fields = {"position": (lambda m, v: setattr(m, "position", list(v)), self.nj),
                      "velocity": (lambda m, v: setattr(m, "velocity", list(v)), self.nj)}
            if p.effort:
                fields["effort"] = (lambda m, v: setattr(m, "effort", list(v)), self.nj)
            out["joint_states"] = ("/joint_states", M.JointState, CdrTemplate.of(msg, fields, [stamp]))
        if "tf" in self.topic_rates:
            rows = self.tf_rows
            msg = M.TFMessage(transforms=[M.TransformStamped(header=M.Header(frame_id=p.world_frame),
                                                             child_frame_id=self.links[i]) for i in rows])

            def poses(m, v):
                for tr, row in zip(m.transforms, np.asarray(v).reshape(-1, 7)):
                    tr.transform = M.Transform(translation=M.Vector3(*row[:3]), rotation=M.Quaternion(*row[3:]))

            stamps = [(lambda m, tm, i=i: setattr(m.transforms[i].header, "stamp", tm)) for i in range(len(rows))]
            tpl = CdrTemplate.of(msg, {"poses": (poses, 7 * len(rows))}, stamps)
            if len(rows) < self.nl:                  # set_floats gets every link's pose: keep the /tf rows
                tpl.selection["poses"] = (7 * rows[:, None] + np.arange(7)).ravel()
            out["tf"] = ("/tf", M.TFMessage, tpl)
        if "imu" in self.topic_rates:
            cov = imu_covariances(p.imu_orientation_noise, p.imu_gyro_noise, p.imu_accel_noise, p.imu_provides)
            msg = M.Imu(header=M.Header(frame_id=p.imu_frame), orientation_covariance=cov["orientation"],
                        angular_velocity_covariance=cov["angular_velocity"],
                        linear_acceleration_covariance=cov["linear_acceleration"])
            fields = {"orientation": (lambda m, v: setattr(m, "orientation", M.Quaternion(*v)), 4),
                      "angular_velocity": (lambda m, v: setattr(m, "angular_velocity", M.Vector3(*v)), 3),
                      "linear_acceleration": (lambda m, v: setattr(m, "linear_acceleration", M.Vector3(*v)), 3)}
            out["imu"] = ("/imu", M.Imu, CdrTemplate.of(msg, fields, [stamp]))
        if "wrench" in self.topic_rates:
            def wrench(m, v):
                m.wrench = M.Wrench(force=M.Vector3(*v[:3]), torque=M.Vector3(*v[3:]))

            out["wrench"] = [(f"/fts/{j}", M.WrenchStamped,
                              CdrTemplate.of(M.WrenchStamped(header=M.Header(frame_id=ln)), {"wrench": (wrench, 6)},
                                             [stamp]))
                             for j, ln in zip(self.wrench_joints, self.wrench_links)]
        return out

    # -- opening and closing ------------------------------------------------------------------
    def before_run(self, t0, u):
        """The DDS participant, writers and latched messages, opened before the clock starts."""
        run = u.cache
        if run.dds is None:
            run.now = t0
            self._open(run, u)

    def _open(self, run: "PublisherRun", u) -> None:
        from .transport import Ros2Participant

        p = self.p
        dds = Ros2Participant(p.domain_id, p.interface)
        writers = {}
        for key, entry in run.templates.items():
            if key not in self.topic_rates:
                continue
            for topic, typ, tpl in (entry if isinstance(entry, list) else [entry]):
                writers.setdefault(key, []).append((RawWriter(dds.writer(topic, typ)), tpl))
        if p.robot_description and self.robot is not None:
            from . import messages as M

            w = dds.writer("/robot_description", M.String)
            w.write(M.String(data=self.description_text()))
        if self.static:
            from . import messages as M

            dds.writer("/tf_static", M.TFMessage).write(self.static_message(run.now))
        if self.rtf_period:
            from . import messages as M

            run.rtf = (self.rtf_period, dds.writer(RTF_TOPIC, M.Float64), M.Float64)
        self._schedule(run, writers, u)
        run.dds = dds
        self.p.announce(dds, "snakesim")              # ros2 node list (:mod:`.node_graph`)
        run.finalizer = weakref.finalize(run, dds.close)

    def _schedule(self, run: "PublisherRun", writers: dict, u) -> None:
        """What each tick writes: (period, topic key, message patches) per topic in a flat tuple, each patch
        bound to its template, input arrays and writer (:mod:`.cdr_patch`), so the per-tick loop reads no
        dicts and patches with slice copies where the layout allows. Shared by every sink that sends these
        messages."""
        from .cdr_patch import MessagePatch

        inputs = {"joint_states": [("position", u.joint_positions), ("velocity", u.joint_velocities)]
                  + ([("effort", u.joint_efforts)] if self.p.effort else []),
                  "tf": [("poses", u.link_poses)],
                  "imu": [("orientation", u.imu_orientation), ("angular_velocity", u.imu_angular_rate),
                          ("linear_acceleration", u.imu_specific_force)]}
        run.wrenches = u.sensor_wrenches
        plan = []
        for key in self.topic_rates:
            patches = tuple(MessagePatch(tpl, [("wrench", run.wrenches[k])] if key == "wrench" else inputs.get(key, ()),
                                         writer)
                            for k, (writer, tpl) in enumerate(writers[key]))
            plan.append((self.periods[key], key, patches))
        run.plan = tuple(plan)
        run.tick = 0

    # -- the per-tick path ----------------------------------------------------------------------
    def update(self, t, xd, u):
        run = u.cache
        if run.dds is None:
            wall = time.perf_counter()
            run.now = t
            self._open(run, u)
            run.open_time = time.perf_counter() - wall
        if not run.said:                   # once: domain, interface, topics (every component has opened by now)
            run.said = True
            from .qos_table import print_start

            print_start(run.dds)
        wall = time.perf_counter()
        ns = int(t * 1e9 + 0.5) if t > 0 else 0
        sec, nsec = divmod(ns, 1_000_000_000)
        tick = run.tick
        published = run.published
        for period, key, patches in run.plan:
            if tick % period:
                continue
            for patch in patches:
                patch.publish(sec, nsec)
            published[key] += 1
        if run.rtf is not None and tick % run.rtf[0] == 0:
            self._publish_rtf(run, t)
        run.tick = tick + 1
        run.publish_time += time.perf_counter() - wall

    def _publish_rtf(self, run: "PublisherRun", t: float) -> None:
        now = time.perf_counter()
        if run.rtf_last is not None:
            t0, w0 = run.rtf_last
            if now > w0:
                _, writer, Float64 = run.rtf
                run.real_time_factor = (t - t0) / (now - w0)
                writer.write(Float64(data=run.real_time_factor))
                run.published["real_time_factor"] = run.published.get("real_time_factor", 0) + 1
        run.rtf_last = (t, now)

    def description_text(self) -> str:
        """/robot_description: the URDF with mesh URIs a ROS tool resolves (:mod:`.robot_description`)."""
        text = getattr(self, "_description", None)
        if text is None:
            from .robot_description import ros_robot_description

            text = self._description = ros_robot_description(self.robot, self.p.mesh_package,
                                                             self.p.mesh_package_path)
        return text

    def static_message(self, t: float = 0.0):
        """/tf_static: each URDF fixed joint's child link in its parent link's frame (the joint's origin)."""
        from scipy.spatial.transform import Rotation

        from . import messages as M

        stamp = M.time_msg(max(t, 0.0))
        out = []
        for j in self.static:
            q = Rotation.from_matrix(np.asarray(j.rotation, dtype=float)).as_quat()       # x, y, z, w
            out.append(M.TransformStamped(
                header=M.Header(stamp=stamp, frame_id=j.parent), child_frame_id=j.child,
                transform=M.Transform(translation=M.Vector3(*map(float, j.translation)),
                                      rotation=M.Quaternion(*map(float, q)))))
        return M.TFMessage(transforms=out)


@dataclasses.dataclass(eq=False)
class PublisherRun:
    """One run's publishing state (``u.cache``): message templates, the DDS participant and writers
    (opened on the first tick), the tick count and what was published."""

    templates: dict
    published: dict                       # messages sent per topic key
    dds: object = None
    plan: tuple = ()
    wrenches: np.ndarray | None = None
    tick: int = 0
    publish_time: float = 0.0             # wall s spent publishing (the interface's cost per tick)
    open_time: float = 0.0                # wall s to open the participant and writers (first tick)
    finalizer: object = None
    now: float = 0.0                      # sim time of the first tick (the /tf_static stamp)
    rtf: tuple | None = None              # (period in ticks, writer, Float64) of /sim/real_time_factor
    rtf_last: tuple | None = None         # (sim t, wall s) at the last real-time-factor tick
    real_time_factor: float | None = None
    said: bool = False                    # the start-of-run table printed (qos_table.print_start)

    def close(self) -> None:
        """Close the participant now (otherwise when the run's cache is dropped)."""
        if self.finalizer is not None:
            self.finalizer()
        self.finalizer, self.dds = None, None
