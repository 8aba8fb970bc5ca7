"""A drawbar testbed's carriage: one link of the robot (a screw module, a wheel's hub) on a slide, towed
back at a constant load, the soil-bin test of terramechanics labs (drawbar pull against slip; Wong,
*Theory of Ground Vehicles*, ch. 2 and 4; Lim et al. 2023 for screws).

The slide. The multibody's joints are revolute, continuous or fixed on a free-flying root
(components/multibody/urdf.py refuses prismatic joints), so the testbed's rails are a penalty on the link,
at its origin, in world axes:

    W = [−F, −k y − c v_y, 0,  −k θ − c ω]       θ = vee((R − Rᵀ)/2) = 2 q_w (q_x, q_y, q_z)

θ the small-angle rotation vector of the link's axes from the world's: travel x and sinkage z stay free;
sway y, roll, pitch and yaw are held (a counter-rotating pair's yaw couple and the tow's pitch moment go
into the springs: ~1 N·m over the default 2·10⁴ N·m/rad is 0.05 mrad). The link starts with its axes on the
world's and its origin at y = 0 (the springs' rest). The slopes are declared (a LinkWrenchJacobian, as the
soil contacts'): ∂W/∂twist = −c and ∂W/∂δ = −k on the held axes, so a linearly implicit integrator takes
the springs implicitly.

The measurement, once per base tick (``check``) and reported at the end (``report``: summary.json's
``reports.<name>``; campaign metrics ``{report: NAME.slip}``), over the last ``steady_window`` s:

    v̄       travel speed, the least-squares slope of the link origin's x(t)                    m/s
    v_nut    the ideal nut speed of the screws on the link, mean over the window of
             |ω| r tan λ (spin ω, radius r, lead angle λ; robot_screws.py)                     m/s
    slip     1 − v̄ / v_nut (the screw-propulsion literature's, as terramechanics_contact's)
    settled  the link origin's height at the start less its mean over the window (~0 when it
             started where the virgin soil carries it; the screws' sinkage is the contact's)   m

so a campaign over ``tow`` draws the slip–drawbar curve (docs/terramechanics.md, "The drawbar rig").

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

HELD = np.array([0.0, 1.0, 0.0, 1.0, 1.0, 1.0])      # y, roll, pitch, yaw held; x, z free


class DrawbarCarriageParams(Params):
    link: str | None = Field(None, description="the link on the carriage, its origin towed and measured "
                                                 "(default: the URDF's root)")
    tow: float = Field(0.0, description="N, the drawbar load, pulling the link back along −x (world); "
                                        "negative pushes it")
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
        _, self.row = robot.mounted_link(p.link, self.name)
        screws = robot.derived(screw_layout)
        on = np.flatnonzero((screws.parent_row == self.row) | (screws.screw_row == self.row))
        self.spin_dof, self.spin_mult = screws.spin_dof[on], screws.spin_mult[on]
        self.nut_per_rad = np.asarray(screws.radius)[on] * np.tan(np.asarray(screws.lead_angle)[on])   # m
        d_twist, d_pose = np.zeros((robot.nl, 6, 6)), np.zeros((robot.nl, 6, 6))
        d_twist[self.row] = -p.damping * np.diag(HELD)
        d_pose[self.row] = -p.stiffness * np.diag(HELD)
        self._jac = LinkWrenchJacobian(rows=np.array([self.row]), d_twist=d_twist, d_pose=d_pose,
                                       inputs=("link_poses", "link_velocities"))

    def make_cache(self, x, u, y):
        return _Track()

    def output(self, t, x, u, y):
        p, r = self.p, self.row
        qx, qy, qz, qw = u.link_poses[r, 3:7]
        v = u.link_velocities[r]
        w = y.wrenches
        w[...] = 0.0
        w[r, 0] = -p.tow
        w[r, 1] = -p.stiffness * u.link_poses[r, 1] - p.damping * v[1]
        w[r, 3] = -p.stiffness * 2.0 * qw * qx - p.damping * v[3]
        w[r, 4] = -p.stiffness * 2.0 * qw * qy - p.damping * v[4]
        w[r, 5] = -p.stiffness * 2.0 * qw * qz - p.damping * v[5]

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
        return {"link": self.robot.links[self.row], "tow_N": p.tow, "window_s": [float(t[w][0]), float(t[-1])],
                "travel_speed_m_s": speed, "nut_speed_m_s": v_nut if np.isfinite(v_nut) else None,
                "slip": slip, "settled_m": float(z[0] - np.mean(z[w]))}

    @staticmethod
    def format_report(r: dict) -> list[str]:
        """Lines for the terminal."""
        if r.get("travel_speed_m_s") is None:
            return [f"drawbar: tow {r['tow_N']:g} N, too short a run to measure"]
        line = f"drawbar: tow {r['tow_N']:g} N, travel {1e3 * r['travel_speed_m_s']:.1f} mm/s"
        if r.get("slip") is not None:
            line += f" against a nut speed of {1e3 * r['nut_speed_m_s']:.1f} mm/s: slip {r['slip']:.3f}"
        return [line + f" (over {r['window_s'][0]:.2f}-{r['window_s'][1]:.2f} s)",
                f"settled {1e3 * r['settled_m']:.1f} mm since the start"]
