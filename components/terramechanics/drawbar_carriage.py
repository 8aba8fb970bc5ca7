"""A drawbar testbed's carriage: one link of the robot (a screw module, a wheel's hub) on a slide, either
towed back at a constant load (the slip follows) or driven along at a set speed (the slip is set, the
drawbar pull follows): the soil-bin tests of terramechanics labs (drawbar pull against slip; Wong,
*Theory of Ground Vehicles*, ch. 2 and 4; Lim et al. 2023 for screws).

The slide. The multibody's joints are revolute, continuous or fixed on a free-flying root
(components/multibody/urdf.py refuses prismatic joints), so the testbed's rails are a penalty on the link,
at its origin, in world axes:

    W = [f_x, −k (y − y₀) − c v_y, 0,  −k θ − c ω]      θ = 2 e_w (e_x, e_y, e_z),  e = q ⊗ q₀⁻¹
    f_x = −F                                       towed (``tow`` F, N)
    f_x = −k (x − x₀ − V t) − c (v_x − V)          driven (``speed`` V, m/s: the carriage on a rail from x₀)

θ the small-angle rotation vector of the link's attitude q from the held one q₀ (``rest_quaternion``: the
world's axes by default; a module on its side, as the robot scenes lie, is held so), the vee of
(E − Eᵀ)/2 for E = R R₀ᵀ, world axes: sinkage z and, towed, travel x stay
free; driven, x follows the rail x₀ + V t, ahead of it by (drawbar pull) / k (2.5 mm for 50 N by default);
sway y, roll, pitch and yaw are held (a counter-rotating pair's yaw couple and the tow's pitch moment go
into the springs: ~1 N·m over the default 2·10⁴ N·m/rad is 0.05 mrad). The link starts with its axes on the
held attitude and its origin at y = y₀ (the springs' rest). The slopes are declared (a LinkWrenchJacobian, as the
soil contacts'): ∂W/∂twist = −c and ∂W/∂δ = −k on the held axes (and x when driven), so a linearly
implicit integrator takes the springs implicitly.

The measurement, once per base tick (``check``) and reported at the end (``report``: summary.json's
``reports.<name>``; campaign metrics ``{report: NAME.slip}``), over the last ``steady_window`` s:

    v̄       travel speed, the least-squares slope of the link origin's x(t)                    m/s
    v_nut    the ideal nut speed of the screws on the link, mean over the window of
             |ω| r tan λ (spin ω, radius r, lead angle λ; robot_screws.py)                     m/s
    slip     1 − v̄ / v_nut (the screw-propulsion literature's, as terramechanics_contact's)
    pull     the drawbar pull: the tow, or driven, the mean over the window of −f_x (what the
             carriage holds back: the screws' net thrust), k·mean(x − x₀ − V t) + c (Δx/Δt − V):
             the damper's mean from the window's displacement, which is exact, not from the
             velocities at the ticks, which carry the integrator's end-of-step error (ROS2 is not
             stiffly accurate: 0.5 mm/s low at 2 ms on the snow bin, 1 N through c)              N
    settled  the link origin's height at the start less its mean over the window (~0 when it
             started where the virgin soil carries it; the screws' sinkage is the contact's)   m

so a campaign over ``tow`` (or over ``speed``, for slips a tow cannot hold: braking, s < 0, or past the
thrust's peak) draws the slip–drawbar curve (docs/terramechanics.md, "The drawbar rig").

uses robot: RobotModel (the multibody's): the link's row, the screws on it
in   link_poses[nl, 7], link_velocities[nl, 6]    the multibody's (world)
     joint_v[nj]                                 rad/s (the screws' spin, for the nut speed)
out  wrenches[nl, 6]    N, N·m at each link origin, world axes (feedthrough): to multibody.wrenches through a
                        wrench_sum with the soil contact's
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.contact.robot_screws import screw_layout
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import joint_names, joint_shape, link_element_names, link_shape
from snakesim.framework import Component, Input, Output, Params, Uses

HELD = np.array([0.0, 1.0, 0.0, 1.0, 1.0, 1.0])      # y, roll, pitch, yaw held; x (towed), z free
DRIVEN = np.array([1.0, 1.0, 0.0, 1.0, 1.0, 1.0])    # x held to the rail too


def _quat_mul(a, b) -> tuple[float, float, float, float]:
    """a ⊗ b, quaternions (x, y, z, w)."""
    ax, ay, az, aw = (float(v) for v in a)
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


class DrawbarCarriageParams(Params):
    link: str | None = Field(None, description="the link on the carriage, its origin towed and measured "
                                                 "(default: the URDF's root)")
    tow: float = Field(0.0, description="N, the drawbar load, pulling the link back along −x (world); "
                                        "negative pushes it")
    speed: float | None = Field(None, description="m/s: drive the link along +x at this speed instead of "
                                                  "towing it (the slip is set, the drawbar pull measured); "
                                                  "None: towed by ``tow``")
    x0: float = Field(0.0, description="m, where the driven carriage's rail starts (the link's initial x)")
    y0: float = Field(0.0, description="m, the rail's line: the link's origin is held at y = y0 (world)")
    rest_quaternion: tuple[float, float, float, float] = Field(
        (0.0, 0.0, 0.0, 1.0), description="the link's held attitude (x, y, z, w; world): its start's")
    stiffness: float = Field(2.0e4, gt=0, description="N/m on y; N·m/rad on roll, pitch and yaw")
    damping: float = Field(2.0e3, ge=0, description="N·s/m on y; N·m·s/rad on roll, pitch and yaw")
    steady_window: float = Field(1.5, gt=0, description="s, the run's last stretch the report averages over")


class _Track:
    """Per run: per base tick, the time, the link origin's x and z, and the nut speed (m/s)."""

    def __init__(self):
        self.t: list[float] = []
        self.x: list[float] = []
        self.z: list[float] = []
        self.nut: list[float] = []


class DrawbarCarriage(Component[DrawbarCarriageParams]):
    type_name = "drawbar_carriage"

    robot = Uses(RobotModel)
    link_poses = Input(shape=link_shape(7), unit=None)
    link_velocities = Input(shape=link_shape(6), unit=None)
    joint_v = Input(shape=joint_shape, unit="rad/s", names=joint_names)
    wrenches = Output(shape=link_shape(6), unit=None, feedthrough=True,
                      names=link_element_names(("fx", "fy", "fz", "tx", "ty", "tz")))

    def setup(self):
        from snakesim.components.multibody.linearization import LinkWrenchJacobian

        p, robot = self.p, self.robot
        if p.speed is not None and p.tow != 0.0:
            raise ValueError(f"{self.name}: tow = {p.tow:g} N and speed = {p.speed:g} m/s: the carriage is towed "
                             "(tow) or driven (speed), not both; set one")
        _, self.row = robot.mounted_link(p.link, self.name)
        q0 = np.asarray(p.rest_quaternion, dtype=float)
        if not abs(np.linalg.norm(q0) - 1.0) < 1e-6:
            raise ValueError(f"{self.name}: rest_quaternion {list(p.rest_quaternion)} is not a unit quaternion "
                             f"(norm {np.linalg.norm(q0):.6g}); give (x, y, z, w) with x² + y² + z² + w² = 1")
        self.q0_inv = (-q0[0], -q0[1], -q0[2], q0[3])
        screws = robot.derived(screw_layout)
        on = np.flatnonzero((screws.parent_row == self.row) | (screws.screw_row == self.row))
        self.spin_dof, self.spin_mult = screws.spin_dof[on], screws.spin_mult[on]
        self.nut_per_rad = np.asarray(screws.radius)[on] * np.tan(np.asarray(screws.lead_angle)[on])   # m
        d_twist, d_pose = np.zeros((robot.nl, 6, 6)), np.zeros((robot.nl, 6, 6))
        held = HELD if p.speed is None else DRIVEN
        d_twist[self.row] = -p.damping * np.diag(held)
        d_pose[self.row] = -p.stiffness * np.diag(held)
        self._jac = LinkWrenchJacobian(rows=np.array([self.row]), d_twist=d_twist, d_pose=d_pose,
                                       inputs=("link_poses", "link_velocities"))

    def make_cache(self, x, u, y):
        return _Track()

    def output(self, t, x, u, y):
        p, r = self.p, self.row
        ex, ey, ez, ew = _quat_mul(u.link_poses[r, 3:7], self.q0_inv)    # the attitude's error from q0
        v = u.link_velocities[r]
        w = y.wrenches
        w[...] = 0.0
        w[r, 0] = self._fx(t, u.link_poses[r, 0], v[0])
        w[r, 1] = -p.stiffness * (u.link_poses[r, 1] - p.y0) - p.damping * v[1]
        w[r, 3] = -p.stiffness * 2.0 * ew * ex - p.damping * v[3]
        w[r, 4] = -p.stiffness * 2.0 * ew * ey - p.damping * v[4]
        w[r, 5] = -p.stiffness * 2.0 * ew * ez - p.damping * v[5]

    def _fx(self, t: float, x: float, vx: float) -> float:
        """The carriage's force along x (N): −F towed, the rail's spring-damper driven."""
        p = self.p
        if p.speed is None:
            return -p.tow
        return -p.stiffness * (x - p.x0 - p.speed * t) - p.damping * (vx - p.speed)

    def port_jacobian(self, port, t, x, u, y):
        return self._jac if port == "wrenches" else None

    def check(self, t, u, restart):
        run, pose = u.cache, u.link_poses[self.row]
        run.t.append(t)
        run.x.append(float(pose[0]))
        run.z.append(float(pose[2]))
        spin = np.abs(self.spin_mult * u.joint_v[self.spin_dof])
        run.nut.append(float(np.mean(spin * self.nut_per_rad)) if len(spin) else float("nan"))

    # -- the run's report (framework/run_reports.py) -------------------------------------------
    def report(self, cache, summary: dict) -> dict | None:
        """Tow, travel speed, nut speed, slip and settling over the last ``steady_window`` s (module docstring)."""
        run, p = cache, self.p
        if run is None or len(run.t) < 2:
            return None
        t, x, z, nut = (np.asarray(a) for a in (run.t, run.x, run.z, run.nut))
        w = t >= t[-1] - p.steady_window - 1e-9
        speed = float(np.polyfit(t[w], x[w], 1)[0]) if w.sum() >= 2 else None
        v_nut = float(np.mean(nut[w]))
        slip = 1.0 - speed / v_nut if speed is not None and np.isfinite(v_nut) and v_nut > 0 else None
        pull = p.tow
        if p.speed is not None:
            tw, xw = t[w], x[w]
            mean_v = (xw[-1] - xw[0]) / (tw[-1] - tw[0]) if len(tw) >= 2 else p.speed
            pull = p.stiffness * float(np.mean(xw - p.x0 - p.speed * tw)) + p.damping * (mean_v - p.speed)
        return {"link": self.robot.links[self.row], "mode": "towed" if p.speed is None else "driven",
                "tow_N": p.tow, "speed_set_m_s": p.speed, "window_s": [float(t[w][0]), float(t[-1])],
                "travel_speed_m_s": speed, "nut_speed_m_s": v_nut if np.isfinite(v_nut) else None,
                "slip": slip, "drawbar_pull_N": float(pull), "settled_m": float(z[0] - np.mean(z[w]))}

    @staticmethod
    def format_report(r: dict) -> list[str]:
        """Lines for the terminal."""
        load = (f"tow {r['tow_N']:g} N" if r.get("mode", "towed") == "towed" else
                f"driven at {1e3 * r['speed_set_m_s']:.1f} mm/s, drawbar pull {r['drawbar_pull_N']:.2f} N")
        if r.get("travel_speed_m_s") is None:
            return [f"drawbar: {load}, too short a run to measure"]
        line = f"drawbar: {load}, travel {1e3 * r['travel_speed_m_s']:.1f} mm/s"
        if r.get("slip") is not None:
            line += f" against a nut speed of {1e3 * r['nut_speed_m_s']:.1f} mm/s: slip {r['slip']:.3f}"
        return [line + f" (over {r['window_s'][0]:.2f}-{r['window_s'][1]:.2f} s)",
                f"settled {1e3 * r['settled_m']:.1f} mm since the start"]
