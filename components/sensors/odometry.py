"""Odometry of a robot link: its true pose and twist, and a degraded dead-reckoning estimate.

Truth (link L, o its origin, R its axes in the world; nav_msgs/Odometry's conventions: the pose in
the world frame, the twist in the child frame, i.e. the link's own axes)::

    pose   = [o, q]                       m, quaternion (x, y, z, w): link -> world
    twist  = [Rᵀ v_o, Rᵀ ω]               m/s, rad/s, link axes (v_o, ω: the multibody's world-axis
                                          origin velocity and angular velocity of L)

Estimate: dead reckoning of the measured body twist, sampled at the component's rate (Hz; 50 Hz
when the assembly gives none; the framework's rules: a whole number of base steps), Δt = 1/rate.
At sample k (k = 0, 1, ...), with the true body twist (v_k, ω_k) read at t_k::

    ṽ_k = (1 + s_v) v_k + b_v,k + n_v,k          n_v,k ~ N(0, σ_v² I)   per sample
    ω̃_k = (1 + s_ω) ω_k + b_ω,k + n_ω,k          n_ω,k ~ N(0, σ_ω² I)
    b_·,k+1 = b_·,k + w_·,k                       w_·,k ~ N(0, σ_b·² Δt I)   bias random walk
    b_·,0 = the ``*_bias`` params

and the pose is advanced by the SE(3) exponential of the measured body twist (exact for a twist
constant over the step; the first sample starts the estimate at the true pose)::

    R̂_k+1 = R̂_k Exp(Δt ω̃_k)
    p̂_k+1 = p̂_k + R̂_k V(Δt ω̃_k) Δt ṽ_k            V(φ) = I + (1 − cos|φ|)/|φ|² [φ]× + (|φ| − sin|φ|)/|φ|³ [φ]×²

Integration error with no noise (the tests check it): with the body twist's rates bounded,
|ω̇_b| ≤ L_ω, |v̇_b| ≤ L_v, and |v_b| ≤ V over [0, T], T = NΔt::

    angle(R̂_N, R_N) ≤ ½ L_ω Δt T
    |p̂_N − p_N|     ≤ Δt (¼ L_ω V T² + ½ L_v T + ⅙ L_ω V Δt T)

(per step the rotation differs by ≤ ∫|ω(s) − ω_k| ds ≤ ½ L_ω Δt², and rotation distance is
bi-invariant; the translation by ≤ θ_k V Δt + ½ L_v Δt² + ⅙ L_ω V Δt³ with θ_k ≤ ½ L_ω Δt t_k).

Covariances, from the model's random parts (the scale errors and the initial biases are
deterministic calibration errors, not in them): the error state e = [δp, δθ, β_v, β_ω] (δp = p̂ − p
world, R̂ = Exp(δθ) R, β the biases' random-walk parts), propagated linearly each sample::

    δp' = δp − Δt [R̂ ṽ]× δθ + Δt R̂ (β_v + n_v)      δθ' = δθ + Δt R̂ (β_ω + n_ω)
    β_v' = β_v + w_v                                β_ω' = β_ω + w_ω
    P' = F P Fᵀ + G Q Gᵀ,  P_0 = 0

``estimate_pose_covariance`` = P's [δp, δθ] block (ROS order x, y, z, rotation about the fixed
X, Y, Z axes); ``estimate_twist_covariance`` = diag(σ_v² I, σ_ω² I) + P's [β_v, β_ω] block (child
frame). With only σ_v and no rotation the position error is a random walk: Var = σ_v² Δt t per axis.

Noise is seeded (``seed``): sample k's 12 normals (n_v, n_ω, w_v, w_ω) come from a Philox
generator keyed by the seed with counter (0, k, 1, 0): the same seed gives the same estimate in
every run, another seed another one; independent of every other sensor's draws.

in   link_poses[nl, 7], link_velocities[nl, 6]   from the multibody (world; velocities at the origin)
out  pose[7], twist[6]                            truth, sampled at the rate
     estimate_pose[7], estimate_twist[6]          the dead-reckoning estimate and the measured twist
     estimate_pose_covariance[6, 6], estimate_twist_covariance[6, 6]
uses robot: RobotModel (the multibody's): the link row; default link: the URDF's root
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.components.port_roles import LINK_POSES, LINK_VELOCITIES
from snakesim.framework import Component, Input, Output, Params, Uses

Vec3 = tuple[float, float, float]

#: Hz, the sample rate when the assembly gives none
DEFAULT_RATE = 50.0
#: the Philox stream of odometry draws (counter word 2): never another sensor's
STREAM = 1

#: port roles (what the ROS 2 odometry bridge matches on): the truth and the estimate
ODOMETRY_POSE = "odometry_pose"
ODOMETRY_TWIST = "odometry_twist"
ODOMETRY_ESTIMATE_POSE = "odometry_estimate_pose"
ODOMETRY_ESTIMATE_TWIST = "odometry_estimate_twist"
ODOMETRY_ESTIMATE_POSE_COVARIANCE = "odometry_estimate_pose_covariance"
ODOMETRY_ESTIMATE_TWIST_COVARIANCE = "odometry_estimate_twist_covariance"

POSE_NAMES = ("x", "y", "z", "qx", "qy", "qz", "qw")
TWIST_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")
COV_NAMES = tuple(f"{a}.{b}" for a in ("x", "y", "z", "rx", "ry", "rz") for b in ("x", "y", "z", "rx", "ry", "rz"))
TWIST_COV_NAMES = tuple(f"{a}.{b}" for a in TWIST_NAMES for b in TWIST_NAMES)

# discrete state layout
_K, _STARTED, _P, _Q, _BV, _BW, _COV = 0, 1, slice(2, 5), slice(5, 9), slice(9, 12), slice(12, 15), slice(15, 159)
_NSTATE = 159


class OdometryParams(Params):
    link: str | None = Field(None, description="link whose odometry is given (default: the robot's base, the "
                                               "URDF's root link)")
    linear_noise: float = Field(0.0, ge=0, description="m/s, σ_v: white noise per sample and axis on the body velocity")
    angular_noise: float = Field(0.0, ge=0, description="rad/s, σ_ω: white noise per sample and axis on the body rate")
    linear_bias: Vec3 = Field((0.0, 0.0, 0.0), description="m/s, initial velocity bias (body axes)")
    angular_bias: Vec3 = Field((0.0, 0.0, 0.0), description="rad/s, initial rate bias (body axes)")
    linear_bias_walk: float = Field(0.0, ge=0, description="m/s/√s, velocity bias random walk (σ of the bias "
                                                           "after 1 s)")
    angular_bias_walk: float = Field(0.0, ge=0, description="rad/s/√s, rate bias random walk")
    linear_scale_error: float = Field(0.0, gt=-1, description="1, s_v: measured speed = (1 + s_v) × true speed")
    angular_scale_error: float = Field(0.0, gt=-1, description="1, s_ω: measured rate = (1 + s_ω) × true rate")
    seed: int = Field(0, ge=0, description="noise seed")


def _skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def quat_to_matrix(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def se3_step(phi, rho):
    """(quaternion (x, y, z, w) of Exp(phi), V(phi) rho): the SE(3) exponential of the twist (rho, phi)."""
    th2 = float(phi @ phi)
    th = np.sqrt(th2)
    if th < 1e-4:                         # series: errors below 1e-17 at this angle
        half = 0.5 - th2 / 48.0
        a, b = 0.5 - th2 / 24.0, 1.0 / 6.0 - th2 / 120.0
        cw = 1.0 - th2 / 8.0
    else:
        half = np.sin(0.5 * th) / th
        a, b = (1.0 - np.cos(th)) / th2, (th - np.sin(th)) / (th2 * th)
        cw = np.cos(0.5 * th)
    c1 = np.cross(phi, rho)
    return np.array([*(half * phi), cw]), rho + a * c1 + b * np.cross(phi, c1)


def quat_mul(a, b):
    """Hamilton product a ⊗ b of quaternions (x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


class Odometry(Component[OdometryParams]):
    type_name = "odometry"
    robot = Uses(RobotModel)

    link_poses = Input(shape=link_shape(7), unit=None, role=LINK_POSES)
    link_velocities = Input(shape=link_shape(6), unit=None, role=LINK_VELOCITIES)
    pose = Output(shape=(7,), unit=None, names=POSE_NAMES, role=ODOMETRY_POSE,
                  doc="true pose: m, quaternion (x, y, z, w), link -> world")
    twist = Output(shape=(6,), unit=None, names=TWIST_NAMES, role=ODOMETRY_TWIST,
                   doc="true twist: m/s, rad/s, in the link's axes (nav_msgs/Odometry's child frame)")
    estimate_pose = Output(shape=(7,), unit=None, names=POSE_NAMES, role=ODOMETRY_ESTIMATE_POSE,
                           doc="dead-reckoning pose, world frame (starts at the true pose)")
    estimate_twist = Output(shape=(6,), unit=None, names=TWIST_NAMES, role=ODOMETRY_ESTIMATE_TWIST,
                            doc="measured twist (scale, bias, noise), link axes")
    estimate_pose_covariance = Output(shape=(6, 6), unit=None, names=COV_NAMES,
                                      role=ODOMETRY_ESTIMATE_POSE_COVARIANCE,
                                      doc="m², rad²: [x, y, z, rot X, rot Y, rot Z] (fixed axes)")
    estimate_twist_covariance = Output(shape=(6, 6), unit=None, names=TWIST_COV_NAMES,
                                       role=ODOMETRY_ESTIMATE_TWIST_COVARIANCE,
                                       doc="(m/s)², (rad/s)²: [vx, vy, vz, wx, wy, wz], link axes")

    def setup(self):
        p = self.p
        self.link, self._i = self.robot.mounted_link(p.link, self.name)
        if self.rate is None:
            self.rate = DEFAULT_RATE
        self.dt = 1.0 / self.rate
        self._scale = np.r_[np.full(3, 1.0 + p.linear_scale_error), np.full(3, 1.0 + p.angular_scale_error)]
        self._bias0 = np.r_[p.linear_bias, p.angular_bias].astype(float)
        if not np.all(np.isfinite(self._bias0)):
            raise ValueError(f"{self.name}: linear_bias and angular_bias must be finite")
        sw = np.sqrt(self.dt)
        #: standard deviations of the 12 draws per sample: n_v, n_ω, w_v, w_ω
        self._std = np.r_[np.full(3, p.linear_noise), np.full(3, p.angular_noise),
                          np.full(3, p.linear_bias_walk * sw), np.full(3, p.angular_bias_walk * sw)]
        self._noisy = bool(self._std.any())
        self._meas_cov = np.diag(np.r_[np.full(3, p.linear_noise ** 2), np.full(3, p.angular_noise ** 2)])
        # process noise of the error state (isotropic: no rotation needed): Δt² σ² for n, σ_b² Δt for w
        self._Q = np.diag(np.r_[np.full(3, (self.dt * p.linear_noise) ** 2), np.full(3, (self.dt * p.angular_noise) ** 2),
                                np.full(3, p.linear_bias_walk ** 2 * self.dt),
                                np.full(3, p.angular_bias_walk ** 2 * self.dt)])

    def discrete_state(self):
        xd = np.zeros(_NSTATE)
        xd[_Q.stop - 1] = 1.0                     # identity quaternion until the first sample sets it
        xd[_BV], xd[_BW] = self._bias0[:3], self._bias0[3:]
        return xd

    # -- the model -------------------------------------------------------------------------
    def _truth(self, u):
        i = self._i
        pose = u.link_poses[i]
        R = quat_to_matrix(pose[3:7])
        vel = u.link_velocities[i]
        return pose, R, np.r_[R.T @ vel[:3], R.T @ vel[3:]]

    def _draws(self, k: float) -> np.ndarray:
        gen = np.random.Generator(np.random.Philox(key=int(self.p.seed), counter=[0, int(k), STREAM, 0]))
        return gen.standard_normal(12) * self._std

    def _measure(self, xd, twist, draws):
        meas = self._scale * twist
        meas[:3] += xd[_BV]
        meas[3:] += xd[_BW]
        if draws is not None:
            meas += draws[:6]
        return meas

    def output(self, t, x, u, y):
        pose, _R, twist = self._truth(u)
        y.pose[:] = pose
        y.twist[:] = twist
        draws = self._draws(x[_K]) if self._noisy else None
        y.estimate_twist[:] = self._measure(x, twist, draws)
        P = x[_COV].reshape(12, 12)
        if x[_STARTED]:
            y.estimate_pose[:3] = x[_P]
            y.estimate_pose[3:] = x[_Q]
        else:
            y.estimate_pose[:] = pose
        y.estimate_pose_covariance[:] = P[:6, :6]
        tc = y.estimate_twist_covariance
        tc[:] = self._meas_cov
        tc += P[6:, 6:]

    def update(self, t, xd, u):
        pose, _R, twist = self._truth(u)
        if not xd[_STARTED]:
            xd[_P], xd[_Q] = pose[:3], pose[3:7]
            xd[_STARTED] = 1.0
        draws = self._draws(xd[_K]) if self._noisy else None
        meas = self._measure(xd, twist, draws)
        dt = self.dt
        q = xd[_Q].copy()
        Rh = quat_to_matrix(q)
        dq, dp = se3_step(dt * meas[3:], dt * meas[:3])
        # covariance (linearised error dynamics), before the state moves on: F and G use R̂_k, ṽ_k
        P = xd[_COV].reshape(12, 12)
        F = np.eye(12)
        F[0:3, 3:6] = -dt * _skew(Rh @ meas[:3])
        F[0:3, 6:9] = dt * Rh
        F[3:6, 9:12] = dt * Rh
        G = np.zeros((12, 12))
        G[0:3, 0:3] = Rh                          # Δt R̂ n_v: its Δt is in Q
        G[3:6, 3:6] = Rh
        G[6:12, 6:12] = np.eye(6)
        Pn = F @ P @ F.T + G @ self._Q @ G.T
        xd[_COV] = (0.5 * (Pn + Pn.T)).ravel()
        xd[_P] += Rh @ dp
        qn = quat_mul(q, dq)
        xd[_Q] = qn / np.sqrt(qn @ qn)
        if draws is not None:
            xd[_BV] += draws[6:9]
            xd[_BW] += draws[9:12]
        xd[_K] += 1.0
