"""The framework against a hand-written loop of the same physics: what the dataflow costs.

The scene is the default surface scene (assemblies/surface-screw-traverse.yaml: EELS 1.0
on flat ice, joint PIDs, a screw speed schedule, SDF screw contact) run with
``semi_implicit_euler``. The hand-written loop is what one would write without the
framework: one Python loop over time calling Pinocchio and the same numba kernels on
preallocated arrays --

    state_outputs (link kinematics) -> schedule look-up -> pid_law -> plane_contact_step
    -> joint_forces -> pin.aba -> PID state rates -> symplectic Euler (pin.integrate)

with the tail's planar pose (x, y, yaw) recorded at the scene's record rate. It borrows
the set-up (the Pinocchio model, tree arrays, contact sample tables, gains) from the
built scene, so both sides do the same arithmetic; the framework run records the same
signal (tail_pose.pose) and keeps the scene's stop condition. Both must end in the same
state (checked: bit-identical, or the script says by how much they differ).

    .venv/bin/python bench/handwritten_loop.py [--modules 10] [--dt 0.001] [--duration 5]
                                               [--repeats 3] [--json FILE]

Prints wall time per simulated second, real-time factor and µs per step for both, and
the ratio framework / hand-written (target: ≤ 1.3). Reference figures from issue 6: a
minimal hand-written Pinocchio + numpy loop with 40 penalty contacts ran ~8x real time
at 10 modules and 1.7x at 100.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import gc  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import click  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

from snakesim.components.contact.sdf_kernels import plane_contact_step  # noqa: E402
from snakesim.components.control.pid_kernel import pid_law  # noqa: E402
from snakesim.components.multibody.kernels import joint_forces, state_outputs  # noqa: E402
from snakesim.framework.assembly import resolve  # noqa: E402
from snakesim.framework.registry import default_registry  # noqa: E402
from snakesim.framework.session import Session  # noqa: E402
from snakesim.framework.wiring import PortRef  # noqa: E402

SCENE = "surface-screw-traverse"
TARGET = 1.3
EXPECTED = {"robot": "multibody", "pid": "joint_pid", "phases": "screw_schedule", "contact": "screw_sdf_contact",
            "terrain": "terrain", "tail_pose": "planar_pose"}


def framework_session(modules: int, dt: float, duration: float) -> Session:
    reg = default_registry()
    resolved = resolve(SCENE, search_path=reg.assembly_paths(), overrides=[f"robot.modules={modules}"],
                       sim_overrides={"dt": dt, "duration": duration, "integrator": "semi_implicit_euler"})
    resolved.record = [("tail_pose.pose", None)]       # the one signal the hand-written loop records too
    s = Session(resolved, reg)
    types = {n: c.type_name for n, c in s.plan.components.items()}
    if types != EXPECTED or s.plan.components["pid"].rate is not None:
        sys.exit(f"{SCENE} changed (components {types}); the hand-written loop mirrors {EXPECTED} "
                 "with a continuous-time joint_pid: update bench/handwritten_loop.py")
    return s


class HandLoop:
    """The scene's physics as one explicit loop (set-up borrowed from the built components)."""

    def __init__(self, s: Session):
        comps = s.plan.components
        self.dt, self.duration = s.resolved.sim.dt, s.resolved.sim.duration
        self.record_every = round(1.0 / (s.resolved.sim.record_rate * self.dt)) if s.resolved.sim.record_rate else 1
        self.mb, self.pid, self.sched, self.contact = comps["robot"], comps["pid"], comps["phases"], comps["contact"]
        self.tail = comps["tail_pose"]
        self.terrain = s.plan.out_buffers[PortRef("terrain", "terrain")].value     # set by a run (warm-up)
        self.X0 = {sl.comp.name: s.simulator.X0[sl.x].copy() for sl in s.plan.slices}     # initial state

    def run(self):
        mb, pid, sc, c = self.mb, self.pid, self.sched, self.contact
        ta, lay = mb._ta, c.layout
        model, data = mb.dyn.model, mb.dyn.data
        nq, nv, nl, nj = mb._nq, mb._nv, len(mb.robot.links), len(mb.robot.joints)
        x = self.X0["robot"].copy()
        xp = self.X0["pid"].copy()
        q, v = x[:nq].copy(), x[nq:].copy()
        R, p, w, vo, aw, thd = (np.zeros((nl, 3, 3)), np.zeros((nl, 3)), np.zeros((nl, 3)), np.zeros((nl, 3)),
                                np.zeros((nl, 3)), np.zeros(nl))
        jq, jv, poses, vels = np.zeros(nj), np.zeros(nj), np.zeros((nl, 7)), np.zeros((nl, 6))
        tau, err, dint, zrate = np.zeros(nj), np.zeros(nj), np.zeros(nj), np.zeros(nj)
        zero_nj = np.zeros(nj)
        W, S, T = np.zeros((nl, 6)), np.zeros((nl, 6)), np.zeros(nv)
        fn, cnt = np.zeros(lay.ns), 0
        mats = c._material_table(self.terrain)
        origin, normal, region = c._plane
        times, table = sc._t, sc._table
        tail_i, tail_axis = self.tail._i, self.tail._axis
        h = self.dt
        hh = h * h
        n_steps = int(round(self.duration / h))
        log = np.zeros((n_steps // self.record_every + 1, 4))
        dq = np.zeros(nv)
        for k in range(n_steps + 1):
            t = k * h
            state_outputs(ta.order, ta.parent, ta.jtype, ta.R0, ta.p0, ta.axis, ta.qidx, ta.qkind, ta.vidx, ta.mult,
                          ta.offset, q, v, R, p, w, vo, aw, thd, mb._jq_idx, mb._jq_cs, mb._dof_v, jq, jv, poses, vels)
            setpoint = table[int(np.searchsorted(times, t, side="right"))]
            pid_law(pid._pos, pid._cont, pid._kp, pid._ki, pid._kd, pid._tf, pid._tmax, pid._inv_tf, pid._a,
                    pid._T, pid._discrete, pid._clamp, setpoint, zero_nj, zero_nj, jq, jv, xp, tau, err, dint, zrate)
            plane_contact_step(c.p.broad_phase, origin, normal, region, c._sphere_r, c._start, c._points_B,
                               lay.mount_p, c._active, c._centres, c._pts, c._dist, c._normal, c._mat, c._sample,
                               c._owner, poses, vels, jv, c._ringc_B, c._radial_B, c._axis_B, lay.parent_row,
                               lay.screw_row, lay.radius, lay.lead_angle, lay.hand, lay.spin_dof, lay.spin_mult, mats,
                               c.p.v_eps, c._mode, c.p.ev_floor, c._R, c._cpt, c._vel, c._force, c._fn, W, fn)
            joint_forces(W.any(), mb._dof_v, tau, mb._damp, v, ta.order, ta.parent, ta.jtype, ta.vidx, ta.mult,
                         R, p, aw, W, S, T)
            a = pin.aba(model, data, q, v, T)
            if k % self.record_every == 0:
                d = R[tail_i] @ tail_axis
                log[cnt] = (t, poses[tail_i, 0], poses[tail_i, 1], np.arctan2(d[1], d[0]))
                cnt += 1
            if k == n_steps:
                break
            # symplectic Euler exactly as the framework's: q ⊕ (h v + h² a), v + h a; PID state explicit
            np.multiply(v, h, out=dq)
            dq += hh * a
            xp[:nj] += h * dint
            xp[nj:] += h * zrate
            q = pin.integrate(model, q, dq)
            v += h * a
        return np.concatenate([q, v]), xp, log[:cnt]


def _timed(fn):
    gc.collect()
    gc.disable()
    t0 = time.perf_counter()
    out = fn()
    wall = time.perf_counter() - t0
    gc.enable()
    return wall, out


def _best_interleaved(fns, repeats):
    """Best wall time of each, the runs alternating so that a busy spell on the machine hits both."""
    best, outs = [np.inf] * len(fns), [None] * len(fns)
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            wall, outs[i] = _timed(fn)
            best[i] = min(best[i], wall)
    return best, outs


@click.command()
@click.option("--modules", default=10, help="EELS 1.0 modules")
@click.option("--dt", default=0.001, help="s, base step (the recommended default)")
@click.option("--duration", default=5.0, help="simulated seconds per run")
@click.option("--repeats", default=5, help="timed runs each (best kept)")
@click.option("--json", "json_path", type=click.Path(dir_okay=False), help="write the figures here")
def main(modules, dt, duration, repeats, json_path):
    s = framework_session(modules, dt, duration)
    s.run()                       # warm-up: numba caches, first-touch
    hand = HandLoop(s)
    hand.run()
    (fw_wall, hw_wall), (fw, (x_end, xp_end, log)) = _best_interleaved([s.run, hand.run], repeats)
    steps = int(round(duration / dt))
    x_fw = s.plan.X[next(sl.x for sl in s.plan.slices if sl.comp.name == "robot")]
    xp_fw = s.plan.X[next(sl.x for sl in s.plan.slices if sl.comp.name == "pid")]
    diff = float(max(np.max(np.abs(x_fw - x_end)), np.max(np.abs(xp_fw - xp_end))))
    pose_diff = float(np.max(np.abs(fw["tail_pose.pose"] - log[:, 1:])))
    rows = []
    for label, wall in (("framework", fw_wall), ("hand-written", hw_wall)):
        rows.append({"loop": label, "wall_s": wall, "real_time_factor": duration / wall,
                     "us_per_step": wall / steps * 1e6})
    ratio = fw_wall / hw_wall
    print(f"{SCENE}, EELS 1.0 x {modules} modules, semi_implicit_euler dt = {dt * 1e3:g} ms, "
          f"{duration:g} s simulated, best of {repeats}")
    print(f"{'loop':14s} {'wall s':>8s} {'RTF':>7s} {'us/step':>8s}")
    for r in rows:
        print(f"{r['loop']:14s} {r['wall_s']:8.3f} {r['real_time_factor']:7.2f} {r['us_per_step']:8.1f}")
    print(f"framework / hand-written = {ratio:.3f} (target <= {TARGET}); "
          f"end states differ by {diff:.3g} (max abs), tail pose log by {pose_diff:.3g}")
    if json_path:
        with open(json_path, "w") as fh:
            json.dump({"machine": platform.processor() or platform.machine(), "python": platform.python_version(),
                       "scene": SCENE, "modules": modules, "dt_s": dt, "duration_s": duration, "rows": rows,
                       "ratio": ratio, "target": TARGET, "end_state_max_abs_diff": diff,
                       "pose_log_max_abs_diff": pose_diff}, fh, indent=2)
        print(f"wrote {json_path}")


if __name__ == "__main__":
    main()
