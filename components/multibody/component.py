"""Free-floating multibody (Pinocchio) from a URDF: the robot's rigid-body dynamics.

A 6-DOF free-flyer at the URDF's root link (the tail), revolute/continuous
joints, fixed joints and massless links merged into frames (paper 2.1.4),
counter-rotating screw pairs (``<mimic multiplier="-1">``) as one DOF
(paper 2.1.3, see :mod:`.model`).

in   tau[nj]            N·m   joint torques, DOF joints in URDF order (default 0)
     wrenches[nl, 6]    N, N·m external wrench on each URDF link (default 0):
                        [f, τ] in WORLD axes, τ about the LINK ORIGIN
     gravity[1] or [3]  params.gravity_input "scale": [s], gravity = s·params.gravity
                        (0 off, 1 on); "vector": the gravity vector in m/s².
                        Unconnected (or NaN): params.gravity
out  state only (no feedthrough):
     q[nq], v[nv]             Pinocchio coordinates (free-flyer v in the tail frame)
     joint_q[nj], joint_v[nj] DOF joint angles (continuous joints wrapped to (-π, π]) and rates
     link_poses[nl, 7]        [x, y, z, qx, qy, qz, qw] of each link frame, world
     link_rotations[nl, 3, 3] link axes in the world
     link_velocities[nl, 6]   [v of link origin, ω], world axes
     momentum[6]              [P, L about the world origin] of all links, world
     com[3]                   centre of mass, world
     feedthrough from gravity only:
     energy[2]                [kinetic (links + rotor armature), potential (-Σ m g·c)], J
     feedthrough from all inputs:
     a[nv]                    dv/dt
     link_accelerations[nl,6] classical [a of link origin, α], world axes, gravity NOT included
                              (an IMU reads a - g)
     joint_wrenches[nl, 6]    for each link, the wrench its parent side exerts on it across its
                              parent joint (fixed or moving), [f, τ] in the link's frame about its
                              origin (paper 2.2.4: force-torque sensors read rows of it); the
                              root's row is zero
continuous state: [q, v] on the configuration manifold (pin.integrate), second order

provides  robot: RobotModel   the built robot (robot_model.py), handed to every component that
                             declares ``Uses(RobotModel)``: a scene names its robot only here

Port layout (element names are the recorded column names, ``robot.q.root_joint.qw``):

    q[nq]   root_joint.x, .y, .z (tail origin, world), root_joint.qx, .qy, .qz, .qw (the tail's
            orientation quaternion, x, y, z, w: scalar LAST), then per moving joint in Pinocchio
            order (parents first): a revolute joint one angle (``bend_00``), a continuous joint
            two numbers, its (cos, sin) (``screw_front_00.cos``, ``.sin``); mimic joints (the rear
            screw of a counter-rotating pair) have none: they follow their primary
    v[nv]   root_joint.vx, .vy, .vz (tail origin velocity, TAIL frame), .wx, .wy, .wz, then one
            rate per DOF joint (continuous joints included)
    joint_q, joint_v, tau [nj]
            the DOF joints only: revolute and continuous joints that are not mimics, URDF order;
            fixed joints and mimic followers (``screw_rear_*``) are omitted; continuous joints
            as one angle wrapped to (-π, π]

Armature: the URDF carries none, so each DOF gets a reflected rotor inertia (a geared
joint's motor, J_m·N²): the design's per-kind table (``Design.armature_per_effort``, kg·m²
per N·m of effort limit: EELS 1.0 bend 0.24, twist 0.12, screw 0.021 kg·m²) unless the
scene sets ``armature`` (by joint or pattern) or ``armature_per_effort`` (by kind: bend,
twist, screw, other); ``armature: {"*": 0}`` removes it (what another engine reading
the same URDF simulates). ``snakesim check`` prints each value and
its source.

Joint stops (``joint_stops: {enabled: true}``, off by default): a one-sided spring-damper past each
limited joint's URDF position limits, added to the generalised force before the forward dynamics,
its slopes in the implicit step's Jacobian (joint_stops.py).

Blow-up guard (``blowup_guard: {enabled: true, factor: 10, floor: 0.2}``, on by default): once per
base step (``check``, never in the integrator's stages) the robot's kinetic energy gain over the step
is compared with what gravity (exactly) and the joint torques, joint stops and link wrenches (their
power at the step's two ends, times h, times ``factor``) can supply; more than that by ``floor`` J/kg
stops the run as a failure of kind ``blow_up`` naming the step and the link whose kinetic energy rose
the most (blowup_guard.py), before an explicit integrator's runaway reaches a non-finite state.

Links (nl) are the URDF's <link> elements in document order, massless
frames included; DOF joints (nj) the moving joints that are not mimics, in
URDF order (``robot.links`` and ``robot.joints``; with the usual
parents-first URDF, v[6:] is in that order too).

Integration: ``integrate`` is pin.integrate (the quaternion and the (cos, sin)
of continuous joints stay on their manifolds), in numba (lie_kernels.py: the same
operations, bit for bit in tests, without Python's per-call conversion). ``dexp_inv`` is the
Munthe-Kaas stage correction the framework's multi-stage integrators (RK4,
DOPRI5, ROS2) apply so they keep their order on SE(3) (see
tests/multibody/test_conservation.py).

Forward dynamics (``params.dynamics``): ``tree`` (auto's choice unless screw_pairs is
mimic_crba) is the articulated-body recursion on the link tree in numba
(articulated_solve_kernels.forward_step: Newton–Euler bias forces with zero joint
accelerations, M eliminated DOF by DOF from the leaves; equal to Pinocchio's ABA to round-off,
tests/multibody/test_articulated_solve.py, and as fast: 97 against 109 µs at 100 modules);
``pinocchio`` is Pinocchio's ABA. Why: Pinocchio 4.1 allocates and zeroes four nv³
second-order derivative tensors in every Data (model.new_data): 0.92 GB and ~3 s to build at
100 EELS-1.0 modules (nv = 306), 28 MB at 30. On the tree no Data is made at all (the model's
Data is built on first use: ``pinocchio`` dynamics, the dense fallbacks, ``snakesim check
--baseline``); a 100-module run peaks at ~0.28 GB instead of 1.2 GB.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Literal

import numpy as np
from pydantic import Field

from snakesim.framework import Component, ContinuousState, Input, Output, Provides

from . import joint_values
from ..kernel_args import bind
from ..port_roles import JOINT_POSITIONS, JOINT_VELOCITIES, JOINT_WRENCHES, LINK_POSES, LINK_VELOCITIES
from .blowup_guard import BlowupGuardParams, blow_up_reason
from .joint_stops import JointStopsParams, build as build_joint_stops
from .lie_kernels import dexp_inv6, integrate_state, joint_layout
from .linearization import mechanical_block
from .robot_model import RobotModel, RobotSource
from .robot_ports import joint_names, joint_shape, link_element_names, link_shape

Vec3 = tuple[float, float, float]


class MultibodyParams(RobotSource):
    # initial state
    base_position: Vec3 = (0.0, 0.0, 0.0)
    base_yaw: float = Field(0.0, description="rad about world z; ignored if base_quaternion is given")
    base_quaternion: tuple[float, float, float, float] | None = Field(None, description="(x, y, z, w)")
    base_velocity: tuple[float, float, float, float, float, float] = Field(
        (0.0,) * 6, description="[v of tail origin, ω], world axes, m/s and rad/s")
    q0: dict[str, float] | list[float] = Field(default_factory=dict, description="joint angles, by name/pattern or a vector")
    v0: dict[str, float] | list[float] = Field(default_factory=dict, description="joint rates, by name/pattern or a vector")
    # physics
    gravity: Vec3 = (0.0, 0.0, -9.81)
    gravity_input: Literal["scale", "vector"] = "scale"
    armature: dict[str, float] = Field(default_factory=dict, description="kg·m² by joint name or pattern")
    armature_per_effort: dict[str, float] = Field(
        default_factory=dict, description="default armature per joint kind, kg·m² per N·m of the URDF effort "
                                          "limit; overrides bend 2e-3, twist 2e-3, screw 7e-4, other 1e-3")
    armature_floor: float = Field(1e-3, ge=0, description="kg·m², least default armature")
    damping: dict[str, float] = Field(default_factory=dict, description="N·m·s/rad by joint name or pattern")
    screw_pairs: Literal["auto", "embedded", "mimic_crba"] = "auto"
    dynamics: Literal["auto", "tree", "pinocchio"] = Field(
        "auto", description="forward dynamics: 'tree' the articulated-body recursion on the link tree "
                            "(no Pinocchio Data: O(nv³) bytes), 'pinocchio' its ABA; auto: tree unless "
                            "screw_pairs is mimic_crba")
    joint_stops: JointStopsParams = Field(default_factory=JointStopsParams,
                                          description="end stops at the URDF position limits (joint_stops.py)")
    blowup_guard: BlowupGuardParams = Field(default_factory=BlowupGuardParams,
                                            description="stop the run when a step's kinetic energy gain is more than "
                                                        "the joints, external wrenches and gravity can supply "
                                                        "(blowup_guard.py; failure kind blow_up)")


SIX = ("vx", "vy", "vz", "wx", "wy", "wz")


class Multibody(Component[MultibodyParams]):
    type_name = "multibody"

    robot = Provides(RobotModel, doc="the built robot: links, joints, frames, geometry, screws")

    tau = Input(shape=joint_shape, unit="N*m", default=0.0, names=joint_names)
    wrenches = Input(shape=link_shape(6), unit=None, default=0.0,
                     names=link_element_names(("fx", "fy", "fz", "tx", "ty", "tz")))
    gravity = Input(shape=lambda c: (1,) if c.p.gravity_input == "scale" else (3,), unit=None, default=np.nan)

    q = Output(shape=lambda c: (c.robot.nq,), unit=None, feedthrough=(), calc="calc_state",
               names=lambda c: c.robot.q_names)
    v = Output(shape=lambda c: (c.robot.nv,), unit=None, feedthrough=(), calc="calc_state",
               names=lambda c: c.robot.v_names)
    joint_q = Output(shape=joint_shape, unit="rad", feedthrough=(), calc="calc_state",
                     names=joint_names, role=JOINT_POSITIONS)
    joint_v = Output(shape=joint_shape, unit="rad/s", feedthrough=(), calc="calc_state",
                     names=joint_names, role=JOINT_VELOCITIES)
    link_poses = Output(shape=link_shape(7), unit=None, feedthrough=(), calc="calc_state",
                        names=link_element_names(("x", "y", "z", "qx", "qy", "qz", "qw")), role=LINK_POSES)
    link_rotations = Output(shape=link_shape(3, 3), unit="1", feedthrough=(), calc="calc_state",
                            names=link_element_names(tuple(f"r{i}{j}" for i in range(3) for j in range(3))))
    link_velocities = Output(shape=link_shape(6), unit=None, feedthrough=(), calc="calc_state",
                             names=link_element_names(SIX), role=LINK_VELOCITIES)
    # their own group: read by recorders and stop conditions, not by the derivatives' inputs, so
    # integrator stages (the continuous closure) skip them
    momentum = Output(shape=(6,), unit=None, feedthrough=(), calc="calc_momentum",
                      names=("px", "py", "pz", "lx", "ly", "lz"))
    com = Output(shape=(3,), unit="m", feedthrough=(), calc="calc_momentum", names=("x", "y", "z"))
    energy = Output(shape=(2,), unit="J", feedthrough=("gravity",), calc="calc_energy", names=("kinetic", "potential"))
    a = Output(shape=lambda c: (c.robot.nv,), unit=None, feedthrough=True, names=lambda c: c.robot.v_names)
    link_accelerations = Output(shape=link_shape(6), unit=None, feedthrough=True,
                                names=link_element_names(("ax", "ay", "az", "alphax", "alphay", "alphaz")))
    joint_wrenches = Output(shape=link_shape(6), unit=None, feedthrough=True,
                            names=link_element_names(("fx", "fy", "fz", "tx", "ty", "tz")), role=JOINT_WRENCHES)

    # -- set-up ------------------------------------------------------------------------
    def setup(self):
        import pinocchio

        from . import kernels
        from .articulated_solve_kernels import mass_matrix, tree_plan
        from .model import build_dynamics, choose_mode, tree_arrays

        self._pin = pinocchio
        p = self.p
        if not np.all(np.isfinite(p.gravity)):
            raise ValueError(f"{self.name}: gravity {p.gravity} must be finite")
        robot = self.robot = RobotModel.of(RobotSource.of(p))
        self.mode, self.mode_reason = choose_mode(p.screw_pairs, robot.groups)
        self.armature_user = joint_values.armature(robot, p)
        self.damping_user = joint_values.damping(robot, p)
        self.dyn = build_dynamics(robot.tree, self.mode, self.armature_user, robot.groups)
        model = self.dyn.model
        if (model.nq, model.nv) != (robot.nq, robot.nv):
            raise AssertionError("internal: model layout differs from the port layout")
        self._ta = tree_arrays(robot.tree, model)
        # M's and the implicit step's matrix's elimination on the link tree in O(links)
        # (articulated_solve_kernels.py); None where a DOF's links do not hang from one body
        self._tree_plan = tree_plan(self._ta.order, self._ta.parent, self._ta.jtype, self._ta.vidx, model.nv)[0] \
            if self.mode != "mimic_crba" else None
        self.forward_dynamics = ("tree" if self._tree_plan is not None else "pinocchio") if p.dynamics == "auto" \
            else p.dynamics
        if self.forward_dynamics == "tree" and self._tree_plan is None:
            raise ValueError(f"{self.name}: params.dynamics = 'tree' needs every DOF's links on one body; "
                             f"screw_pairs = '{self.mode}' keeps mimic joints apart: use 'auto' or 'pinocchio'")
        self.structured_solve = True            # False: the implicit step's dense LU (tests compare the two)
        nq, nv = robot.nq, robot.nv
        self._nq, self._nv = nq, nv
        self._dof_v = np.array([model.joints[model.getJointId(j)].idx_v for j in robot.joints], dtype=np.int64)
        jq = [model.joints[model.getJointId(j)] for j in robot.joints]
        self._jq_idx = np.array([m.idx_q for m in jq], dtype=np.int64)
        self._jq_cs = np.array([m.nq == 2 for m in jq], dtype=bool)
        self._damp = np.array([self.damping_user.get(j, 0.0) for j in robot.joints])
        self._arm_v = np.zeros(nv)
        self._arm_v[self._dof_v] = [self.armature_user.get(j, 0.0) for j in robot.joints]
        if self._tree_plan is not None:        # M without a Pinocchio Data (model.Dynamics.data)
            self.dyn.tree_mass_matrix = functools.partial(mass_matrix, self._ta, nv, self._arm_v)
        joint_values.check_mass_matrix(robot, self.dyn, self.name)
        # every link but the root has a parent joint to cut across
        self._cut_links = np.array([i for i, ln in enumerate(robot.links) if ln != robot.tree.root], dtype=np.int64)
        self._g_param = np.array(p.gravity, dtype=float)
        self.dyn.model.gravity.linear[:] = self._g_param
        ta = self._ta
        self._tree = kernels.Tree(
            order=ta.order, parent=ta.parent, jtype=ta.jtype, R0=ta.R0, p0=ta.p0, axis=ta.axis, qidx=ta.qidx,
            qkind=ta.qkind, vidx=ta.vidx, mult=ta.mult, offset=ta.offset, mass=ta.mass, com=ta.com,
            inertia=ta.inertia, jq_idx=self._jq_idx, jq_cs=self._jq_cs, dof_v=self._dof_v, damping=self._damp,
            cut_links=self._cut_links, g_param=self._g_param, gravity_scale=p.gravity_input == "scale")
        self._report = None
        self._selections = None
        self._x0 = joint_values.initial_state(robot, p, model)   # validated here, so errors name the component
        self._lie = joint_layout(model)          # integrate's joint layout (None: a joint lie_kernels lacks)
        self._stops = build_joint_stops(self, p.joint_stops)     # None when off
        self._mass = float(ta.mass.sum())                        # kg, the links' (the guard's floor is per kg)

    def joint_inertia(self) -> np.ndarray:
        """Apparent inertia of each DOF joint (robot.joints order) at the initial state, 1 / (M⁻¹)_ii with
        the armature in M: what a joint's PID gains act on (kg·m², or kg for a prismatic joint)."""
        m = self.dyn.mass_matrix(self._x0[:self._nq])
        return 1.0 / np.diag(np.linalg.inv(m))[self._dof_v]

    def continuous_state(self):
        return ContinuousState(self._x0.copy(), ndx=2 * self._nv,
                               second_order=self._nv,
                               names=self.robot.q_names + tuple(f"{n}.v" for n in self.robot.v_names))

    def integrate(self, x, dx, out):
        nq = self._nq
        if self._lie is None:
            out[:nq] = self._pin.integrate(self.dyn.model, x[:nq], dx[:self._nv])
            np.add(x[nq:], dx[self._nv:], out=out[nq:])
        else:                               # Pinocchio's integrate, in numba (lie_kernels.py)
            integrate_state(x, dx, out, nq, self._nv, *self._lie)

    def bind_integrate(self, x, dx, out):
        """integrate(x, dx, out) for arrays fixed for a run: a call without arguments (plan.bind_integrate)."""
        if self._lie is None:
            return functools.partial(self.integrate, x, dx, out)
        return bind(integrate_state, x, dx, out, self._nq, self._nv, *self._lie)

    def dexp_inv(self, x0, u, k):
        """RKMK hook: ``k`` (a derivative evaluated at x0 ⊕ u) -> the rate of u in the chart at x0, in place.

        The free-flyer's q ⊕ u is q·exp6(u) on SE(3), and a body velocity ξ
        at q·exp6(u) is u̇ = Jexp6(u)⁻¹ ξ in that chart; the other
        coordinates (revolute angles, SO(2) of continuous joints, v) commute
        and pass unchanged. A Runge-Kutta scheme that combines stage
        derivatives in the chart at the step's start point keeps its order
        on the manifold only with this correction (Munthe-Kaas); without it
        classical RK4 is second order in the free-flyer's orientation.
        """
        dexp_inv6(u, k)         # Jexp6(u)⁻¹ = Jlog6(exp6(u)), Pinocchio's closed form in numba (lie_kernels.py)

    def bind_dexp_inv(self, x0, u, k):
        """dexp_inv(x0, u, k) for arrays fixed for a run: a call without arguments (plan.bind_dexp_inv)."""
        return bind(dexp_inv6, u, k)

    # -- this run's cache -----------------------------------------------------------------------
    def make_cache(self, x, u, y):
        """Kinematics and solver scratch, the kernels bound to this plan's state and port buffers,
        and a copy of the Pinocchio model whose gravity follows the gravity input."""
        return _Cache(self, x, u, y)

    # -- hot path -------------------------------------------------------------------------------
    # derivative() follows output() on the same (t, x, u) (framework contract): output() solves,
    # derivative() copies. The kinematics kernels check themselves which state they belong to.
    def derivative(self, t, x, u, dx):
        c = u.cache
        nv = self._nv
        dx[:nv] = c.v
        dx[nv:] = c.a

    def output(self, t, x, u, y):
        c = u.cache
        if x is not c.x:
            raise _not_the_state(self.name)
        if c.force():
            c.model.gravity.linear[:] = c.g
        if self._stops is not None:                 # joint stops past the URDF limits (joint_stops.py)
            self._stops.apply(c.q, c.v, c.T)
        c.a = a = c.solve()                         # derivative() reads it
        if c.want_acc:
            c.qdd[:] = a
            c.accelerations()

    # -- derivatives for linearly implicit integrators (framework/linearization.py) ------------------
    def port_jacobian(self, port, t, x, u, y):
        """joint_q and joint_v copy coordinates of the state's tangent ([q tangent, v], DOF columns)."""
        sel = self._selections
        if sel is None:                     # constants of the layout: the same objects every time
            from snakesim.framework.linearization import Selection
            sel = self._selections = {"joint_q": Selection(self._dof_v), "joint_v": Selection(self._nv + self._dof_v),
                                      "v": Selection(self._nv + np.arange(self._nv))}
        return sel.get(port)

    # -- the blow-up guard (blowup_guard.py): once per base step ------------------------------
    def has_check(self) -> bool:
        return self.p.blowup_guard.enabled

    def check(self, t, u, restart):
        c = u.cache
        args = c.guard_args
        args[0], args[1] = t, 1.0 if restart else 0.0
        link = c.guard()
        if link >= 0:
            self.stop(blow_up_reason(self.robot, link, args, c.guard_out, t, self._mass), kind="blow_up")

    def stiffness_hint(self, u, readers):
        """The joint stops' modes (joint_stops.py), none when off."""
        return self._stops.hint() if self._stops is not None else []

    def mechanical_jacobian(self, t, x, u, y, lin):
        """M and ∂Q/∂(q, v, other states) from the torque and wrench inputs' sources (linearization.py)."""
        if self.mode == "mimic_crba":
            return None                 # its CRBA convention differs (model.py): left explicit
        return mechanical_block(self, t, x, u, y, lin)

    # -- outputs ---------------------------------------------------------------------------
    def calc_state(self, t, x, u, y):
        c = u.cache
        if x is not c.x:
            raise _not_the_state(self.name)
        c.state()

    def calc_momentum(self, t, x, u, y):
        u.cache.momentum()

    def calc_energy(self, t, x, u, y):
        c = u.cache
        if c.energy():
            c.model.gravity.linear[:] = c.g
        np.multiply(c.v, c.v, out=c.vv)
        y.energy[0] += 0.5 * float(self._arm_v @ c.vv)

    # -- introspection ------------------------------------------------------------------------
    def build_report(self, baseline: bool = False):
        """``snakesim check`` shows the multibody optimisation (with ``--baseline`` also its timing against
        the unoptimised baselines, built only then: at 100 modules each holds ~1 GB of Pinocchio Data),
        and each joint's armature with where it came from (the URDF has none: the design or the scene
        adds it)."""
        rep = self.optimisation_report(timing=baseline)
        rep["armature"] = {j: {"kg_m2": v, "source": src, "kind": self.robot.kind_of(j)}
                           for j, (v, src) in joint_values.armature_sources(self.robot, self.p).items()}
        return rep

    def optimisation_report(self, timing: bool = True):
        """The multibody optimisation (paper 2.1.4): links, joints and DOF before and after, and the
        cost of one dynamics evaluation with and without it. A dict; ``print()`` gives a table."""
        if self._report is None or (timing and not self._report.get("timed")):
            from .report import optimisation_report
            self._report = optimisation_report(self.robot, self.dyn, self.mode, self.mode_reason,
                                               self.armature_user, timing=timing)
        return self._report

    def dof_index(self, joint: str) -> int:
        """Index of a DOF joint in tau / joint_q / joint_v."""
        return self.robot.dof_index(joint)

    def link_index(self, link: str) -> int:
        """Row of a link in wrenches / link_poses / link_velocities / link_accelerations."""
        return self.robot.link_index(link)


def _not_the_state(name: str) -> ValueError:
    return ValueError(f"{name}: evaluated at another state array than the one its cache was made for (the "
                      "plan's state view; a Harness's h.x): write the state into that array instead")


class _Cache:
    """One run's multibody scratch and bound kernels (see Multibody.make_cache).

    With ``dynamics: tree`` the solve is the link-tree kernel on its own scratch (no Data);
    otherwise the Pinocchio Data is the component's: a workspace every solve overwrites whole, one
    per component because Pinocchio 4.1's Data holds nv³ derivative tensors (0.92 GB at 100 modules)."""

    __slots__ = ("x", "q", "v", "a", "qdd", "g", "vv", "fresh", "model", "want_acc", "kin", "ports", "state", "force",
                 "solve", "accelerations", "momentum", "energy", "ensure_kinematics", "lin_scratch", "frames", "lin_tau",
                 "lin_op", "T", "solved", "guard", "guard_args", "guard_out", "guard_prev")

    def __init__(self, mb: Multibody, x, u, y):
        from . import kernels as k
        from ..kernel_args import bind

        nl, nq, nv = mb.robot.nl, mb._nq, mb._nv
        used = mb.used_outputs
        q, v = x[:nq], x[nq:]
        self.x, self.q, self.v = x, q, v
        self.a = self.qdd = np.zeros(nv)      # a: the last solve's accelerations; qdd: the kernels' copy
        self.g = mb._g_param.copy()
        self.vv, self.T = np.zeros(nv), np.zeros(nv)      # T: the generalised force (kernels.force_step)
        T = self.T
        self.model = model = mb._pin.Model(mb.dyn.model)          # its gravity is this run's
        self.want_acc = bool(used & {"a", "link_accelerations", "joint_wrenches"})
        z3 = lambda: np.zeros((nl, 3))  # noqa: E731
        self.fresh = np.zeros(1, dtype=bool)                      # the kinematics belong to at_q, at_v
        self.frames = (np.zeros((nl, 3, 3)), z3(), z3())          # R, p, aw: read by linearization.py
        self.kin = k.Kin(q=q, v=v, at_q=np.zeros(nq), at_v=np.zeros(nv), fresh=self.fresh,
                         R=self.frames[0], p=self.frames[1], w=z3(), vo=z3(), aw=self.frames[2], thd=np.zeros(nl), alpha=z3(),
                         ao=z3(), S=np.zeros((nl, 6)), T=T, qdd=self.qdd, g=self.g, h_scratch=np.zeros(6),
                         c_scratch=np.zeros(3), e_scratch=np.zeros(2))
        self.ports = k.Ports(tau=u.tau, wrenches=u.wrenches, gravity=u.gravity, q=y.q, v=y.v, joint_q=y.joint_q,
                             joint_v=y.joint_v, link_poses=y.link_poses, link_velocities=y.link_velocities,
                             link_rotations=y.link_rotations, momentum=y.momentum, com=y.com, energy=y.energy, a=y.a,
                             link_accelerations=y.link_accelerations, joint_wrenches=y.joint_wrenches,
                             want_qv=bool(used & {"q", "v"}), want_rot="link_rotations" in used,
                             want_cut="joint_wrenches" in used)
        args = (mb._tree, self.kin, self.ports)
        self.state, self.force = bind(k.state_step, *args), bind(k.force_step, *args)
        self.accelerations, self.momentum = bind(k.acceleration_step, *args), bind(k.momentum_step, *args)
        self.energy = bind(k.energy_step, *args)
        self.ensure_kinematics = bind(k._ensure_kinematics, mb._tree, self.kin)
        self.guard = self.guard_args = self.guard_out = self.guard_prev = None
        if mb.p.blowup_guard.enabled:           # blowup_guard.py: its record and kernel, bound once
            from .blowup_guard import guard_step, make_guard
            rec, self.guard_args, self.guard_out, self.guard_prev = make_guard(mb, mb.p.blowup_guard)
            self.guard = bind(guard_step, mb._tree, self.kin, self.ports, rec)
        self.lin_scratch = np.zeros((nl, 6, 6))          # composite blocks (linearization.tree_quadratic)
        self.lin_tau = None                                # (torque input's Coo, its slopes: linearization.py)
        self.lin_op = None                                 # the link-tree operator (linearization.ArticulatedW)
        self.solved = None                                 # (Iin, sig, at_q, q) of the tree solve, when it is one
        if mb.forward_dynamics == "tree":
            from .articulated_solve_kernels import forward_step, tree_dynamics
            # the solve's link inertias and joint twists, and the q they belong to: the implicit step's
            # assembly reuses them (linearization.ArticulatedW.prepare)
            Iin, sig, at_q = np.zeros((nl, 6, 6)), np.zeros((nl, 6)), np.full(nq, np.nan)
            self.solved = (Iin, sig, at_q, q)
            self.solve = bind(forward_step, mb._tree, self.kin,
                              tree_dynamics(mb._ta, nv, mb._arm_v, mb._tree_plan, Iin, sig, at_q))
        elif mb.mode != "mimic_crba":
            self.solve = functools.partial(mb._pin.aba, model, mb.dyn.data, q, v, T)
        else:
            self.solve = functools.partial(dataclasses.replace(mb.dyn, model=model).forward, q, v, T)
