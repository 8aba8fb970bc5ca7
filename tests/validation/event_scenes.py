"""Event cases shared by the tests (tests/contact/test_contact_events.py) and bench/events.py: the default
scene's robot dropped onto the ice from a height, its screws idle, at any integrator setting, and what a
drop is judged by (the centre of mass never above its start, the rest pose against a converged RK4 run)."""

from __future__ import annotations

import numpy as np

from snakesim.framework.session import load_session

SCENE = "surface-screw-traverse"
REST_Z = 0.0898                   # m: the default scene's base height, its screw envelopes just pressing the ice
REFERENCE = {"name": "rk4", "params": {}}
REFERENCE_DT = 2e-4               # s: RK4 converged on these drops (0.1 ms moves the rest pose by < 0.05 mm)


def drop(height: float, integrator: dict | None = None, dt: float | None = None, duration: float = 1.0,
         sets=()):
    """The default robot released ``height`` m above its resting height, screws idle (the schedule's settle
    outlasts the run). ``integrator``/``dt`` None: the scene's own (what a user gets). Returns the run."""
    sim = {"duration": duration}
    if integrator is not None:
        sim["integrator"] = integrator
    if dt is not None:
        sim["dt"] = dt
    s = load_session(SCENE, overrides=[f"components.robot.params.base_position=[0,0,{REST_Z + height!r}]",
                                       f"settle={duration + 1.0!r}", *sets], sim_overrides=sim)
    return s.run()


def reference_drop(height: float, duration: float = 1.0):
    return drop(height, REFERENCE, REFERENCE_DT, duration)


def rise_above_start(r) -> float:
    """m: the largest height of the centre of mass above where it started (> 0: energy was injected)."""
    z = np.asarray(r["robot.com"])[:, 2]
    return float(z.max() - z[0])


def rest_offset(r, ref) -> float:
    """m: the largest distance between a link origin at the end of ``r`` and in the reference."""
    a = np.asarray(r["robot.link_poses"])[-1].reshape(-1, 7)[:, :3]
    b = np.asarray(ref["robot.link_poses"])[-1].reshape(-1, 7)[:, :3]
    return float(np.linalg.norm(a - b, axis=1).max())


# -- a braced robot started off a wall (tube, U-channel) ----------------------------------------------------------

#: the body-respecting brace scenes: EELS 1.5 braced by screws on both walls, every link colliding, joint stops on
WALL_SCENES = {"tube": "tube-body-brace", "u-channel": "u-channel-body-brace-traverse"}
WALL_GAP = 5e-4                   # m: the bracing screws of one wall start this far off it
#: the converged reference of the wall cases. Not RK4: the walls' regularised friction (μ 1.5, v_ε 0.1-0.2 mm/s,
#: ~100 N per screw) has a slope μ F_n / v_ε ~ 1e6 N·s/m, a mode of ~1e5 /s that RK4 resolves only below ~20 µs
#: (the tube brace shifted 0.5 mm: RK4 at 0.1 and 0.05 ms sinks 4.9 and 2.5 mm in 2 s, converging linearly to the
#: implicit solution's 0.26 mm; at 1 ms 70-75 mm). rosenbrock_w under error control at tolerances 30x below its
#: defaults, J at every step, h_min lowered so that the onset's short steps are not refused: tolerances 10x tighter
#: again, and fixed 0.1 ms steps with J at every step, move the 2 s end pose by <= 5 µm (bench/events.py
#: --check-references prints the first).
WALL_REFERENCE = {"name": "rosenbrock_w", "params": {"method": "ros2", "step_control": "error", "atol_q": 1e-5,
                                                     "atol_v": 1e-4, "rtol": 1e-4, "h_min": 1e-10,
                                                     "jacobian_every": 1, "jacobian_refresh": "steps",
                                                     "refresh_window": 0.0, "substeps": 1, "refresh_substeps": 1}}
WALL_REFERENCE_DT = 0.01


def contact_depths(session, component: str = "contact") -> list[tuple[str, float, np.ndarray]]:
    """(link, deepest penetration m, mean outward terrain normal) per link that ``component`` (a contact
    model with a ``contact_set`` output) finds in the terrain at the session's initial state."""
    plan = session.plan
    plan.f(session.resolved.sim.t0, plan.X.copy())          # every output at X0
    _, u, y = plan.io[component]
    plan.components[component].calc_contact_set(session.resolved.sim.t0, None, u, y)
    cs = y.contact_set
    out = []
    for link in np.unique(cs.link):
        m = cs.link == link
        n = cs.normals[m].mean(axis=0)
        out.append((cs.link_names[link], float(cs.depth[m].max()), n / np.linalg.norm(n)))
    return out


def wall_offset(scene: str, gap: float = WALL_GAP) -> tuple[list[str], dict]:
    """``--set`` items that translate the scene's fitted brace (its ``pose`` parameter: the base of a
    ``shape: {kind: joints}`` placement) along the normal of the wall that most bracing screws press, until
    the deepest of them is ``gap`` m clear of it; the other wall's screws go deeper by as much. And what was
    done: the wall's normal, the offset, each screw's depth before."""
    s = load_session(scene)
    screws = contact_depths(s)
    normals = np.array([n for _, _, n in screws])
    # the wall pressed by the most screws: group the screws by their normal's side
    side = np.sign(normals @ normals[0])
    wall = side == (1.0 if (side > 0).sum() >= (side < 0).sum() else -1.0)
    n = normals[wall].mean(axis=0)
    n /= np.linalg.norm(n)
    shift = max(d / float(n @ m) for (_, d, _), m, w in zip(screws, normals, wall) if w) + gap
    pose = s.resolved.parameters["pose"]
    p0 = np.array([float(v) for v in pose["position"]])
    p = p0 + shift * n                                      # along the outward normal: away from that wall
    info = {"normal": n.tolist(), "offset_m": float(shift), "gap_m": gap,
            "screws": {name: {"depth_m": d, "off_wall": bool(w)} for (name, d, _), w in zip(screws, wall)}}
    return [f"pose.position={[float(v) for v in p]!r}"], info


def off_wall(scene: str, integrator: dict | None = None, dt: float | None = None, duration: float = 2.0,
             gap: float = WALL_GAP, sets=()):
    """The braced robot of ``scene`` (a WALL_SCENES value) started ``gap`` off one wall (wall_offset) and held
    (the U-channel's screws start at 3 s: ``duration`` below that is a hold). ``integrator``/``dt`` None: the
    scene's own."""
    return off_wall_session(scene, integrator, dt, duration, gap, sets)[0].run()


def off_wall_session(scene: str, integrator: dict | None = None, dt: float | None = None, duration: float = 2.0,
                     gap: float = WALL_GAP, sets=()):
    """(the session of :func:`off_wall`, wall_offset's account of the move)."""
    move, info = wall_offset(scene, gap)
    sim = {"duration": duration}
    if integrator is not None:
        sim["integrator"] = integrator
    if dt is not None:
        sim["dt"] = dt
    return load_session(scene, overrides=[*move, *sets], sim_overrides=sim), info


def reference_off_wall(scene: str, duration: float = 2.0, gap: float = WALL_GAP):
    return off_wall(scene, WALL_REFERENCE, WALL_REFERENCE_DT, duration, gap)


# -- a /sim/set_pose placement mid-run -------------------------------------------------------------------------------

def scripted_set_pose_class():
    """``ros2_sim_control`` (the ROS 2 gate, components/ros2/sim_control.py) with its DDS poll replaced by one
    scripted /sim/set_pose message (geometry_msgs/PoseStamped, world frame, stamped now) at the first control
    tick at or after ``at``: the gate validates it (placement_requests.pose_write: the base pose, every velocity
    zero), queues it and hands it to the step loop in its edit_state, as it does a message from the network."""
    from pydantic import Field

    from snakesim.components.ros2 import messages as M
    from snakesim.components.ros2.placement_requests import POSE_TOPIC
    from snakesim.components.ros2.sim_control import Ros2SimControl, Ros2SimControlParams

    class ScriptedSetPoseParams(Ros2SimControlParams):
        at: float = Field(0.5, description="s: sim time of the request")
        position: tuple[float, float, float] = (0.0, 0.0, 0.0)
        quaternion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)

    class ScriptedSetPose(Ros2SimControl):
        type_name = "scripted_set_pose"
        Params = ScriptedSetPoseParams

        def poll(self, run, t: float = 0.0) -> bool:
            if getattr(run, "scripted_sent", False) or t < self.p.at - 1e-9:
                return False
            run.scripted_sent = True
            (px, py, pz), (qx, qy, qz, qw) = self.p.position, self.p.quaternion
            msg = M.PoseStamped(header=M.Header(stamp=M.time_msg(t), frame_id=self.p.world_frame),
                                pose=M.Pose(position=M.Point(x=px, y=py, z=pz),
                                            orientation=M.Quaternion(x=qx, y=qy, z=qz, w=qw)))
            self.request(run, POSE_TOPIC, msg, t)
            return True

    return ScriptedSetPose


_SET_POSE = []


def _registry_with_set_pose():
    from snakesim.framework.registry import default_registry

    reg = default_registry()
    if not _SET_POSE:
        _SET_POSE.append(scripted_set_pose_class())
    if "scripted_set_pose" not in reg.components:
        reg.add_component(_SET_POSE[0])
    return reg


def set_pose_drop(height: float, integrator: dict | None = None, dt: float | None = None, duration: float = 1.5,
                  at: float = 0.5):
    """The default robot resting on the ice (screws idle), placed by a /sim/set_pose request at ``at`` s with its
    base ``height`` m above its resting height, in its initial orientation, at rest: it drops from there.
    ``integrator``/``dt`` None: the scene's own. Returns (run, the set_pose control tick's time)."""
    from snakesim.framework.assembly import ComponentSpec, resolve
    from snakesim.framework.session import Session

    reg = _registry_with_set_pose()
    sim = {"duration": duration}
    if integrator is not None:
        sim["integrator"] = integrator
    if dt is not None:
        sim["dt"] = dt
    resolved = resolve(SCENE, search_path=reg.assembly_paths(), overrides=[f"settle={duration + 1.0!r}"],
                       sim_overrides=sim)
    quat = [float(v) for v in resolved.components["robot"].params["base_quaternion"]]
    period = max(resolved.sim.dt, 0.02)                    # the gate's control period: a multiple of the step
    resolved.components["set_pose"] = ComponentSpec(
        type="scripted_set_pose", rate=1.0 / period, uses={"robot": "robot"},
        params={"robot_state": "robot", "at": at, "position": [0.0, 0.0, REST_Z + height], "quaternion": quat})
    return Session(resolved, reg).run()


def released(r, at: float) -> np.ndarray:
    """Rows of ``r`` after the set_pose edit (the state at the tick after ``at`` is the placed one)."""
    return np.asarray(r["t"]) > at + 1e-9


# -- the lively free robot (issue 24) ----------------------------------------------------------------------------------

LIVELY = ['components.robot.params.v0={"bend_*": 0.6, "twist_*": -0.4, "screw_*": 5}',
          'components.robot.params.q0={"bend_*": 0.1, "twist_*": -0.2}',
          'components.robot.params.base_velocity=[0.1, 0, 0, 0.2, -0.1, 0.3]',
          'record=[robot.momentum, robot.energy, robot.com, robot.link_poses]']


def free_robot(integrator: dict | None = None, dt: float | None = None, duration: float = 2.0):
    """robot-zero-g with every joint moving (no gravity, torque, contact: nothing external acts)."""
    sim = {"duration": duration}
    if integrator is not None:
        sim["integrator"] = integrator
    if dt is not None:
        sim["dt"] = dt
    return load_session("robot-zero-g", overrides=LIVELY, sim_overrides=sim).run()


def invariant_drift(r) -> dict:
    """Per second of the run, max over it of |I(t) − I(0)| / |I(0)| for the kinetic energy (links and rotors),
    the linear momentum P and the angular momentum about the centre of mass L_G (world axes): the multibody's
    own outputs (Pinocchio's centroidal momentum of the recorded state)."""
    h, c = np.asarray(r["robot.momentum"]), np.asarray(r["robot.com"])
    P = h[:, :3]
    inv = {"energy": np.asarray(r["robot.energy"]).sum(axis=1)[:, None], "P": P, "L_G": h[:, 3:] - np.cross(c, P)}
    T = float(np.asarray(r["t"])[-1] - np.asarray(r["t"])[0])
    return {k: float(np.linalg.norm(v - v[0], axis=1).max() / np.linalg.norm(v[0]) / max(T, 1e-12))
            for k, v in inv.items()}
