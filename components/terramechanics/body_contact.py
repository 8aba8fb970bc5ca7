"""Soil body contact: the robot's body links (their URDF collision cylinders) on a deformable soil (terrain
kind ``deformable``), for shape gaits on sand and regolith; screws are terramechanics_contact's.

Model, per collision cylinder (radius r, length L; a link may have several) against the terrain's nodes
(spacing Δ), as SCM does for any body and with the screws' soil law (the base's normal N: ẑ on a plane
base; terrain/deformable_kernels.py):

    contact nodes   those whose line along N meets the cylinder below the unloaded (rutted) surface
    normal          σ = min(K_e (s − s_p), (k_c / b + k_φ) sⁿ), s the sinkage along N,
                    b = the smaller of the chord 2√(2 r p − p²) of the deepest penetration p and the contact's
                    axial extent (+ Δ); F_n = max(0, σ − R v_n) A along N, A = Δ² / N_z
    shear           τ = (c + σ tan φ)(1 − e^(−j/K)) A (Mohr–Coulomb, Janosi–Hanamoto) against the node's
                    slip velocity u in the base's tangent plane (the link's material point; the soil at rest),
                    regularised as u / √(|u|² + v_ε²); j = the distance from the patch's upstream edge along
                    the piece centre's sliding direction (+ Δ/2): the soil under a sliding body has been
                    sheared by the path since it entered the patch (the steady form of SCM's per-node
                    j = ∫ |u| dt, Wong's j = i x at full slip)
    skin            the shear's along- and across-axis parts × ``along`` and ``across`` (1, 1: Mohr–Coulomb
                    alone). An ``across`` above 1 is a fitted stand-in for the groove wall's resistance
    rut walls       (``rut_walls``) that resistance from a model instead: a link slipping sideways pushes the
                    rut's wall, Rankine's passive earth pressure over its contact length L_c and depth z (its
                    deepest sinkage): P = L_c (½ γ z² K_p + 2 c z √K_p), K_p = tan²(45° + φ/2), γ = ρ g (the
                    soil's ``density``, ``gravity``), against the piece centre's slip across its axis v_a as
                    −P v_a / √(v_a² + v_ε²), z/3 above the piece's bottom (Rankine 1857; Terzaghi, Theoretical
                    Soil Mechanics, 1943: a smooth vertical wall, level ground: a lower bound for a rough one)
    wrench          Σ (F_n N + the shear) at each node (+ the walls' force), on the link about its origin

The loads are committed once per base tick (``check``), never inside the integrator's stages, as the
screws' (contact.py). Jacobian (``port_jacobian``, body_kernels.py docstring): per link the 6×6 blocks of the
shear's and the walls' velocity slopes (τ A / v_ε per node and P / v_ε per piece near rest, what limits an
explicit step) and of the pressure's height slope, for linearly implicit integrators (rosenbrock_w), as the
screws'.

Berms: with the terrain's ``bulldozing`` the soil each commit presses out is heaped on the patch's rim
(terrain/bulldozing.py). Not modelled: shapes other than cylinders (capsules, spheres, boxes are refused by
name), the soil the walls push (not moved), the walls' build-up with displacement (mobilised by the slip's
velocity), the transient build-up of j, a link standing on an end.

uses robot: RobotModel
in   link_poses[nl,7], link_velocities[nl,6]   multibody's (world)
     terrain                                   a DeformableTerrain
out  wrenches[nl,6]          N, N·m  to multibody.wrenches (or a wrench_sum with the screws')
     normal_force[1] N, contacts[1] (soil nodes under the links)
     link_normal_force[nl] N, link_sinkage[nl] m (the deepest node's sinkage under each link)
all feedthrough, no state of its own: the soil's state is the terrain's, committed in ``check``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
from pydantic import Field

from snakesim.framework import Component, ConfigError, Input, Output, Params, Uses
from snakesim.components.contact.body_samples import BodySampleOptions, selected_links
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_element_names, link_shape
from snakesim.components.multibody.urdf import MultibodyModelError, rpy_matrix
from snakesim.components.terrain.base import Terrain
from snakesim.components.terrain.bulldozing import SoilFlowLog
from snakesim.components.terrain.deformable import DeformableTerrain

from .body_kernels import L_NODES, L_NORMAL, L_SINKAGE, body_soil
from .contact import NO_LOG, after_commit, check_cell, require_soil, write_soil_files
from .kernels import SCRATCH_COLUMNS, scratch_rows


class SoilBodyContactParams(Params):
    links: list[str] = Field(["*"], description="fnmatch patterns of the links on the soil")
    exclude: list[str] = Field([], description="fnmatch patterns of links left out")
    exclude_screws: bool = Field(False, description="leave the design's screw links to terramechanics_contact")
    skin: dict[str, float] = Field({"along": 1.0, "across": 1.0},
                                   description="factors on the shear along / across each link's axis (module "
                                               "docstring: across > 1 stands in for the groove wall's resistance)")
    v_eps: float = Field(0.01, gt=0, description="m/s, slip-velocity regularisation of the shear's direction")
    rut_walls: bool = Field(False, description="the rut walls' passive earth pressure against each link's sideways "
                                               "slip (Rankine; module docstring); needs the soil's density")
    gravity: float = Field(9.81, gt=0, description="m/s², the soil's weight γ = ρ g in the rut walls' pressure (the "
                                                   "scene's gravity)")


class BodyPieces:
    """The kernel's per-piece arrays (body_kernels.py docstring) from the robot's collision cylinders."""

    def __init__(self, robot: RobotModel, p: SoilBodyContactParams):
        opts = BodySampleOptions(links=tuple(p.links), exclude=tuple(p.exclude), exclude_screws=p.exclude_screws)
        chosen = set(selected_links(robot, opts))
        along, across = float(p.skin.get("along", 1.0)), float(p.skin.get("across", 1.0))
        if set(p.skin) - {"along", "across"} or not (along >= 0 and across >= 0):
            raise ConfigError(f"skin = {p.skin}: give 'along' and 'across', factors ≥ 0", None, "skin")
        link, geo, Rs, ps, names = [], [], [], [], []
        for el in ET.fromstring(robot.urdf).findall("link"):
            name = el.get("name")
            if name not in chosen:
                continue
            for k, col in enumerate(el.findall("collision")):
                shape = next(iter(col.find("geometry")), None)
                where = f"{robot.label}: link '{name}' <collision> #{k + 1}"
                if shape is None or shape.tag != "cylinder":
                    raise MultibodyModelError(f"{where}: soil_body_contact takes <cylinder> collision shapes, not "
                                              f"<{getattr(shape, 'tag', 'nothing')}>; exclude the link ('exclude')")
                o = col.find("origin")
                Rs.append(rpy_matrix([float(v) for v in o.get("rpy", "0 0 0").split()]) if o is not None
                          else np.eye(3))
                ps.append([float(v) for v in o.get("xyz", "0 0 0").split()] if o is not None else [0.0, 0.0, 0.0])
                geo.append([float(shape.get("radius")), float(shape.get("length")), along, across])
                link.append(robot.link_row[name])
                names.append(f"{name}#{k + 1}")
        if not link:
            raise MultibodyModelError(f"soil_body_contact: no collision cylinders on the selected links of "
                                      f"{robot.label} (links {p.links}, exclude {p.exclude})")
        self.link = np.array(link, dtype=np.int64)
        self.geo = np.ascontiguousarray(geo, dtype=np.float64)
        self.R = np.ascontiguousarray(Rs, dtype=np.float64)
        self.p = np.ascontiguousarray(ps, dtype=np.float64)
        self.names = tuple(names)


class _Run:
    def __init__(self, nl):
        self.terrain = None
        self.scratch = self.walls = self.flow = None
        self.per_link, self.totals = np.zeros((nl, 3)), np.zeros(2)
        self.commit_wrenches = np.zeros((nl, 6))
        # the Jacobian's evaluation: its own outputs and blocks (body_kernels.py)
        self.jac_wrenches, self.jac_per_link, self.jac_totals = np.zeros((nl, 6)), np.zeros((nl, 3)), np.zeros(2)
        self.d_twist, self.d_pose = np.zeros((nl, 6, 6)), np.zeros((nl, 6, 6))
        self.on_link = np.zeros(nl, dtype=np.bool_)
        # over the run's ticks: Σ of the deepest sinkage under any link, its max, ticks in contact
        self.sink_sum, self.sink_max, self.ticks = 0.0, 0.0, 0


class SoilBodyContact(Component[SoilBodyContactParams]):
    type_name = "soil_body_contact"

    robot = Uses(RobotModel)
    link_poses = Input(shape=link_shape(7), unit=None)
    link_velocities = Input(shape=link_shape(6), unit=None)
    terrain = Input(type=Terrain)
    wrenches = Output(shape=link_shape(6), unit=None, feedthrough=True,
                      names=link_element_names(("fx", "fy", "fz", "tx", "ty", "tz")))
    normal_force = Output(shape=(1,), unit="N", feedthrough=True)
    contacts = Output(shape=(1,), unit="1", feedthrough=True)
    link_normal_force = Output(shape=link_shape(), unit="N", feedthrough=True)
    link_sinkage = Output(shape=link_shape(), unit="m", feedthrough=True)

    def setup(self):
        self.pieces = BodyPieces(self.robot, self.p)

    def make_cache(self, x, u, y):
        return _Run(self.robot.nl)

    def _bind(self, run: _Run, terrain) -> DeformableTerrain:
        if terrain is run.terrain:
            return terrain
        require_soil(self, terrain, "terrains/sand-field.yaml", "body_contact")
        g = self.pieces
        check_cell(terrain, g.geo[:, 0], g.geo[:, 1], g.names, what="body cylinder")
        run.walls = self._walls(terrain)
        run.terrain = terrain
        rows = scratch_rows(g.geo[:, 0], g.geo[:, 1], terrain.cell)
        run.scratch = np.zeros((rows, SCRATCH_COLUMNS))
        run.flow = SoilFlowLog(terrain, rows * len(g.link))
        return terrain

    def _evaluate(self, run, terrain, poses, vels, wrenches, commit, jac=False):
        st, g = terrain.state, self.pieces
        wrenches[...] = 0.0
        per_link, totals = (run.jac_per_link, run.jac_totals) if jac else (run.per_link, run.totals)
        log, log_n = (run.flow.entries, run.flow.count) if commit else NO_LOG
        return body_soil(terrain.grid, terrain.base_z, terrain.soil, st.tile_of, st.plastic, st.yield_p, st.lift,
                         st.used, g.link, g.geo, g.R, g.p, np.ascontiguousarray(poses, dtype=np.float64),
                         np.ascontiguousarray(vels, dtype=np.float64), self.p.v_eps, run.walls, commit, log, log_n,
                         run.scratch, wrenches, per_link, totals, jac, run.d_twist, run.d_pose, run.on_link)

    def _walls(self, terrain: DeformableTerrain) -> np.ndarray:
        """The kernel's [γ N/m³, K_p] of the rut walls (γ = 0: off): Rankine's K_p = tan²(45° + φ/2)."""
        if not self.p.rut_walls:
            return np.zeros(2)
        soil = terrain.soil_spec
        if soil.density is None:
            raise ConfigError(f"{self.name}: rut_walls needs the soil's bulk density (kg/m³, the weight in the walls' "
                              f"passive pressure); give soil.density in the terrain file", terrain.source,
                              "soil.density")
        phi = np.radians(soil.friction_angle)
        return np.array([soil.density * self.p.gravity, np.tan(np.pi / 4 + phi / 2) ** 2])

    def output(self, t, x, u, y):
        run = u.cache
        terrain = self._bind(run, u.terrain)
        self._evaluate(run, terrain, u.link_poses, u.link_velocities, y.wrenches, False)
        y.normal_force[0] = run.totals[0]
        y.contacts[0] = run.totals[1]
        y.link_normal_force[:] = run.per_link[:, L_NORMAL]
        y.link_sinkage[:] = run.per_link[:, L_SINKAGE]

    def port_jacobian(self, port, t, x, u, y):
        """∂wrenches/∂(link twist, displacement): per-link 6×6 blocks (body_kernels.py docstring)."""
        if port != "wrenches":
            return None
        from snakesim.components.multibody.linearization import LinkWrenchJacobian

        run = u.cache
        terrain = self._bind(run, u.terrain)
        self._evaluate(run, terrain, u.link_poses, u.link_velocities, run.jac_wrenches, False, jac=True)
        return LinkWrenchJacobian(rows=np.flatnonzero(run.on_link), d_twist=run.d_twist, d_pose=run.d_pose,
                                  inputs=("link_poses", "link_velocities"))

    def check(self, t, u, restart):
        """Once per base tick, after the tick's outputs: commit the soil's loads (ruts, yield memory)."""
        run = u.cache
        terrain = self._bind(run, u.terrain)
        flows = self._evaluate(run, terrain, u.link_poses, u.link_velocities, run.commit_wrenches, True)
        after_commit(self, terrain, run.flow, flows, t)
        touching = run.per_link[:, L_NODES] > 0
        if touching.any():
            deepest = float(run.per_link[touching, L_SINKAGE].max())
            run.ticks += 1
            run.sink_sum += deepest
            run.sink_max = max(run.sink_max, deepest)

    def report(self, cache, summary):
        """summary.json's ``reports.<name>``: the deepest link sinkage, its mean over the ticks in contact, and
        the terrain's rut (deformable_files.py)."""
        from snakesim.components.terrain.deformable_files import rut_summary

        run = cache
        if run is None or run.terrain is None:
            return None
        return {"mean_deepest_sinkage_m": run.sink_sum / run.ticks if run.ticks else None,
                "max_sinkage_m": run.sink_max, "rut": rut_summary(run.terrain)}

    def write_files(self, cache, out_dir):
        """``--out``: ``soil_state.npz`` and ``rut.png``, as terramechanics_contact's."""
        if cache is None or cache.terrain is None:
            return []
        return write_soil_files(cache.terrain, out_dir, self.name)

    @staticmethod
    def format_report(rep):
        r = rep["rut"]
        lines = []
        if rep["mean_deepest_sinkage_m"] is not None:
            lines.append(f"sinkage: deepest link mean {100 * rep['mean_deepest_sinkage_m']:.2f} cm, max "
                         f"{100 * rep['max_sinkage_m']:.2f} cm")
        lines.append(f"rut: {r['deformed_nodes']} nodes, deepest {100 * r['max_rut_depth_m']:.2f} cm, "
                     f"{1e3 * r['rut_volume_m3']:.2f} L pressed, {r['tiles_used']} of {r['max_tiles']} tiles")
        return lines
