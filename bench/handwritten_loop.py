"""The framework against a hand-written loop of the same physics: what the dataflow costs.

The scene is the default surface scene (assemblies/surface-screw-traverse.yaml: EELS 1.0
on flat ice, joint PIDs, a screw speed schedule, SDF screw contact) run with
``semi_implicit_euler``. The hand-written loop is what one would write without the
framework: one Python loop over time calling Pinocchio and the same numba kernels on
preallocated arrays --

    state_step (link kinematics) -> schedule look-up -> pid_step -> plane_step
    -> force_step -> pin.aba -> PID state rates -> symplectic Euler (pin.integrate)

with the tail's planar pose (x, y, yaw) recorded at the scene's record rate. The kernels
take argument records (components/kernel_args.py); the loop builds its own records on its
own arrays and calls the kernels bound to them (``bind``), as the components do, so both
sides pay the same per call and the ratio is the dataflow's cost alone. It borrows the
set-up (the Pinocchio model, the robot's tree record, the contact's sample tables, the
PID gains) from the built scene, so both sides do the same arithmetic; the framework run
records the same signal (tail_pose.pose) and keeps the scene's stop condition. Both must
end in the same state (checked: bit-identical, or the script says by how much they differ).

    .venv/bin/python bench/handwritten_loop.py [--modules 10] [--dt 0.001] [--duration 5]
                                               [--repeats 3] [--json FILE]

Prints wall time per simulated second, real-time factor and µs per step for both, and
the ratio framework / hand-written (target: ≤ 1.15). Reference figures from issue 6: a
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

from snakesim.components.contact.plane_kernels import plane_extremal_step, plane_step  # noqa: E402
from snakesim.components.contact.contact_law import ContactLaw  # noqa: E402
from snakesim.components.contact.kernels import MODES  # noqa: E402
from snakesim.components.contact.screw_contact_kernels import SdfPorts, SdfWork, Surface  # noqa: E402
from snakesim.components.control.pid_kernel import PidRun, pid_step  # noqa: E402
from snakesim.components.kernel_args import bind  # noqa: E402
from snakesim.components.multibody.kernels import Kin, Ports, force_step, state_step  # noqa: E402
from snakesim.framework.assembly import resolve  # noqa: E402
from snakesim.framework.registry import default_registry  # noqa: E402
from snakesim.framework.session import Session  # noqa: E402
from snakesim.framework.wiring import PortRef  # noqa: E402

SCENE = "surface-screw-traverse"
TARGET = 1.15
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
        lay, terrain = c.screws, self.terrain
        model, data = mb.dyn.model, mb.dyn.data
        nq, nv, nl, nj, ns, n = mb._nq, mb._nv, len(mb.robot.links), len(mb.robot.joints), lay.ns, c.n_rows
        z = np.zeros
        x = self.X0["robot"].copy()
        xp = self.X0["pid"].copy()
        q, v = x[:nq].copy(), x[nq:].copy()
        R, p, thd, jq, jv, poses, vels = z((nl, 3, 3)), z((nl, 3)), z(nl), z(nj), z(nj), z((nl, 7)), z((nl, 6))
        tau, err, dint, zrate, setpoint, zero_nj = z(nj), z(nj), z(nj), z(nj), z(nj), z(nj)
        W, T = z((nl, 6)), z(nv)
        # the records the kernels take, on this loop's arrays (gravity input: NaN, the parameter's)
        g = mb._g_param.copy()
        kin = Kin(q=q, v=v, at_q=z(nq), at_v=z(nv), fresh=z(1, dtype=bool), R=R, p=p, w=z((nl, 3)), vo=z((nl, 3)),
                  aw=z((nl, 3)), thd=thd, alpha=z((nl, 3)), ao=z((nl, 3)), S=z((nl, 6)), T=T, qdd=z(nv), g=g,
                  h_scratch=z(6), c_scratch=z(3), e_scratch=z(2))
        ports = Ports(tau=tau, wrenches=W, gravity=np.full(1, np.nan), q=z(nq), v=z(nv), joint_q=jq, joint_v=jv,
                      link_poses=poses, link_velocities=vels, link_rotations=z((nl, 3, 3)), momentum=z(6), com=z(3),
                      energy=z(2), a=z(nv), link_accelerations=z((nl, 6)), joint_wrenches=z((nl, 6)), want_qv=False,
                      want_rot=False, want_cut=False)
        work = SdfWork(active=z(ns, dtype=np.int64), centres=z((ns, 3)), points=z((n, 3)), distance=z(n),
                       normal=z((n, 3)), material=z(n, dtype=np.int64), sample=z(n, dtype=np.int64),
                       owner=z(n, dtype=np.int64), R=z((3, 3)), point=z((n, 3)), vel=z((n, 3)), force=z((n, 3)),
                       fn=z(n), counts=z(7, dtype=np.int64), track=False, seen_poses=z((nl, 7)),
                       seen_vels=z((nl, 6)), seen_joint_v=z(nj), ring_row=z(n, dtype=np.int64), ring_dir=z((n, 3)),
                       ext_points=z((c.n_rings, 3)), ext_row=z(c.n_rings, dtype=np.int64), ext_distance=z(c.n_rings),
                       ext_normal=z((c.n_rings, 3)), ext_material=z(c.n_rings, dtype=np.int64))
        law_rows = dict(mu_scale=np.ones(ns), ev_scale=np.ones(ns), sinkage=z(ns), slip_power=z(ns),
                        slip_speed=z(ns), row_fn=z(ns), bad_row=np.full(1, -1, dtype=np.int64))
        contact_law = ContactLaw(v_eps=float(c.p.v_eps), mode=MODES[c.p.regularisation], ev_floor=float(c.p.ev_floor),
                                 row_of_owner=np.arange(ns, dtype=np.int64), **law_rows)
        contact_ports = SdfPorts(poses=poses, vels=vels, joint_v=jv, wrenches=W, screw_fn=z(ns), normal_force=z(1),
                                 contacts=z(1), law=contact_law)
        surface = Surface(origin=np.array(terrain.origin, dtype=float), n=np.array(terrain.n, dtype=float),
                          region_material=int(terrain.region_material[0]), mats=c.material_table(terrain))
        state = bind(state_step, mb._tree, kin, ports)
        force = bind(force_step, mb._tree, kin, ports)
        law = bind(pid_step, pid._gains, PidRun(setpoint=setpoint, rate_ref=zero_nj, tau_ff=zero_nj, q=jq, v=jv,
                                                x=xp, tau=tau, err=err, dint=dint, zrate=zrate))
        contact = bind(plane_extremal_step if c.exact else plane_step, c.table, work, contact_ports, surface)
        times, table = sc._t, sc._table
        tail_i, tail_axis = self.tail._i, self.tail._axis
        dt = self.dt
        n_steps = int(round(self.duration / dt))
        log = np.zeros((n_steps // self.record_every + 1, 4))
        cnt = 0
        dq = np.zeros(nv)
        for k in range(n_steps + 1):
            t = k * dt
            state()
            setpoint[:] = table[int(np.searchsorted(times, t, side="right"))]
            law()
            contact()
            if force():                          # gravity changed (never here: the input is unconnected)
                model.gravity.linear[:] = g
            a = pin.aba(model, data, q, v, T)
            if k % self.record_every == 0:
                d = R[tail_i] @ tail_axis
                log[cnt] = (t, poses[tail_i, 0], poses[tail_i, 1], np.arctan2(d[1], d[0]))
                cnt += 1
            if k == n_steps:
                break
            # symplectic Euler exactly as the framework's: q ⊕ (h v + h² a), v + h a; PID state explicit.
            # The step is (t + dt) − t, as the framework's integrators take it (it rounds differently
            # from dt in the last bits)
            h = (t + dt) - t
            hh = h * h
            np.multiply(v, h, out=dq)
            dq += hh * a
            xp[:nj] += h * dint
            xp[nj:] += h * zrate
            q[:] = pin.integrate(model, q, dq)
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
