"""Writes a scene into a rerun recording: static geometry once, then batched frames.

Shared by the live sink and ``snakesim replay`` so both produce the same
entities (layout: :mod:`.entities`). Costs are kept off the simulation:

- meshes (robot links, terrain) are logged once, static; afterwards a frame
  is only each link's Transform3D (a terrain whose state can change is logged
  on the ``sim`` timeline instead, once and at each change: ``log_terrain``);
- frames are buffered (one numpy copy per frame into preallocated arrays)
  and sent with ``send_columns``, one call per entity per ``flush_frames``
  frames (per-frame ``log`` calls cost ~80 µs per entity); the link
  transforms of a batch are one float32 copy and two arrow arrays that each
  link's column slices (~0.1 ms per link per batch, whatever its length);
- contacts, attraction arrows and tethers change size every frame: they are batched the
  same way, as partitioned columns (one partition per frame; an empty one
  clears the previous frame's), their colours and radii logged once, static.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pyarrow as pa

from . import entities as E

AXIS_COLORS = np.array([[230, 60, 60, 255], [60, 200, 60, 255], [60, 110, 240, 255]], dtype=np.uint8)
NORMAL_COLOR = (70, 140, 255, 255)
FRICTION_COLOR = (255, 150, 40, 255)
POINT_COLOR = (255, 230, 60, 255)
TETHER_COLOR = (250, 200, 40, 255)
ATTRACTION_COLOR = (255, 235, 0, 255)         # yellow, as the attraction arrows of paper fig. 9

# arrow types and descriptors of Transform3D's translation and quaternion (rerun 0.41: float32 xyz, xyzw)
_VEC3 = pa.list_(pa.field("item", pa.float32(), nullable=False), 3)
_QUAT = pa.list_(pa.field("item", pa.float32(), nullable=False), 4)


class _Arrow:
    """An arrow array as a rerun component batch (what ``ComponentColumn`` partitions)."""

    def __init__(self, array):
        self.array = array

    def as_arrow_array(self):
        return self.array


class SceneLog:
    """One recording's writer.

    rec         rerun.RecordingStream
    robot       multibody component name (entity ``world/physical/<robot>``), or None
    link_names  rows of the pose arrays this log receives (the multibody's link order)
    meshes      :class:`~.robot_geometry.LinkMesh` list (links without one get no entity)
    series      [(signal 'comp.port', element names or None, width)], one plot entity each
    visuals     {link: rr.Mesh3D} made beforehand (:func:`link_visuals`, e.g. at build time):
                converting the meshes to arrow costs ~10 ms on a 10-module robot
    """

    def __init__(self, rec, *, robot: str | None = None, link_names: Sequence[str] = (), meshes=(),
                 series: Sequence[tuple[str, Sequence[str] | None, int]] = (), body_frames: bool = False,
                 frame_length: float = 0.1, force_scale: float = 0.002, flush_frames: int = 30,
                 contacts: bool = False, tethers: bool = False, attraction: bool = False,
                 visuals: dict | None = None):
        import rerun as rr

        self.rr, self.rec = rr, rec
        self.robot = robot
        self.link_names = list(link_names)
        row = {n: i for i, n in enumerate(self.link_names)}
        self.meshes = [m for m in meshes if m.link in row]
        self.mesh_rows = np.array([row[m.link] for m in self.meshes], dtype=np.int64)
        self.link_paths = [E.link_path(robot or "robot", m.link) for m in self.meshes]
        self.visuals = visuals or {}
        self.body_frames, self.frame_length = body_frames, float(frame_length)
        self.frame_paths = [E.frame_path(n) for n in self.link_names] if body_frames else []
        # rows of the pose array sent as transforms, and where: meshed links, then body frames
        self._pose_rows = np.concatenate([self.mesh_rows, np.arange(len(self.frame_paths), dtype=np.int64)])
        self._pose_paths = self.link_paths + self.frame_paths
        self.force_scale = float(force_scale)
        self.series = [(s, tuple(names) if names else None, int(w)) for s, names, w in series]
        n = max(1, int(flush_frames))
        self._cap = n
        self._t = np.zeros(n)
        self._poses = np.zeros((n, len(self.link_names), 7))
        self._vals = [np.zeros((n, w)) for _, _, w in self.series]
        self._rtf = np.full(n, np.nan)
        self._n = 0
        self.contacts, self.tethers, self.attraction = contacts, tethers, attraction
        self._c_pts, self._c_fn, self._c_ft, self._tethers = [], [], [], []
        self._a_pts, self._a_vec = [], []

    # -- static geometry ------------------------------------------------------------------
    def log_static(self, terrain_mesh=None) -> None:
        rr, rec = self.rr, self.rec
        rec.log(E.WORLD, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for path, m in zip(self.link_paths, self.meshes):
            visual = self.visuals.get(m.link) or link_visuals([m])[m.link]
            rec.log(f"{path}/visual", visual, static=True)
        if self.body_frames:
            L = self.frame_length
            for name, path in zip(self.link_names, self.frame_paths):
                rec.log(f"{path}/axes", rr.Arrows3D(vectors=np.eye(3) * L, colors=AXIS_COLORS, radii=0.02 * L,
                                                    labels=[name, "", ""], show_labels=False), static=True)
        if terrain_mesh is not None:
            self.log_terrain(terrain_mesh)
        for signal, names, width in self.series:
            if names and len(names) == width:
                rec.log(E.series_path(signal), rr.SeriesLines(names=list(names)), static=True)
        rec.log(E.REAL_TIME_FACTOR, rr.SeriesLines(names=["real-time factor"]), static=True)
        if self.contacts:             # styles once, static; per frame only positions and vectors
            rec.log(E.CONTACT_POINTS, rr.Points3D.from_fields(colors=POINT_COLOR, radii=0.008), static=True)
            rec.log(E.CONTACT_NORMAL, rr.Arrows3D.from_fields(colors=NORMAL_COLOR, radii=0.004), static=True)
            rec.log(E.CONTACT_FRICTION, rr.Arrows3D.from_fields(colors=FRICTION_COLOR, radii=0.004), static=True)
        if self.tethers:
            rec.log(E.TETHERS, rr.LineStrips3D.from_fields(colors=TETHER_COLOR, radii=0.006), static=True)
        if self.attraction:
            rec.log(E.ATTRACTION, rr.Arrows3D.from_fields(colors=ATTRACTION_COLOR, radii=0.005), static=True)

    def log_terrain(self, mesh, t: float | None = None) -> None:
        """The terrain's mesh (world frame): static when ``t`` is None, else at simulated time ``t`` s
        (a terrain whose state changes: static data would hide every later mesh in rerun)."""
        rr, rec = self.rr, self.rec
        archetype = rr.Mesh3D(vertex_positions=mesh.vertices, triangle_indices=mesh.faces,
                              vertex_normals=mesh.normals, vertex_colors=mesh.colors,
                              face_rendering=rr.components.MeshFaceRendering.DoubleSided)
        if t is None:
            rec.log(E.TERRAIN, archetype, static=True)
            return
        rec.set_time(E.TIMELINE, duration=float(t))
        rec.log(E.TERRAIN, archetype)
        rec.reset_time()          # the frames are sent with explicit times; leave no time set behind

    # -- frames (buffered) ----------------------------------------------------------------
    def add_frame(self, t: float, poses=None, values: Sequence[np.ndarray] = (), rtf: float = np.nan,
                  contacts=None, tethers=None, attraction=None) -> None:
        """Queue one frame: link poses [nl, 7] (xyz + quaternion xyzw, world), one array
        per series, the real-time factor, the contact set, tether polylines and attraction
        springs (when the log was made with ``contacts``/``tethers``/``attraction``). Sent
        when ``flush_frames`` are queued."""
        k = self._n
        self._t[k] = t
        if poses is not None and self._poses.shape[1]:
            self._poses[k] = poses
        for buf, v in zip(self._vals, values):
            buf[k] = np.ravel(v)
        self._rtf[k] = rtf
        if self.contacts:
            self._queue_contacts(contacts)
        if self.tethers:
            self._tethers.append(tether_strips(tethers) or [])
        if self.attraction:
            self._queue_attraction(attraction)
        self._n = k + 1
        if self._n == self._cap:
            self.flush()

    def flush(self) -> None:
        n = self._n
        if n == 0:
            return
        self._n = 0
        t = self._t[:n]
        self.send_poses(t, self._poses[:n])
        for (signal, _, _), buf in zip(self.series, self._vals):
            self.send_series(signal, t, buf[:n])
        ok = np.isfinite(self._rtf[:n])
        if ok.any():
            self.send_series(E.REAL_TIME_FACTOR, t[ok], self._rtf[:n][ok], path=E.REAL_TIME_FACTOR)
        if self.contacts:
            self._flush_contacts(t)
        if self.tethers:
            self._flush_tethers(t)
        if self.attraction:
            self._flush_attraction(t)

    def send_poses(self, t: np.ndarray, poses: np.ndarray) -> None:
        """Transforms of every meshed link (and body frame) at times t (n,) from poses (n, nl, 7).

        All links' columns come from one float32 copy of the batch, link-major, and two arrow
        arrays (translations, quaternions) that each link's column slices without copying:
        rerun's ``Transform3D.columns`` would convert and validate per link (~0.2 ms each).
        """
        rr, rec = self.rr, self.rec
        n = len(t)
        if not n or not poses.shape[1] or not len(self._pose_rows):
            return
        P = np.asarray(poses)[:, self._pose_rows].transpose(1, 0, 2).astype(np.float32)   # (links, n, 7)
        trans = pa.FixedSizeListArray.from_arrays(pa.array(P[..., :3].reshape(-1)), type=_VEC3)
        quat = pa.FixedSizeListArray.from_arrays(pa.array(P[..., 3:].reshape(-1)), type=_QUAT)
        offsets = np.arange(n + 1, dtype=np.int32)          # one transform per row
        index = [rr.TimeColumn(E.TIMELINE, duration=t)]
        for i, path in enumerate(self._pose_paths):
            rec.send_columns(path, indexes=index, columns=[
                rr.ComponentColumn(rr.Transform3D.descriptor_translation(), _Arrow(trans.slice(i * n, n)),
                                   offsets=offsets),
                rr.ComponentColumn(rr.Transform3D.descriptor_quaternion(), _Arrow(quat.slice(i * n, n)),
                                   offsets=offsets)])

    def send_series(self, signal: str, t: np.ndarray, values: np.ndarray, path: str | None = None) -> None:
        rr = self.rr
        v = np.asarray(values, dtype=float).reshape(len(t), -1)
        self.rec.send_columns(path or E.series_path(signal), indexes=[rr.TimeColumn(E.TIMELINE, duration=t)],
                              columns=rr.Scalars.columns(scalars=v))

    # -- contacts and tethers: variable size per frame, batched as partitions ------------------
    def _queue_contacts(self, c) -> None:
        """Points and force arrows of a contact set: anything with ``points`` (m, 3) and
        ``forces`` (m, 3); with ``normals`` and ``normal_force`` the force is split into
        its normal and friction parts. Arrow length = force · force_scale (m/N)."""
        # copies: a producer may reuse its arrays next step
        pts = np.array(getattr(c, "points", np.zeros((0, 3))), dtype=float).reshape(-1, 3) if c is not None \
            else np.zeros((0, 3))
        f = np.asarray(c.forces, dtype=float).reshape(-1, 3) if len(pts) else np.zeros((0, 3))
        normals = getattr(c, "normals", None) if len(pts) else None
        fn = getattr(c, "normal_force", None) if len(pts) else None
        if normals is not None and fn is not None:
            f_n = np.asarray(fn, dtype=float).reshape(-1, 1) * np.asarray(normals, dtype=float).reshape(-1, 3)
            rest = f - f_n
        else:
            f_n, rest = f, np.zeros((0, 3))        # no normals: the whole force on the normal entity
        self._c_pts.append(pts)
        self._c_fn.append(self.force_scale * f_n)
        self._c_ft.append((pts[: len(rest)], self.force_scale * rest))

    def _flush_contacts(self, t) -> None:
        rr, rec = self.rr, self.rec
        index = [rr.TimeColumn(E.TIMELINE, duration=t)]
        lens = [len(p) for p in self._c_pts]
        pts = np.concatenate(self._c_pts) if sum(lens) else np.zeros((0, 3))
        rec.send_columns(E.CONTACT_POINTS, indexes=index, columns=rr.Points3D.columns(positions=pts).partition(lens))
        fn = np.concatenate(self._c_fn) if sum(lens) else np.zeros((0, 3))
        rec.send_columns(E.CONTACT_NORMAL, indexes=index,
                         columns=rr.Arrows3D.columns(vectors=fn, origins=pts).partition(lens))
        flen = [len(o) for o, _ in self._c_ft]
        org = np.concatenate([o for o, _ in self._c_ft]) if sum(flen) else np.zeros((0, 3))
        vec = np.concatenate([v for _, v in self._c_ft]) if sum(flen) else np.zeros((0, 3))
        rec.send_columns(E.CONTACT_FRICTION, indexes=index,
                         columns=rr.Arrows3D.columns(vectors=vec, origins=org).partition(flen))
        self._c_pts, self._c_fn, self._c_ft = [], [], []

    def _queue_attraction(self, a) -> None:
        """Arrows of the attraction springs: anything with ``points`` (m, 3) and ``forces`` (m, 3) N;
        arrow = force · force_scale (m/N) from its point. None: an empty frame (clears the last)."""
        pts = np.array(a.points, dtype=float).reshape(-1, 3) if a is not None else np.zeros((0, 3))
        f = np.array(a.forces, dtype=float).reshape(-1, 3) if len(pts) else np.zeros((0, 3))
        self._a_pts.append(pts)
        self._a_vec.append(self.force_scale * f)

    def _flush_attraction(self, t) -> None:
        rr = self.rr
        lens = [len(p) for p in self._a_pts]
        pts = np.concatenate(self._a_pts) if sum(lens) else np.zeros((0, 3))
        vec = np.concatenate(self._a_vec) if sum(lens) else np.zeros((0, 3))
        self.rec.send_columns(E.ATTRACTION, indexes=[rr.TimeColumn(E.TIMELINE, duration=t)],
                              columns=rr.Arrows3D.columns(vectors=vec, origins=pts).partition(lens))
        self._a_pts, self._a_vec = [], []

    def _flush_tethers(self, t) -> None:
        self.send_tethers(t, self._tethers)
        self._tethers = []

    def send_tethers(self, t, frames) -> None:
        """Tether polylines at times t (n,): frames[i] is a list of (m, 3) strips."""
        rr = self.rr
        lens = [len(s) for s in frames]
        strips = [s for frame in frames for s in frame]
        self.rec.send_columns(E.TETHERS, indexes=[rr.TimeColumn(E.TIMELINE, duration=t)],
                              columns=rr.LineStrips3D.columns(strips=strips).partition(lens))


def link_visuals(meshes) -> dict:
    """{link: rr.Mesh3D} of :class:`~.robot_geometry.LinkMesh` es (link frame)."""
    import rerun as rr

    return {m.link: rr.Mesh3D(vertex_positions=m.vertices, triangle_indices=m.faces, vertex_normals=m.normals,
                              vertex_colors=m.colors) for m in meshes}


def tether_strips(value) -> list[np.ndarray] | None:
    if value is None:
        return None
    for attr in ("strips", "points", "polyline"):
        if hasattr(value, attr) and not isinstance(value, np.ndarray):
            value = getattr(value, attr)
            break
    if isinstance(value, (list, tuple)):
        return [np.asarray(s, dtype=float).reshape(-1, 3) for s in value]
    a = np.asarray(value, dtype=float)
    if a.ndim == 2 and a.shape[1] == 3:
        return [a]
    if a.ndim == 3 and a.shape[2] == 3:
        return list(a)
    return None
