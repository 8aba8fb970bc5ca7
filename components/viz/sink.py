"""Rerun viewer sink: the robot, terrain, contacts, tethers, placement attraction, what the sensors
measure and recorded signals, live or to an .rrd.

A sink (``is_sink``): it keeps its upstream alive, has no outputs and runs
as a discrete component at the viewer rate (its ``rate``; without one it
decimates itself to ``viewer_rate``), so the simulation pays for logging
30 times per simulated second, not every step. ``snakesim run --viz ...``
adds and wires it (:mod:`.attach`); in YAML::

    viz: {type: rerun_viewer, rate: 30.30303, params: {target: "save run.rrd", robot_component: robot}}
    connections: [robot.link_poses -> viz.link_poses, ground.terrain -> viz.terrain]

uses robot: RobotModel (the multibody's; optional): its links are the rows of link_poses and its
     URDF visuals the meshes drawn (``robot.derived(link_meshes)``: built once per robot); with
     several providers name one with ``uses: {robot: NAME}``. No robot in the scene: no links drawn
in   link_poses[nl, 7]  m, 1  [x, y, z, qx, qy, qz, qw] per link, world (the multibody's; optional)
     terrain            Terrain, drawn once as a static mesh (optional); a terrain with state
                        (``terrain.state.may_change``) is drawn at the first frame and again, at
                        the change's time, whenever its ``state.version`` moves (terrain/derived.py)
     contacts           ContactSet (any contact back end): points and forces, split into normal
                        and friction arrows (optional)
     attraction         AttractionSet: placement_settle's attraction springs, points (m, 3) and
                        forces (m, 3) N, drawn as yellow arrows under world/debug/attraction (optional)
     tethers            any structured value with ``strips``/``points`` polylines (optional);
                        without it, params.tether_lines are drawn as straight segments from
                        each tie point (link pose · offset) to its anchor
     s0 .. s{k-1}       one numeric input of any shape per entry of params.series (the signal
                        it plots, 'comp.port'); made per instance from the params; its legend
                        names the elements as params.series_names does (attach.py fills it from
                        the source port's declared names), else rerun numbers them
     sensor0 .. sensor{m-1}
                        one structured input per entry of params.sensors (the sensor output it
                        draws, 'comp.port'): a LidarScan (points coloured by intensity) or a
                        CameraFrame (pinhole, image, depth), drawn under world/sensors/<comp>/<port>
                        at each sample's own time (:mod:`.sensor_log`); made per instance
out  none

First frame: opens the recording (:func:`.target.open_recording`: headless
machines never spawn a window), logs the static meshes. Every frame: link
transforms, series values, the real-time factor, contacts, attraction arrows
and tethers are queued and sent in ``send_columns`` batches
(:class:`.scene_log.SceneLog`) of 1 s of frames to a live viewer, 2 s to a
file (``flush_frames``); a sensor sample not yet drawn is logged at once, at
its sample time (:class:`.sensor_log.SensorLog`). Everything is sent and the
file closed at the last frame before ``t_end``, on the session's ``close()``
(``plan.caches[name].close()``), or at interpreter exit. A later run of the
same build (time going back) starts a new recording. The recording and its
clock are the build's (``make_cache``), not the component's. Entity layout and
the physical / ornamental contract: :mod:`.entities`.
"""

from __future__ import annotations

import atexit
import dataclasses
import sys
import time
import weakref

import numpy as np
from pydantic import Field, field_validator

from snakesim.components.contact import ContactSet
from snakesim.components.multibody.robot_model import RobotModel
from snakesim.components.placement import AttractionSet
from snakesim.components.terrain import Terrain, TerrainDerived
from snakesim.framework import Component, Input, Params, Uses
from snakesim.components.port_roles import LINK_POSES

from . import entities as E
from .robot_geometry import link_meshes
from .target import VizTargetError, open_recording, parse_target

Vec3 = tuple[float, float, float]
LIVE_FLUSH_S = 1.0       # simulated s of frames per send_columns batch to a live viewer
SAVE_FLUSH_S = 2.0       # ... to an .rrd file


class RerunSinkParams(Params):
    target: str = Field("save snakesim.rrd", description="spawn | serve | save FILE.rrd")
    viewer_rate: float = Field(30.0, gt=0, description="Hz; frames per simulated second when the component has no rate")
    application_id: str = "snakesim"
    recording_id: str | None = Field(None, description="rerun recording id (default: a fresh one per run)")
    # the robot itself is the RobotModel resource (uses robot); this only names its entity
    robot_component: str = Field("robot", description="entity name of the robot: world/physical/<this> "
                                                      "(--viz: the component that provides the robot)")
    # what to draw
    terrain_extent: float = Field(4.0, gt=0, description="m: unbounded terrains drawn this far around the centre")
    terrain_cell: float = Field(0.25, gt=0, description="m: checkerboard cell of drawn terrain")
    terrain_center: Vec3 | None = Field(None, description="m, world; default: the robot's start centroid")
    terrain_cutaway: Vec3 | None = Field((0.0, -0.6, 0.8), description="enclosing terrain cut away towards this")
    body_frames: bool = Field(False, description="draw every link frame (ornamental)")
    frame_length: float = Field(0.1, gt=0, description="m, body frame axis length")
    force_scale: float = Field(0.002, gt=0, description="m of arrow per N of contact or attraction force")
    series: list[str] = Field(default_factory=list, description="'comp.port' plotted from inputs s0, s1, ...")
    series_names: list[list[str] | None] = Field(
        default_factory=list, description="each series' element names, the plot's legend (planar_pose: x, y, yaw), "
                                          "as its port declares them; None or missing: numbered")
    sensors: list[str] = Field(default_factory=list, description="'comp.port' of lidar scans and camera frames "
                                                                 "drawn from inputs sensor0, sensor1, ...")
    point_radius: float = Field(0.01, gt=0, description="m, radius of a drawn lidar point")
    intensity_range: tuple[float, float] = Field((0.0, 1.0), description="lidar intensities spread over the "
                                                                          "colormap (saturated outside)")
    frustum_depth: float = Field(0.3, gt=0, description="m, length of a camera's drawn frustum")
    tether_lines: list[dict] = Field(default_factory=list,
                                     description="[{link, offset, anchor}]: straight ropes drawn from link_poses")
    serve_host: str = Field("127.0.0.1", description="serve: the address its servers bind (0.0.0.0: every "
                                                     "interface, reachable from other machines)")
    serve_port: int = Field(9090, ge=0, le=65535, description="serve: the web viewer's HTTP port")
    grpc_port: int = Field(9876, ge=0, le=65535, description="serve: the gRPC server's port (rerun --connect)")
    keep_serving: bool = Field(True, description="serve: after the run, keep serving until Ctrl-C when the "
                                                 "process has a terminal (stdin is a tty)")
    flush_frames: int | None = Field(None, ge=1, description="frames per send_columns batch; default "
                                     "1 s of frames live (spawn, serve), 2 s when saving")
    t_end: float | None = Field(None, description="s: send everything and close at this time")

    @field_validator("intensity_range")
    @classmethod
    def _intensity_range(cls, v):
        if not v[0] < v[1]:
            raise ValueError(f"intensity_range = {list(v)}: the low end must be below the high end")
        return v

    @field_validator("target")
    @classmethod
    def _target(cls, v):
        try:
            parse_target(v)
        except VizTargetError as e:
            raise ValueError(str(e)) from None
        return v


def robot_visuals(robot: RobotModel) -> dict:
    """{link: rr.Mesh3D} of the robot's link meshes: converted to arrow once per robot
    (``robot.derived(robot_visuals)``), not once per viewer."""
    from .scene_log import link_visuals

    return link_visuals(robot.derived(link_meshes))


def series_input_name(i: int) -> str:
    return f"s{i}"


def sensor_input_name(i: int) -> str:
    return f"sensor{i}"


class RerunSink(Component[RerunSinkParams]):
    type_name = "rerun_viewer"
    is_sink = True

    robot = Uses(RobotModel, required=False, doc="the robot drawn: link rows and URDF visuals")

    link_poses = Input(shape=lambda c: (len(c.links), 7), unit=None, default=0.0,
                       doc="[x, y, z, qx, qy, qz, qw] per link, world", role=LINK_POSES)
    terrain = Input(type=Terrain, required=False, doc="drawn once, static (again at each change of its state)")
    contacts = Input(type=ContactSet, required=False, doc="contact points and forces, any contact back end")
    tethers = Input(type=object, required=False, doc="anything with strips/points polylines")
    attraction = Input(type=AttractionSet, required=False, doc="placement springs: points (m,3), forces (m,3)")

    def setup(self):
        p = self.p
        self.target = parse_target(p.target)
        if self.target.mode == "serve":
            self.target = dataclasses.replace(self.target, host=p.serve_host, port=p.serve_port,
                                              grpc_port=p.grpc_port)
        robot = self.robot
        self.links = robot.links if robot is not None else ()
        # series inputs are per instance: one numeric input of any shape per signal
        # and sensor inputs: one structured input per sensor output drawn (LidarScan or CameraFrame)
        self.add_inputs({**{series_input_name(i): Input(shape=None, unit=None, default=np.zeros(0))
                            for i in range(len(p.series))},
                         **{sensor_input_name(i): Input(type=object, doc=f"{ref}: a LidarScan or a CameraFrame")
                            for i, ref in enumerate(p.sensors)}})
        self._period = 1.0 / (self.rate or p.viewer_rate)
        # the slow parts (mesh building, rerun's import: ~2 s) happen at build time, not in the run
        import rerun.blueprint  # noqa: F401

        self._meshes = robot.derived(link_meshes) if robot is not None else []
        self._visuals = robot.derived(robot_visuals) if robot is not None else {}   # arrow conversion once

    def make_cache(self, x, u, y):
        """This build's viewer session (:class:`_Viewing`): the recording, opened at the first frame, and
        its clock."""
        return _Viewing()

    # -- the per-frame path ---------------------------------------------------------------
    def update(self, t, xd, u):
        v = u.cache
        if t < v.last_t:                             # a new run of the same build
            v.close()
            v.last_t = v.next_t = -np.inf
        if self.rate is None:                        # no scheduler rate: decimate here
            if t < v.next_t - 1e-9 * self._period:
                return
            v.next_t = t + self._period
        if v.log is None:
            if v.last_t > -np.inf:                   # closed at t_end: nothing more this run
                return
            self._open(v, t, u)
        if v.terrain_mesh is not None and u.terrain is not None and v.terrain_mesh.stale(u.terrain):
            _log_terrain(v, t, u.terrain)          # first frame, or the terrain's state changed
        wall = time.perf_counter()
        rtf = (t - v.last_t) / (wall - v.last_wall) if v.last_t > -np.inf else np.nan
        v.last_t, v.last_wall = t, wall
        tethers = u.tethers if v.has_tethers else (v.ropes.segments(v.poses) if v.ropes is not None else None)
        v.log.add_frame(t, v.poses, v.series, rtf, contacts=u.contacts if v.has_contacts else None,
                        tethers=tethers, attraction=u.attraction if v.has_attraction else None)
        if v.sensors is not None:
            v.sensors.add([getattr(u, name) for name in v.sensor_inputs])
        # the last frame is the one whose successor would fall at or after t_end (the loop makes no
        # update at t_end itself): close here, whatever the run's length modulo the frame period
        if self.p.t_end is not None and t + self._period > self.p.t_end - 1e-9 * self._period:
            v.close()

    # -- opening ----------------------------------------------------------------------------
    def _open(self, v: _Viewing, t, u):
        from .blueprint import default_blueprint
        from .terrain_geometry import terrain_mesh

        p = self.p
        v.poses = u.link_poses                       # input views: never reallocated
        v.series = [getattr(u, series_input_name(i)) for i in range(len(p.series))]
        v.has_contacts = u.contacts is not None
        v.has_tethers = u.tethers is not None
        v.has_attraction = u.attraction is not None
        v.ropes = _ropes(p.tether_lines, self.links) if not v.has_tethers else None
        pos = np.asarray(v.poses)[:, :3] if len(self.links) else np.zeros((1, 3))
        center = np.asarray(p.terrain_center) if p.terrain_center is not None else pos.mean(axis=0)
        terrain = u.terrain
        tmesh = v.terrain_mesh = None
        if terrain is not None:
            def draw(terrain):
                return terrain_mesh(terrain, center, p.terrain_extent, p.terrain_cell, p.terrain_cutaway)

            if terrain.state.may_change:           # logged in time by update(), now and at each change
                v.terrain_mesh = TerrainDerived(draw)
            else:
                tmesh = draw(terrain)
        names = list(p.series_names) + [None] * (len(p.series) - len(p.series_names))
        series = [(s, n, int(np.size(a))) for s, n, a in zip(p.series, names, v.series)]
        v.sensor_inputs = [sensor_input_name(i) for i in range(len(p.sensors))]
        bp = default_blueprint(pos, [E.series_path(s) for s in p.series],
                               _camera_pinholes(p.sensors, [getattr(u, n) for n in v.sensor_inputs]))
        rec, v.used_target = open_recording(self.target, p.application_id, p.recording_id, blueprint=bp)
        from .scene_log import SceneLog

        v.log = SceneLog(rec, robot=p.robot_component, link_names=self.links, meshes=self._meshes, series=series,
                         visuals=self._visuals,
                         body_frames=p.body_frames, frame_length=p.frame_length, force_scale=p.force_scale,
                         flush_frames=self._flush_frames(v.used_target), contacts=v.has_contacts,
                         attraction=v.has_attraction, tethers=v.has_tethers or v.ropes is not None)
        v.log.log_static(tmesh)
        if p.sensors:
            from .sensor_log import SensorLog

            v.sensors = SensorLog(rec, p.sensors, point_radius=p.point_radius, intensity_range=p.intensity_range,
                                  frustum_depth=p.frustum_depth)
        v.finalizer = weakref.finalize(v, _finish, v.log, rec, v.used_target.mode, v.used_target.path,
                                       p.keep_serving)
        v.last_wall = time.perf_counter()

    def _flush_frames(self, target) -> int:
        # a live viewer wants to see the run move; a file only pays per send_columns call
        if self.p.flush_frames is not None:
            return self.p.flush_frames
        seconds = SAVE_FLUSH_S if target.mode == "save" else LIVE_FLUSH_S
        return max(1, round(seconds / self._period))


class _Viewing:
    """One build's viewer session: the recording and scene log (None until the first frame, and after
    ``close()``), the last frame's simulated and wall time, the next frame's time when the sink
    decimates itself, and the input views and options the first frame found."""

    def __init__(self):
        self.log = self.finalizer = self.used_target = None
        self.last_t = self.next_t = -np.inf
        self.last_wall = 0.0
        self.poses, self.series, self.ropes = None, [], None
        self.has_contacts = self.has_tethers = self.has_attraction = False
        self.sensors, self.sensor_inputs = None, []
        self.terrain_mesh = None        # TerrainDerived of a terrain with state; None: static or none

    def close(self) -> None:
        """Send what is queued and close the recording (idempotent)."""
        if self.finalizer is not None:
            self.finalizer()
        self.finalizer, self.log, self.sensors = None, None, None


class _Ropes:
    """Straight tether segments: tie point o + R(q)·offset on a link to a world anchor."""

    def __init__(self, rows, offsets, anchors):
        self.rows, self.offsets, self.anchors = rows, offsets, anchors

    def segments(self, poses) -> np.ndarray:
        P = np.asarray(poses)[self.rows]
        qv, w = P[:, 3:6], P[:, 6:7]
        # offsets rotated by the unit quaternions (x, y, z, w): v + 2w(q×v) + 2q×(q×v)
        c = np.cross(qv, self.offsets)
        tie = P[:, :3] + self.offsets + 2 * w * c + 2 * np.cross(qv, c)
        return np.stack([tie, self.anchors], axis=1)


def _log_terrain(v: _Viewing, t: float, terrain: Terrain) -> None:
    """Log the mesh of a terrain with state as it is now: at its first frame ``t``, then at the time its
    model gave the change (``state.changed_at``), else at the frame that noticed it."""
    first = v.terrain_mesh.builds == 0
    mesh = v.terrain_mesh.get(terrain)
    at = terrain.state.changed_at
    v.log.log_terrain(mesh, t if first or at is None else at)


def _ropes(lines, links) -> _Ropes | None:
    if not lines:
        return None
    row = {n: i for i, n in enumerate(links)}
    bad = [d.get("link") for d in lines if d.get("link") not in row]
    if bad:
        raise ValueError(f"tether_lines: links {bad} are not robot links; links: {', '.join(links)}")
    return _Ropes(np.array([row[d["link"]] for d in lines]),
                  np.array([d.get("offset", (0.0, 0.0, 0.0)) for d in lines], dtype=float),
                  np.array([d["anchor"] for d in lines], dtype=float))


def _camera_pinholes(refs, values) -> list[str]:
    """Pinhole entities of the sensor outputs whose first value is a camera frame (a 2-D view each)."""
    from snakesim.components.perception import CameraFrame

    return [f"{E.sensor_path(ref)}/{E.SENSOR_PINHOLE}" for ref, value in zip(refs, values)
            if isinstance(value, CameraFrame)]


def _finish(log, rec, mode: str, path: str | None = None, keep_serving: bool = True) -> None:
    log.flush()
    rec.flush()
    if mode == "save":
        rec.disconnect()                             # writes the .rrd footer
        # say what was written, and how to look at it: a save is otherwise silent
        sys.stderr.write(f"snakesim viz: wrote {path} (view it with `rerun {path}`)\n")
    elif mode == "serve":
        serving = getattr(rec, "_snakesim_serving", None)
        if serving is None:
            return
        if keep_serving and sys.stdin is not None and sys.stdin.isatty():
            # at exit, once the run has printed its summary and written --out: a short run's viewer stays
            atexit.register(_serve_until_interrupted, serving)
        else:
            sys.stderr.write("snakesim viz: run finished; the servers stop now (stdin is not a terminal, "
                             "so nobody could press Ctrl-C: use --viz save FILE.rrd to keep the run)\n")
            serving.stop()


def _serve_until_interrupted(serving) -> None:
    """Keep a served recording up after the run, until Ctrl-C (or SIGTERM); then stop its servers."""
    import signal

    where = serving.web_url or f"`rerun --connect {serving.url}`"
    sys.stderr.write(f"snakesim viz: run finished; still serving the recording at {where}: "
                     "press Ctrl-C to stop\n")
    sys.stderr.flush()
    old = None
    try:
        old = signal.signal(signal.SIGTERM, signal.default_int_handler)
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        sys.stderr.write("\nsnakesim viz: stopped serving\n")
    except ValueError:                   # not the main thread: no signal handling, no waiting
        pass
    finally:
        if old is not None:
            signal.signal(signal.SIGTERM, old)
        serving.stop()
