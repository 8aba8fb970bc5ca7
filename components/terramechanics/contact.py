"""Terramechanics contact: the robot's screws on a deformable soil (terrain kind ``deformable``).

Model, per screw (envelope cylinder of radius r, length L, lead angle λ, hand h; robot_screws.py) against
the terrain's nodes (spacing Δ), as Chrono's SCM does for its bodies, along the base's normal N (ẑ on a plane
base, vertical lines and A = Δ²; terrain/deformable_kernels.py):

    contact nodes   those whose line along N from the node's virgin surface point meets the screw below the
                    unloaded (rutted) surface
    sinkage         s = the depth of that meeting point below the virgin surface, along N
    normal          σ = min(K_e (s − s_p), (k_c / b + k_φ) sⁿ)   (Bekker–Wong with SCM's elastic
                    unloading; terrain/deformable_kernels.py), b the patch's smaller side: the chord
                    2√(2 r p − p²) of the deepest sinkage p below the virgin surface, or the
                    contact's axial extent (+ Δ) if smaller; F_n = max(0, σ − R v_n) A along N,
                    A = Δ² / N_z the soil surface of the node's cell (R SCM's damping)
    shear strength  τ_max = c + σ tan φ                              (Mohr–Coulomb)
    thread          at the contact point, n̂ radial, ê_θ = â × n̂; across the thread
                    ê_x = cos λ â − h sin λ ê_θ, along it ê_h = h sin λ â + cos λ ê_θ; the surface's
                    velocity v (the soil at rest) splits into v_x = v·ê_x and v_h = v·ê_h
    Janosi          across the thread the soil in the groove is sheared by the flanks: j = |v_x| ℓ / |v_h|ε
                    with ℓ the helix path from where the thread entered the patch (ℓ = arc / cos λ, the
                    arc measured round the envelope from the patch's upstream edge at r·acos(1 − p/r)
                    from the bottom (towards −N), + Δ/2 for the node's own cell) and |v_h|ε =
                    √(v_h² + v_ε²): the steady form of j = ∫ v_x dt along the helix (Wong's j = i x for a
                    track); τ_x = τ_max (1 − e^(−j/K)) against v_x
                    along the thread the soil slides on the screw's skin: τ_h = helix_shear_ratio τ_max
                    (1 − e^(−ℓ/K)) against v_h (regularised by v_ε)
    wrench          Σ (F_n N − τ_x A sgn(v_x) ê_x − τ_h A ê_h) at each node, on the screw link about its
                    origin: the across-thread shear is the thrust along â; its moment about â loads the spin

An ideal screw (a nut in the soil) advances at h ω r tan λ: v_x = 0, no shear across the thread; slip
s = 1 − v_axial / (h ω r tan λ) (Lim et al. 2023; the screw-propulsion literature's definition).

The step's loads are committed once per base tick (``check``): nodes that
yield get a deeper rut (plastic sinkage) and a higher yield memory (with the terrain's ``bulldozing`` the soil
pressed out is heaped on the rim: terrain/bulldozing.py), then ``terrain.state.changed(t)``
tells the viewer and the sensors to redraw. ``output`` only evaluates (the integrator's stages and its
finite-difference Jacobian evaluate many times per step and must not dig).

Jacobian (``port_jacobian``, kernels.py docstring): per screw link the 6×6 blocks ∂W/∂(twist) of the shear
(its near-rest slope τ_max ℓ / (K v_ε) per node area is what made explicit steps sub-millisecond) and
∂W/∂(height) of the pressure, for linearly implicit integrators (the scene runs rosenbrock_w at 20 ms).
Report (``report``, summary.json's ``reports.<name>``): per screw the mean and deepest sinkage and the mean
slip while driven, and the rut (terrain/deformable_files.py's ``rut_summary``).

Not modelled here: body links (soil_body_contact, body_contact.py, with ``exclude_screws: true``; a scene with
both sums their wrenches with wrench_sum), lateral pressure on the rut walls (the body contact's rut_walls; a
screw's flanks already shear the groove), screws
standing on an end, a screw outside the terrain's patch (the base there is rigid and not sampled: keep the run
inside the patch), the transient build-up of j (the steady helix form above).

uses robot: RobotModel
in   link_poses[nl,7], link_velocities[nl,6]   multibody's (world)
     joint_v[nj]                               rad/s (screw spin rates)
     terrain                                   a DeformableTerrain
out  wrenches[nl,6]          N, N·m  to multibody.wrenches
     normal_force[1] N, contacts[1] (soil nodes under the screws)
     screw_sinkage[ns] m, screw_slip[ns] 1, screw_thrust[ns] N (along the screw axis), screw_normal_force[ns] N
all feedthrough, no state of its own: the soil's state is the terrain's (``terrain.state``), committed in
``check`` (once per base tick, after the tick's outputs; never inside the integrator's stages).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydantic import Field

from snakesim.framework import Component, ConfigError, Input, Output, Params, Uses
from snakesim.components.contact.robot_screws import screw_layout
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import joint_names, joint_shape, link_element_names, link_shape
from snakesim.components.terrain.base import Terrain
from snakesim.components.terrain.bulldozing import SoilFlowLog
from snakesim.components.terrain.deformable import DeformableTerrain

from .kernels import NODES, NORMAL, SCRATCH_COLUMNS, SINKAGE, SLIP, THRUST, scratch_rows, screw_soil


class TerramechanicsContactParams(Params):
    helix_shear_ratio: float = Field(0.5, ge=0, le=1, description="τ_max along the thread (soil on the screw's "
                                                                  "skin) over τ_max across it (soil on soil)")
    v_eps: float = Field(0.01, gt=0, description="m/s, slip-velocity regularisation: j = |v_x| ℓ / √(v_h² + v_ε²), "
                                                 "the skin's shear ∝ v_h / √(v_h² + v_ε²); sets the near-rest "
                                                 "slope (∝ 1 / v_ε) the Jacobian carries")


#: m/s, the nut speed ω r tan λ from which a screw counts as driven in the report's slip: a held screw's PID
#: jitter (~1e-3 rad/s) makes a slip of noise; a screw at 0.3 rad/s (EELS 1.0: 1 cm/s) is driven
DRIVEN_NUT_SPEED = 0.01


def _per_screw(c):
    return (c.screws.ns,)


def _screw_names(c):
    return c.screws.names


class ScrewGeometry:
    """The kernel's per-screw arrays (kernels.py docstring), from a robot's screw layout."""

    def __init__(self, layout):
        self.rows = np.column_stack([layout.parent_row, layout.screw_row, layout.spin_dof]).astype(np.int64)
        self.geo = np.column_stack([layout.radius, layout.length, layout.lead_angle, layout.hand.astype(float),
                                    layout.spin_mult]).astype(np.float64)
        self.mount_R = np.ascontiguousarray(layout.mount_R, dtype=np.float64)
        self.mount_p = np.ascontiguousarray(layout.mount_p, dtype=np.float64)
        self.names = layout.names
        self.radius, self.length = np.asarray(layout.radius), np.asarray(layout.length)


def require_soil(component, terrain, example: str, rigid: str) -> None:
    """A soil contact's terrain must be a deformable one: else a ConfigError naming the kind it got, an
    example terrain file and the contact for rigid terrain."""
    if not isinstance(terrain, DeformableTerrain):
        raise ConfigError(f"{component.name}: the terrain is a '{getattr(terrain, 'kind', type(terrain).__name__)}'; "
                          f"{component.type_name} needs kind 'deformable' (e.g. {example}); on a rigid terrain use "
                          f"{rigid}")


def check_cell(terrain: DeformableTerrain, radius: np.ndarray, length: np.ndarray, names, what: str = "screw") -> None:
    """The terrain's cell must resolve every screw (or body cylinder): no larger than its diameter and length."""
    smallest = np.minimum(2.0 * radius, length)
    k = int(np.argmin(smallest))
    if terrain.cell > smallest[k]:
        raise ConfigError(f"cell = {terrain.cell:g} m is larger than {what} '{names[k]}' (diameter "
                          f"{2 * radius[k]:g} m, length {length[k]:g} m): a {what} must span several nodes; give "
                          f"cell ≤ {smallest[k] / 4:g} m (a quarter of it) or less", terrain.source, "cell")


def write_soil_files(terrain: DeformableTerrain, out_dir, name: str) -> list[str]:
    """``--out``'s soil files: the state after the run (``soil_state.npz``; an ``initial_state`` of a later
    run) and a top view of the rut (``rut.png``, when there is one)."""
    from snakesim.components.terrain.deformable_files import rut_picture, save_state

    written = [save_state(terrain, Path(out_dir) / "soil_state.npz").name]
    picture = rut_picture(terrain, Path(out_dir) / "rut.png", title=f"{name}: rut after the run")
    return written + ([picture.name] if picture is not None else [])


class SoilEvaluation:
    """One evaluation's buffers: scratch nodes, per-screw columns and totals (the run cache holds two:
    one for the outputs, one for the commit)."""

    def __init__(self, ns: int, rows: int, nl: int):
        self.scratch = np.zeros((rows, SCRATCH_COLUMNS))
        self.per_screw = np.zeros((ns, 5))
        self.totals = np.zeros(2)
        # the Jacobian's blocks (filled only by an evaluation with jac; kernels.py docstring)
        self.d_twist, self.d_pose = np.zeros((nl, 6, 6)), np.zeros((nl, 6, 6))
        self.on_link = np.zeros(nl, dtype=np.bool_)


def evaluate(terrain: DeformableTerrain, g: ScrewGeometry, poses, vels, joint_v, wrenches, ev: SoilEvaluation,
             helix_ratio: float, v_eps: float, commit: bool, jac: bool = False, flow: SoilFlowLog | None = None) -> int:
    """Screw forces into ``wrenches`` (zeroed first) and ``ev``; commits the loads with ``commit`` (logged in
    ``flow`` for bulldozing), fills ``ev``'s Jacobian blocks with ``jac``. The number of nodes that flowed, −1
    when the tile pool is full."""
    st = terrain.state
    wrenches[...] = 0.0
    log, log_n = (flow.entries, flow.count) if flow is not None else NO_LOG
    return screw_soil(terrain.grid, terrain.base_z, terrain.soil, st.tile_of, st.plastic, st.yield_p, st.lift, st.used,
                      g.rows, g.geo, g.mount_R, g.mount_p, np.ascontiguousarray(poses, dtype=np.float64),
                      np.ascontiguousarray(vels, dtype=np.float64), np.ascontiguousarray(joint_v, dtype=np.float64),
                      helix_ratio, v_eps, commit, log, log_n, ev.scratch, wrenches, ev.per_screw, ev.totals, jac,
                      ev.d_twist, ev.d_pose, ev.on_link)


#: the kernels' log arguments when nothing is logged (no bulldozing)
NO_LOG = (np.zeros((0, 4)), np.zeros(2, dtype=np.int64))


def after_commit(component, terrain: DeformableTerrain, flow: SoilFlowLog, flows: int, t: float) -> None:
    """After a soil contact's commit: bulldoze (``flow``), stop the run when the tile pool ran out, tell the
    terrain's consumers when the soil changed."""
    raised = flow.apply(terrain) if flows >= 0 else 0
    if flows < 0 or raised < 0:
        component.stop(f"terrain '{terrain.source}': all {terrain.max_tiles} tiles of its max_tiles are in use at "
                       f"t = {t:.6g} s (each 32 × 32 nodes of {terrain.cell:g} m); raise max_tiles in the terrain "
                       f"file")
    elif flows > 0 or raised > 0:
        terrain.state.changed(t)


class _Run:
    def __init__(self, ns):
        self.terrain = None
        self.out = None
        self.commit = None
        self.commit_wrenches = self.jac_wrenches = None
        self.jac = self.flow = None
        self.ns = ns
        # per screw over the run's ticks in contact: Σ sinkage, its max, Σ slip and ticks (while spinning)
        self.sink_sum, self.sink_max, self.contact_ticks = np.zeros(ns), np.zeros(ns), np.zeros(ns)
        self.slip_sum, self.slip_ticks = np.zeros(ns), np.zeros(ns)


class TerramechanicsContact(Component[TerramechanicsContactParams]):
    type_name = "terramechanics_contact"

    robot = Uses(RobotModel)
    link_poses = Input(shape=link_shape(7), unit=None)
    link_velocities = Input(shape=link_shape(6), unit=None)
    joint_v = Input(shape=joint_shape, unit="rad/s", names=joint_names)
    terrain = Input(type=Terrain)
    wrenches = Output(shape=link_shape(6), unit=None, feedthrough=True,
                      names=link_element_names(("fx", "fy", "fz", "tx", "ty", "tz")))
    normal_force = Output(shape=(1,), unit="N", feedthrough=True)
    contacts = Output(shape=(1,), unit="1", feedthrough=True)
    screw_sinkage = Output(shape=_per_screw, unit="m", feedthrough=True, names=_screw_names)
    screw_slip = Output(shape=_per_screw, unit="1", feedthrough=True, names=_screw_names)
    screw_thrust = Output(shape=_per_screw, unit="N", feedthrough=True, names=_screw_names)
    screw_normal_force = Output(shape=_per_screw, unit="N", feedthrough=True, names=_screw_names)

    def setup(self):
        self.screws = self.robot.derived(screw_layout)
        self.geometry = ScrewGeometry(self.screws)

    def make_cache(self, x, u, y):
        return _Run(self.screws.ns)

    def _bind(self, run: _Run, terrain) -> DeformableTerrain:
        if terrain is run.terrain:
            return terrain
        require_soil(self, terrain, "terrains/snow-field.yaml", "screw_sdf_contact")
        g = self.geometry
        check_cell(terrain, g.radius, g.length, g.names)
        rows = scratch_rows(g.radius, g.length, terrain.cell)
        run.terrain = terrain
        nl = self.robot.nl
        run.out = SoilEvaluation(self.screws.ns, rows, nl)
        run.commit = SoilEvaluation(self.screws.ns, rows, nl)
        run.jac = SoilEvaluation(self.screws.ns, rows, nl)
        run.commit_wrenches = np.zeros((nl, 6))
        run.jac_wrenches = np.zeros((nl, 6))
        run.flow = SoilFlowLog(terrain, rows * self.screws.ns)
        return terrain

    def output(self, t, x, u, y):
        run = u.cache
        terrain = self._bind(run, u.terrain)
        p = self.p
        ev = run.out
        evaluate(terrain, self.geometry, u.link_poses, u.link_velocities, u.joint_v, y.wrenches, ev,
                 p.helix_shear_ratio, p.v_eps, False)
        y.normal_force[0] = ev.totals[0]
        y.contacts[0] = ev.totals[1]
        y.screw_sinkage[:] = ev.per_screw[:, SINKAGE]
        y.screw_slip[:] = ev.per_screw[:, SLIP]
        y.screw_thrust[:] = ev.per_screw[:, THRUST]
        y.screw_normal_force[:] = ev.per_screw[:, NORMAL]

    def port_jacobian(self, port, t, x, u, y):
        """∂wrenches/∂(screw link twist, displacement): per-link 6×6 blocks (kernels.py docstring), for
        linearly implicit integrators; without them the near-rest shear (slope τ_max ℓ / (K v_ε) per node
        area) is integrated explicitly and needs sub-millisecond steps."""
        if port != "wrenches":
            return None
        from snakesim.components.multibody.linearization import LinkWrenchJacobian

        run = u.cache
        terrain = self._bind(run, u.terrain)
        p, ev = self.p, run.jac
        evaluate(terrain, self.geometry, u.link_poses, u.link_velocities, u.joint_v, run.jac_wrenches, ev,
                 p.helix_shear_ratio, p.v_eps, False, jac=True)
        return LinkWrenchJacobian(rows=np.flatnonzero(ev.on_link), d_twist=ev.d_twist, d_pose=ev.d_pose,
                                  inputs=("link_poses", "link_velocities"))

    def check(self, t, u, restart):
        """Once per base tick, after the tick's outputs (never inside an integrator's stages): commit the
        soil's loads at this tick's poses (ruts, yield memory), then tell the terrain's consumers."""
        run = u.cache
        terrain = self._bind(run, u.terrain)
        p = self.p
        flows = evaluate(terrain, self.geometry, u.link_poses, u.link_velocities, u.joint_v, run.commit_wrenches,
                         run.commit, p.helix_shear_ratio, p.v_eps, True, flow=run.flow)
        after_commit(self, terrain, run.flow, flows, t)
        ps = run.commit.per_screw
        touching = ps[:, NODES] > 0
        run.contact_ticks += touching
        run.sink_sum += np.where(touching, ps[:, SINKAGE], 0.0)
        np.maximum(run.sink_max, ps[:, SINKAGE], out=run.sink_max)
        # driven: its ideal nut speed ω r tan λ at least DRIVEN_NUT_SPEED (slower, slip is a ratio of noise)
        g = self.geometry
        nut = np.abs(g.geo[:, 4] * u.joint_v[g.rows[:, 2]]) * g.radius * np.tan(g.geo[:, 2])
        driven = touching & (nut >= DRIVEN_NUT_SPEED)
        run.slip_ticks += driven
        run.slip_sum += np.where(driven, ps[:, SLIP], 0.0)

    def report(self, cache, summary):
        """summary.json's ``reports.contact``: per screw the mean sinkage over the ticks it touched the soil,
        the deepest, the mean slip while driven in contact (nut speed ω r tan λ ≥ DRIVEN_NUT_SPEED); the terrain's rut
        (deformable_files.py)."""
        run = cache
        if run is None or run.terrain is None:
            return None
        from snakesim.components.terrain.deformable_files import rut_summary

        with np.errstate(invalid="ignore", divide="ignore"):
            sink = np.where(run.contact_ticks > 0, run.sink_sum / run.contact_ticks, np.nan)
            slip = np.where(run.slip_ticks > 0, run.slip_sum / run.slip_ticks, np.nan)
        nan_none = lambda a: [None if not np.isfinite(v) else float(v) for v in a]   # noqa: E731
        return {"screws": list(self.geometry.names), "mean_sinkage_m": nan_none(sink),
                "max_sinkage_m": [float(v) for v in run.sink_max], "mean_slip_driven": nan_none(slip),
                "rut": rut_summary(run.terrain)}

    def write_files(self, cache, out_dir):
        """``--out``: the soil's state after the run (``soil_state.npz``, a later run's ``initial_state``) and a
        top view of the rut (``rut.png``, when the robot left one)."""
        run = cache
        if run is None or run.terrain is None:
            return []
        return write_soil_files(run.terrain, out_dir, self.name)

    @staticmethod
    def format_report(rep):
        sink = [v for v in rep["mean_sinkage_m"] if v is not None]
        slip = [v for v in rep["mean_slip_driven"] if v is not None]
        r = rep["rut"]
        lines = []
        if sink:
            lines.append(f"sinkage: mean over screws {100 * np.mean(sink):.1f} cm, deepest "
                         f"{100 * max(rep['max_sinkage_m']):.1f} cm")
        if slip:
            lines.append(f"slip while driven: median over screws {np.median(slip):.2f} (range {min(slip):.2f} to "
                         f"{max(slip):.2f})")
        lines.append(f"rut: {r['deformed_nodes']} nodes, deepest {100 * r['max_rut_depth_m']:.1f} cm, "
                     f"{1e3 * r['rut_volume_m3']:.1f} L pressed, {r['tiles_used']} of {r['max_tiles']} tiles")
        return lines
