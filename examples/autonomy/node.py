"""The autonomy node: lidar + odometry in, its own cost map, a planned path, screw and bend commands out.

Run it beside ``snakesim run perception-obstacle-course --ros2-commands --ros2-lockstep --odometry head``
(README.md gives the full line). It is a plain ROS 2 participant on cyclonedds with the standard messages
(:mod:`messages`); the domain is ROS_DOMAIN_ID and Cyclone's settings come from CYCLONEDDS_URI, as for
any ROS 2 node. Its loop, once per control period (lockstep: the sim holds until it answers):

    /joint_states (t)      the state at t: joint names, and the cue to answer
    /tf, /tf_static        every link's pose in world; the lidar frame on its link
    /odom/ground_truth     the head's pose (``--odometry head``)
    /<lidar>/points        PointCloud2 in the lidar frame -> world, each return from the pose its beam
                           fired at (:mod:`deskew`) -> the cost map (:mod:`cost_map`), returns within
                           ``self_radius`` of a link dropped (the robot's own body)
    every ``replan`` s     Dijkstra from the head to the goal (:mod:`planner`)
    /joint_command         JointState stamped t: screws by velocity, bends by position (:mod:`follower`)

A state it missed (the sim published t = 0 before this node's reader had matched it) is answered from
/clock, which a held sim repeats with the time it holds at; before any joint names are known, with an
empty JointState (the sim rejects it with a warning, and it releases the period all the same).
It stops the screws once the head is within ``goal_radius`` of the goal, answers a few more periods
and leaves; with ``--log FILE`` it writes what it did (JSON: the stamps it answered, each /clock it saw
against its last answer, the head's track, the path, and from the clouds' ground-truth ``label`` field the
obstacles each mapped scan showed: never used to map, only to score the map), with ``--picture FILE`` a PNG of
the map, path and track. Units: m, rad, s; frame ``world``.
"""

import argparse
import json
import os
import sys
import time

import numpy as np
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from scipy.spatial import cKDTree

if __package__ in (None, ""):                 # run as a script: its folder holds the other modules
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from cost_map import CostMap, CostMapParams  # noqa: E402
from deskew import deskew  # noqa: E402
from follower import Follower, FollowerParams  # noqa: E402
from messages import (QOS_CLOCK, QOS_DEFAULT, QOS_SENSOR, QOS_TF, QOS_TF_STATIC, Clock, Header,  # noqa: E402
                      JointState, Odometry, PointCloud2, TFMessage, Time)
from planner import plan  # noqa: E402

PERIOD = 0.01          # s, the sim's control period (--ros2-lockstep holds at 100 Hz)


def rotation(q) -> np.ndarray:
    """3x3 rotation matrix of a quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def transform(tf) -> tuple[np.ndarray, np.ndarray]:
    """(R, p) of a geometry_msgs/Transform."""
    r, t = tf.rotation, tf.translation
    return rotation((r.x, r.y, r.z, r.w)), np.array([t.x, t.y, t.z])


def cloud_points(msg: PointCloud2) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """x, y, z [n, 3] of a PointCloud2's returns (NaN points, the beams without a return, dropped), and those
    of its optional fields it has, per return: ``t`` (float32 s, the firing time relative to the stamp, for
    :mod:`deskew`) and ``label`` (uint16, the simulator's ground truth of what each beam hit)."""
    offs = {f.name: f.offset for f in msg.fields}
    extra = [(name, fmt) for name, fmt in (("t", "<f4"), ("label", "<u2")) if name in offs]
    names, formats = ["x", "y", "z"] + [n for n, _ in extra], ["<f4"] * 3 + [f for _, f in extra]
    dt = np.dtype({"names": names, "formats": formats, "offsets": [offs[n] for n in names],
                   "itemsize": msg.point_step})
    cloud = np.frombuffer(msg.data, dtype=dt, count=msg.width * msg.height)
    xyz = np.stack([cloud["x"], cloud["y"], cloud["z"]], axis=1).astype(float)
    ok = np.isfinite(xyz).all(axis=1)
    return xyz[ok], {name: cloud[name][ok] for name, _ in extra}


def stamp_key(stamp) -> int:
    """A message stamp as whole microseconds: the key that pairs a cloud with the /tf of its instant."""
    return int(round(stamp.seconds() * 1e6))


class AutonomyNode:
    """One ROS 2 participant: the readers and the writer above, the map, the plan and the follower's state."""

    def __init__(self, args):
        self.args = args
        dp = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))
        self.dp = dp
        self.states = DataReader(dp, Topic(dp, "rt/joint_states", JointState), QOS_DEFAULT)
        self.tf = DataReader(dp, Topic(dp, "rt/tf", TFMessage), QOS_TF)
        self.tf_static = DataReader(dp, Topic(dp, "rt/tf_static", TFMessage), QOS_TF_STATIC)
        self.odom = DataReader(dp, Topic(dp, "rt/odom/ground_truth", Odometry), QOS_DEFAULT)
        self.points = DataReader(dp, Topic(dp, f"rt/{args.lidar}/points", PointCloud2), QOS_SENSOR)
        self.clock = DataReader(dp, Topic(dp, "rt/clock", Clock), QOS_CLOCK)
        self.command = DataWriter(dp, Topic(dp, "rt/joint_command", JointState), QOS_DEFAULT)
        self.map = CostMap(CostMapParams(inflate=args.inflate))
        self.links: dict[str, tuple[np.ndarray, np.ndarray]] = {}     # link -> (R, p) in world, latest
        # the links at each recent /tf stamp (µs): a cloud is placed with the poses of its own stamp, never
        # with whatever /tf arrived last (under load the two drift apart by a tick or more)
        self.links_at: dict[int, dict[str, tuple[np.ndarray, np.ndarray]]] = {}
        self.pending: list = []                # clouds whose stamp's /tf has not arrived yet
        self.static: dict[str, tuple[str, np.ndarray, np.ndarray]] = {}   # frame -> (parent, R, p)
        self.head = None
        self.path = None
        self.follower = None
        self.last_plan = -np.inf
        self.answered: list[float] = []
        self.clock_vs_answer: list[tuple[float, float]] = []
        self.track: list[tuple] = []           # (t, head x, y, tail x, y, bend) per period, m and rad
        self.reached_at = None
        self.scans = 0
        self.evidence: dict[int, list] = {}    # obstacle label -> its range (m) in each mapped scan that showed it
        self.wall, self.cues = [], []           # wall time of each answer; what prompted it

    # -- inputs -----------------------------------------------------------------------------------
    def take_frames(self) -> None:
        for msg in self.tf_static.take(N=100):
            if isinstance(msg, TFMessage):
                for ts in msg.transforms:
                    self.static[ts.child_frame_id] = (ts.header.frame_id, *transform(ts.transform))
        for msg in self.tf.take(N=1000):
            if isinstance(msg, TFMessage):
                for ts in msg.transforms:
                    self.links[ts.child_frame_id] = transform(ts.transform)
                    at = self.links_at.setdefault(stamp_key(ts.header.stamp), {})
                    at[ts.child_frame_id] = self.links[ts.child_frame_id]
        while len(self.links_at) > 200:
            del self.links_at[min(self.links_at)]
        for msg in self.odom.take(N=100):
            if isinstance(msg, Odometry):
                p = msg.pose.pose.position
                self.head = np.array([p.x, p.y, p.z])

    def mount(self, frame: str, links: dict):
        """(link, R, p): the moving link (one of ``links``, from /tf) a frame is fixed on, and the frame's pose
        on it through /tf_static; None while the chain is not known."""
        R, p = np.eye(3), np.zeros(3)
        while frame not in links:
            if frame not in self.static:
                return None
            frame, r, q = self.static[frame]
            R, p = r @ R, r @ p + q
        return frame, R, p

    def take_clouds(self) -> None:
        clouds = self.pending + [m for m in self.points.take(N=10) if isinstance(m, PointCloud2)]
        self.pending = []
        newest = max(self.links_at) if self.links_at else None
        for msg in clouds:
            key = stamp_key(msg.header.stamp)
            links = self.links_at.get(key)
            if links is None:
                if newest is None or key > newest:
                    self.pending.append(msg)      # its /tf is still on the way
                continue                          # older than the /tf kept: dropped
            mount = self.mount(msg.header.frame_id, links)
            if mount is None or self.head is None:
                continue
            local, fields = cloud_points(msg)
            keep = np.hypot(local[:, 0], local[:, 1]) < self.args.max_range
            world = self.place(local[keep], fields["t"][keep] if "t" in fields else None, key, mount, links)
            body = cKDTree(np.array([p for _, p in links.values()]))
            near, _ = body.query(world, distance_upper_bound=self.args.self_radius)
            mapped = np.isinf(near)                      # inf: no link within self_radius
            self.map.add(world[mapped])
            self.scans += 1
            if "label" in fields:
                R, p = links[mount[0]]
                self.count_evidence(world[mapped], fields["label"][keep][mapped], R @ mount[2] + p)

    def place(self, local: np.ndarray, tau, key: int, mount: tuple, links: dict) -> np.ndarray:
        """World positions of a cloud's points (lidar frame), stamped ``key`` (µs): deskewed (:mod:`deskew`)
        between the mount link's /tf at the sweep's start and at the stamp where the cloud has firing times
        and the earlier /tf is kept; else all placed with the pose at the stamp."""
        link, R_ls, p_ls = mount
        R, p = links[link]
        if tau is not None and len(tau):
            start = key + int(np.floor(float(tau.min()) * 1e6)) + 1   # µs; float32 times: a hair of slack
            earlier = [k for k, at in self.links_at.items() if k <= start and link in at]
            if earlier:
                k0 = max(earlier)
                return deskew(local, tau, key * 1e-6, (k0 * 1e-6, *self.links_at[k0][link]), (key * 1e-6, R, p),
                              (R_ls, p_ls))
        return local @ (R @ R_ls).T + (R @ p_ls + p)

    def count_evidence(self, world: np.ndarray, label: np.ndarray, origin: np.ndarray) -> None:
        """Score, never map: from the cloud's ground-truth labels, note each obstacle (label 2000 + i) that this
        mapped scan showed standing clear of the ground (``evidence_returns`` returns more than 2·max_step above
        the median of the scan's terrain returns, labels 1..999), with the horizontal range (m) of the nearest
        of them from the lidar at ``origin``. The log's ``evidence`` (label -> one range per scan) says what
        the map was shown, so its recall can be judged."""
        terrain = (label >= 1) & (label < 1000)
        if not terrain.any():
            return
        high = (label >= 2000) & (world[:, 2] > np.median(world[terrain, 2]) + 2 * self.map.p.max_step)
        reach = np.hypot(*(world[high, :2] - origin[:2]).T)
        for i in np.unique(label[high]):
            mine = label[high] == i
            if mine.sum() >= self.args.evidence_returns:
                self.evidence.setdefault(int(i), []).append(round(float(reach[mine].min()), 3))

    def take_clock(self) -> None:
        last = self.answered[-1] if self.answered else -np.inf
        for msg in self.clock.take(N=100):
            if isinstance(msg, Clock):
                self.clock_vs_answer.append((msg.clock.seconds(), last))

    # -- the control period -----------------------------------------------------------------------
    def answer(self, t: float, names: list[str], cue: str = "state") -> None:
        """Plan when due, then send the command that answers the state at t."""
        a = self.args
        if self.follower is None:
            self.follower = Follower(names, FollowerParams(speed=a.speed))
        tail = self.links.get(a.tail, (None, None))[1]
        head = self.head
        stop = True
        if head is not None and tail is not None:
            self.track.append((t, float(head[0]), float(head[1]), float(tail[0]), float(tail[1]), self.follower.bend))
            if np.hypot(*(head[:2] - a.goal)) < a.goal_radius and self.reached_at is None:
                self.reached_at = t
            if self.scans and t - self.last_plan >= a.replan and self.reached_at is None:
                path = plan(self.map, self.map.cost(), head[:2], a.goal)
                self.path = path if path is not None else self.path
                self.last_plan = t
            stop = self.reached_at is not None or self.path is None or t < a.settle
        position, velocity = self.follower.command(head, tail, self.path, PERIOD, stop=stop)
        self.command.write(JointState(header=Header(stamp=Time.of(t)), name=self.follower.joints,
                                      position=[float(v) for v in position], velocity=[float(v) for v in velocity]))
        self.answered.append(t)
        self.cues.append(cue)
        self.wall.append(time.monotonic())

    def run(self) -> None:
        a = self.args
        deadline = time.monotonic() + a.timeout
        last_seen = time.monotonic()
        held = None
        while time.monotonic() < deadline:
            self.take_clock()
            states = [m for m in self.states.take(N=100) if isinstance(m, JointState)]
            if not states:
                # the sim holds at a tick whose state this node missed (it joined late): /clock says which
                if self.clock_vs_answer:
                    held = self.clock_vs_answer[-1][0]
                if time.monotonic() - last_seen > 0.3 and held is not None and held > (
                        self.answered[-1] if self.answered else -1) + 1e-9:
                    self.take_frames()
                    if self.follower is None:      # no joint names yet: a bare message releases the period
                        self.command.write(JointState(header=Header(stamp=Time.of(held))))
                        self.answered.append(held)
                        self.cues.append("clock")
                        self.wall.append(time.monotonic())
                    else:
                        self.answer(held, self.follower.joints, cue="clock")
                    last_seen = time.monotonic()
                elif time.monotonic() - last_seen > a.quiet and self.answered:
                    break                                   # the run ended
                time.sleep(0.0002)
                continue
            last_seen = time.monotonic()
            self.take_frames()
            self.take_clouds()
            for msg in states:
                t = msg.header.stamp.seconds()
                if self.answered and t <= self.answered[-1] + 1e-9:
                    continue
                self.answer(t, list(msg.name))
            if self.reached_at is not None and self.answered[-1] - self.reached_at > a.linger:
                break
        self.finish()

    def finish(self) -> None:
        a = self.args
        head = self.head.tolist() if self.head is not None else None
        result = {"reached": self.reached_at is not None, "reached_at": self.reached_at, "head": head,
                  "goal": list(a.goal), "answered": self.answered, "clock_vs_answer": self.clock_vs_answer,
                  "track": self.track, "path": self.path.tolist() if self.path is not None else None,
                  "scans": self.scans, "evidence": self.evidence, "wall": self.wall, "cues": self.cues,
                  "obstacles": self.map.center(*np.nonzero(self.map.obstacles())).tolist()}
        if a.log:
            with open(a.log, "w") as f:
                json.dump(result, f)
        if a.picture:
            from picture import write_picture

            write_picture(a.picture, self.map, self.path, np.array(self.track).reshape(-1, 6)[:, 1:3], a.goal)
        print(json.dumps({k: result[k] for k in ("reached", "reached_at", "head", "scans")}), flush=True)


def parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goal", type=float, nargs=2, default=(9.0, -2.7), metavar=("X", "Y"), help="m, world")
    ap.add_argument("--goal-radius", type=float, default=0.4, help="m: the head within it has arrived")
    ap.add_argument("--lidar", default="lidar", help="the lidar's topic is /<lidar>/points")
    ap.add_argument("--tail", default="tail", help="the tail link (its /tf pose sets the body's heading)")
    ap.add_argument("--speed", type=float, default=10.0, help="rad/s of the front screws (URDF limit 10)")
    ap.add_argument("--inflate", type=float, default=0.9,
                    help="m, lethal radius around obstacles (the robot's swept half-width)")
    ap.add_argument("--self-radius", type=float, default=0.25, help="m: returns this close to a link are the robot")
    ap.add_argument("--max-range", type=float, default=6.0, help="m: farther returns are not mapped")
    ap.add_argument("--evidence-returns", type=int, default=10,
                    help="returns clear of the ground that make a scan's evidence of an obstacle (--log's evidence)")
    ap.add_argument("--settle", type=float, default=1.0, help="s of sim time before driving (the robot settles)")
    ap.add_argument("--replan", type=float, default=1.0, help="s of sim time between plans")
    ap.add_argument("--linger", type=float, default=0.5, help="s of sim time answered after arriving")
    ap.add_argument("--quiet", type=float, default=5.0, help="wall s without a state: the run has ended")
    ap.add_argument("--timeout", type=float, default=600.0, help="wall s at most")
    ap.add_argument("--log", help="write a JSON log here")
    ap.add_argument("--picture", help="write a PNG of the cost map, path and track here")
    a = ap.parse_args(argv)
    a.goal = np.array(a.goal, dtype=float)
    return a


if __name__ == "__main__":
    AutonomyNode(parse()).run()
