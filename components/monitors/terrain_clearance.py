"""Which links end up inside the terrain: a watch for the bodies a scene gives no contact model.

A scene models only what it needs: the EELS 1.5 brace scenes let the screws touch the walls and
nothing else, so a module body or the tail may pass into a wall without any force acting. That is a
modelling choice a result must carry, not a silent one: this monitor samples the collision shapes
of the chosen links (the body contact's samples, components/contact/body_samples.py, fixed in their
links) at its ``rate`` and measures how deep each link has been inside the terrain::

    p = o_l + R_l s            every sample s of link l (link frame -> world)
    depth_l = max(0, −min φ(p))  over the link's samples, φ the terrain's signed distance
    inside  a link whose depth exceeded ``tolerance`` at some sample time

It reports the deepest depth per link over the run and when the first link went inside
(``report()``: ``summary.json`` under ``reports/<name>``, printed by ``snakesim run``), and
with ``stop_on_intrusion`` ends the run there, naming the link and depth. Links that have a
contact model in the scene are meant to be left out (``exclude_screws``, ``exclude``): their
depth is the contact's own business (its ``max_depth`` watch).

in   terrain              Terrain (the terrain component)
     link_poses[nl, 7]    role link_poses, from the multibody
out  max_depth m (deepest so far, any chosen link)
uses robot: RobotModel (the multibody's): links, collision shapes
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.contact.body_samples import BodySampleOptions, body_samples
from snakesim.components.multibody.pose_quaternions import rotation_matrices
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.multibody.robot_ports import link_shape
from snakesim.components.port_roles import LINK_POSES
from snakesim.components.terrain.base import Terrain
from snakesim.framework import Component, Input, Output, Params, Uses

from .watch import RunningWorst, WorstSoFarOutput, require_rate


class TerrainClearanceParams(Params):
    links: list[str] = Field(default_factory=lambda: ["*"], min_length=1, description="link name patterns watched")
    exclude: list[str] = Field(default_factory=list, description="link name patterns left out")
    exclude_screws: bool = Field(True, description="leave out the design's screw links (the screw contact's)")
    spacing: float = Field(0.03, gt=0, le=1.0, description="m, largest distance between neighbouring samples")
    tolerance: float = Field(0.005, ge=0, description="m, a link deeper than this counts as inside the terrain")
    stop_on_intrusion: bool = Field(False, description="end the run when a link first goes inside")


class TerrainClearance(WorstSoFarOutput, Component[TerrainClearanceParams]):
    type_name = "terrain_clearance"
    WORST_OUTPUT = "max_depth"
    robot = Uses(RobotModel)

    terrain = Input(type=Terrain)
    link_poses = Input(shape=link_shape(7), unit=None, role=LINK_POSES)
    max_depth = Output(shape=(), unit="m")

    def setup(self):
        p = self.p
        require_rate(self)
        opts = BodySampleOptions(spacing=p.spacing, links=tuple(p.links), exclude=tuple(p.exclude),
                                 exclude_screws=p.exclude_screws)
        s = self.robot.derived(body_samples, opts)
        counts = np.diff(s.start)
        self._link = np.repeat(s.piece_link, counts).astype(np.int64)    # sample -> link row
        self._points = s.points
        self.watched = tuple(sorted({self.robot.links[i] for i in s.piece_link}, key=self.robot.links.index))

    def make_cache(self, x, u, y):
        return RunningWorst(self.robot.nl)       # worst: the deepest depth per link, m

    def update(self, t, xd, u):
        if not self._link.size:
            return
        poses = np.asarray(u.link_poses, float)
        R = rotation_matrices(poses[self._link, 3:])
        world = poses[self._link, :3] + np.einsum("nij,nj->ni", R, self._points)
        depth = np.maximum(-u.terrain.distance(world), 0.0)
        w = u.cache
        np.maximum.at(w.worst, self._link, depth)
        row = w.end_sample(t, xd, self.p.tolerance, self.robot.links, w.worst)
        if row is not None and self.p.stop_on_intrusion:
            self.stop(f"{self.robot.links[row]} is {1e3 * w.worst[row]:.1f} mm inside the terrain "
                      f"(tolerance {1e3 * self.p.tolerance:.1f} mm; it has no contact model in this scene)")

    # -- the run's report (framework/run_reports.py) -------------------------------------------
    def report(self, cache, summary: dict) -> dict:
        """The deepest depth of every watched link that went inside, deepest first."""
        if cache is None:
            return {}
        tol = self.p.tolerance
        r = {"tolerance_m": tol, "watched": list(self.watched),
             "max_depth_m": float(cache.worst.max(initial=0.0)),
             "inside": {self.robot.links[i]: float(cache.worst[i]) for i in cache.over(tol)},
             **cache.first_report("link", "depth_m")}
        return r

    @staticmethod
    def format_report(r: dict) -> list[str]:
        """Lines for the terminal."""
        if not r["inside"]:
            return [f"no watched link went deeper than {1e3 * r['tolerance_m']:.3g} mm into the terrain"]
        worst = ", ".join(f"{k} {1e3 * v:.0f} mm" for k, v in list(r["inside"].items())[:5])
        more = len(r["inside"]) - 5
        return [f"links inside the terrain (no contact model in this scene): {worst}"
                + (f" and {more} more" if more > 0 else "")]
