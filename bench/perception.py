"""Perception cost: rays per second of the lidar and the cameras against raw Embree on the same
geometry, frame times, and the default scene's real-time factor with the sensors on and off.

rays      at each scene's initial state (the robot as the scene starts it, the terrain as the
          sensor_scene builds it), the same world rays cast (a) by raw ``embreex``: one Embree
          scene holding the terrain mesh and the posed robot mesh, ``run(..., output=1)``, as one
          call ("raw") and split into the caster's chunks, one thread each ("raw xN": embreex
          releases the GIL; the pipeline casts its chunks so, N = numba's thread count; both in
          the sensor's cast order: a lidar's pattern order, a camera's interleaved), and
          (b) by the sensor:
          ``Lidar.sample`` (64x1024, spinning-64) and ``StereoCamera``'s render of both eyes
          (640x480 pinhole, sun without shadows): everything from the sensor pose to the
          finished scan or images. Raw and pipeline run in turn in each repeat, best of
          ``--repeats``. pipeline/raw rays per second is the pipeline's efficiency (target ≥ 0.7).
          The lidar twice: ``terrain_hits: exact`` (the default: hits on a curved analytic
          terrain refined onto its surface, what the contact model touches) and ``mesh`` (the
          tessellation's hits: the geometry raw casts), with the range difference of the
          mesh's returns from the exact ones (max, rms, 99th percentile; beams that return in
          both) and how many beams change status; the stereo pair likewise (speed only).
frames    the same sensors' time on a fresh instant (link rotations and bounding spheres not yet
          computed: nothing else is built per instant), in the obstacle course and the moulin.
accuracy  the ranges of ``terrain_hits: exact`` and ``mesh`` against a reference computed without the
          caster: a spinning-64 lidar 5 cm off the axis of a 0.3 m tube (its beams along the axis
          graze the wall; reference: the ray-cylinder quadratic), and 20 cm above the fractal DEM
          (terrains/fractal-dem.yaml; reference: z_ray − h sampled every 0.5 mm along the beam with
          the contact's height query, the first sign change bisected); max and RMS error per mode,
          the mesh's worst error over its first-order bound sag/sin θ (θ the grazing angle), and the
          DEM cast's rays per second exact and mesh (the DEM's hits were the mesh's before its
          refinement), best of ``--repeats``.
rtf       the default scene (surface-screw-traverse, its dt and integrator) with a 64x1024 lidar
          at 10 Hz and a 640x480 stereo pair at 10 Hz (``--lidar spinning-64 --stereo 640x480
          --stereo-rate 10``: sensor_scene's ``ray_caster: raster``, the pair rasterised), the same
          cast by Embree alone (``ray_caster: embree``: before the raster back end), the same with
          the sensors seeing the robot's collision shapes (``robot_geometry: collision``: screw
          envelopes instead of blades), and without sensors, alternately in this process, best of
          ``--repeats`` after a warm-up (issue 26's goal: the sensors on at >= 5x real time).

    python bench/perception.py [--repeats 3] [--duration 2] [--only rays|accuracy|rtf] [--json FILE]
"""

from __future__ import annotations

import argparse
import concurrent.futures
import copy
import json
import os
import platform
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from snakesim.components.perception import SensorScene  # noqa: E402
from snakesim.components.perception.attach import attach_lidar, attach_stereo  # noqa: E402
from snakesim.components.perception.hit_kernels import rays_to_world  # noqa: E402
from snakesim.components.perception.lidar import RETURN  # noqa: E402
from snakesim.components.perception.ray_caster import (CAST_CHUNK_MIN, THREADS, CastBuffers,  # noqa: E402
                                                        RobotScenes, SensorWorld, chunks, embree_scene)
from snakesim.framework.assembly import resolve  # noqa: E402
from snakesim.framework.registry import default_registry  # noqa: E402
from snakesim.framework.session import Session  # noqa: E402

_POOL = concurrent.futures.ThreadPoolExecutor(THREADS)
SCENES = {"obstacle-course": "perception-obstacle-course", "moulin": "moulin"}
#: scenes whose robot has no head sensor frames (the moulin's EELS 1.5): mount on the front module,
#: 0.3 m ahead of its frame, in the shaft 12 cm from the wall (at [0.45, 0, 0.1] it sat 5 cm inside
#: the ice, and its beams hit the wall from behind)
MOUNTS = {"moulin": {"link": "module_03", "xyz": [0.3, 0.0, 0.0]}}
DEFAULT = "surface-screw-traverse"
#: the real-time factor's sensor rates (issue 26: both at 10 Hz)
RTF_LIDAR_RATE, RTF_STEREO_RATE = 10.0, 10.0


def sensor_session(scene: str, duration: float | None = None) -> Session:
    """The scene with a spinning-64 lidar and a 640x480 stereo pair (its own, or added)."""
    reg = default_registry()
    sim = {"duration": duration} if duration else {"duration": 0.002}
    r = resolve(scene, search_path=reg.assembly_paths(), sim_overrides=sim)
    if "lidar" in r.components:
        r.components["lidar"].params.update(preset="spinning-64")
        r.components["stereo"].params.update(width=640, height=480, light={"kind": "sun", "shadows": False})
    else:
        attach_lidar(r, "spinning-64", reg)
        attach_stereo(r, "640x480", reg)
        for name in ("lidar", "stereo"):
            r.components[name].params.update(MOUNTS.get(scene, {}))
    return Session(r, reg)


def initial_world(scene: str) -> tuple[SensorWorld, Session]:
    """The sensor_scene's world at the scene's first step (captured from its output; the plan binds
    methods at build, so the spy goes in first)."""
    seen = {}
    original = SensorScene.output

    def spy(self, t, x, u, y):
        original(self, t, x, u, y)
        seen.setdefault("world", y.world)

    SensorScene.output = spy
    try:
        s = sensor_session(scene)
        s.run()
    finally:
        SensorScene.output = original
    return seen["world"], s


def fresh(world: SensorWorld) -> SensorWorld:
    """The same instant with nothing computed for it yet (link rotations and bounding spheres)."""
    return SensorWorld(world.t, world.terrain, world.robot, world.link_poses)


def best(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def raw_scene(world: SensorWorld):
    """One Embree scene of the terrain mesh and the posed robot mesh."""
    ter = world.terrain.surfaces
    rob = world.robot.surfaces
    posed = rob.posed(world.rotations, world.link_poses[:, :3])
    V = np.vstack([ter.vertices, posed])
    F = np.vstack([ter.faces, rob.faces + len(ter.vertices)]).astype(np.int32)
    return embree_scene((V, F))


def world_rays(R, p, o_l, d_l, min_range):
    n = len(o_l)
    o_w, d_w = np.empty((n, 3)), np.empty((n, 3))
    o32, d32 = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
    rays_to_world(o_l, d_l, R, p, float(min_range), o_w, d_w, o32, d32)
    return o32, d32


def interleaved(fns: dict, repeats: int) -> dict:
    """Best time of each function, the functions run in turn in every repeat (a machine whose load
    drifts affects them alike)."""
    times = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    return {k: min(v) for k, v in times.items()}


def raw_cast(scene, o32, d32, far, threaded: bool):
    """Raw embreex: one ``run`` over every ray, or the rays (in the sensor's cast order) split into
    the caster's chunks (``chunks(n, CAST_CHUNK_MIN)``), one thread each (embreex releases the GIL)."""
    parts = chunks(len(o32), CAST_CHUNK_MIN)
    if not threaded or len(parts) == 1:
        return scene.run(o32, d32, dists=far.copy(), query="INTERSECT", output=1)
    futures = [_POOL.submit(scene.run, o32[sl], d32[sl], far[sl].copy(), "INTERSECT", 1) for sl in parts]
    return [f.result() for f in futures]


def rays(scene: str, repeats: int) -> dict:
    world, s = initial_world(SCENES[scene])
    lidar, stereo = s.plan.components["lidar"], s.plan.components["stereo"]
    raw = raw_scene(world)
    world.spheres()                                    # the instant's link spheres, as in a run

    # the lidar: its pose, its beams, the same rays raw
    R_wl, p_wl = world.link_pose(lidar.row)
    R, p = R_wl @ lidar.R_ls, p_wl + R_wl @ lidar.p_ls
    o32, d32 = world_rays(R, p, lidar.pattern.origins, lidar.pattern.directions, 1e-6)
    far = np.full(len(o32), lidar.max_range, np.float32)
    raw.run(o32[:10], d32[:10])
    exact = lidar.sample(world, 0.0, 0)
    # the same lidar with terrain_hits: mesh (its own buffers: a scan's arrays are views of them)
    mesh_lidar = copy.copy(lidar)
    mesh_lidar.p = lidar.p.model_copy(update={"terrain_hits": "mesh"})
    mesh_lidar.buffers = CastBuffers(lidar.buffers.n)
    mesh = mesh_lidar.sample(world, 0.0, 0)
    both = (exact.status == RETURN) & (mesh.status == RETURN)
    err = np.abs(mesh.range[both].astype(float) - exact.range[both])
    tl = interleaved({"raw": lambda: raw_cast(raw, o32, d32, far, False),
                      "raw_threads": lambda: raw_cast(raw, o32, d32, far, True),
                      "pipeline": lambda: lidar.sample(world, 0.0, 0),
                      "mesh": lambda: mesh_lidar.sample(world, 0.0, 0),
                      "frame": lambda: lidar.sample(fresh(world), 0.0, 0),
                      "mesh_frame": lambda: mesh_lidar.sample(fresh(world), 0.0, 0)}, repeats)

    # the stereo pair: both eyes' rays raw, against both renders
    Rl, pl = stereo.pose(world)
    Rr, pr = stereo.pose(world, (stereo.p.baseline, 0.0, 0.0))
    eyes = [world_rays(Rc, pc, stereo._o, stereo._d, stereo.p.near) for Rc, pc in ((Rl, pl), (Rr, pr))]
    farc = np.full(len(stereo._o), stereo.p.max_range, np.float32)
    n_cam = 2 * len(stereo._o)

    mesh_stereo = copy.copy(stereo)             # terrain_hits: mesh, its own buffers
    mesh_stereo.p = stereo.p.model_copy(update={"terrain_hits": "mesh"})
    mesh_stereo._buffers = CastBuffers(stereo._buffers.n)

    def render(w, cam=stereo):
        cam.render(w, Rl, pl, 0.0, 0, "left")
        cam.render(w, Rr, pr, 0.0, 0, "right")

    render(world)
    render(world, mesh_stereo)
    tc = interleaved({"raw": lambda: [raw_cast(raw, a, b, farc, False) for a, b in eyes],
                      "raw_threads": lambda: [raw_cast(raw, a, b, farc, True) for a, b in eyes],
                      "pipeline": lambda: render(world),
                      "mesh": lambda: render(world, mesh_stereo),
                      "frame": lambda: render(fresh(world)),
                      "mesh_frame": lambda: render(fresh(world), mesh_stereo)}, repeats)
    t0 = time.perf_counter()
    RobotScenes(world.robot.surfaces)
    t_build = time.perf_counter() - t0
    n_l = len(o32)
    return {
        "scene": SCENES[scene], "threads": THREADS,
        "terrain_faces": int(len(world.terrain.surfaces.faces)), "robot_faces": int(len(world.robot.surfaces.faces)),
        "lidar_rays": n_l, "camera_rays": n_cam,
        "lidar_raw_rays_per_s": n_l / tl["raw"], "lidar_raw_threads_rays_per_s": n_l / tl["raw_threads"],
        "lidar_pipeline_rays_per_s": n_l / tl["pipeline"],
        "lidar_efficiency": tl["raw"] / tl["pipeline"], "lidar_efficiency_threads": tl["raw_threads"] / tl["pipeline"],
        "lidar_frame_s": tl["frame"],
        "lidar_mesh_raw_rays_per_s": n_l / tl["raw"], "lidar_mesh_raw_threads_rays_per_s": n_l / tl["raw_threads"],
        "lidar_mesh_pipeline_rays_per_s": n_l / tl["mesh"],
        "lidar_mesh_efficiency": tl["raw"] / tl["mesh"],
        "lidar_mesh_efficiency_threads": tl["raw_threads"] / tl["mesh"],
        "lidar_mesh_frame_s": tl["mesh_frame"],
        "mesh_range_error_max_m": float(err.max(initial=0.0)),
        "mesh_range_error_rms_m": float(np.sqrt(np.mean(err ** 2))) if err.size else 0.0,
        "mesh_range_error_p99_m": float(np.percentile(err, 99)) if err.size else 0.0,
        "mesh_returns_compared": int(both.sum()), "mesh_status_changed": int(np.sum(exact.status != mesh.status)),
        "camera_raw_rays_per_s": n_cam / tc["raw"], "camera_raw_threads_rays_per_s": n_cam / tc["raw_threads"],
        "camera_pipeline_rays_per_s": n_cam / tc["pipeline"],
        "camera_efficiency": tc["raw"] / tc["pipeline"], "camera_efficiency_threads": tc["raw_threads"] / tc["pipeline"],
        "stereo_frame_s": tc["frame"],
        "camera_mesh_raw_rays_per_s": n_cam / tc["raw"],
        "camera_mesh_raw_threads_rays_per_s": n_cam / tc["raw_threads"],
        "camera_mesh_pipeline_rays_per_s": n_cam / tc["mesh"],
        "camera_mesh_efficiency": tc["raw"] / tc["mesh"],
        "camera_mesh_efficiency_threads": tc["raw_threads"] / tc["mesh"],
        "stereo_mesh_frame_s": tc["mesh_frame"],
        "robot_scenes_build_s": t_build,
    }


def _lidar_world(terrain, position):
    """The sensor_scene's world on ``terrain`` (no robot visible) and a spinning-64 lidar's world rays
    from ``position``, its frame the world's."""
    from snakesim.components.multibody.robot_model import RobotModel
    from snakesim.components.perception.beam_patterns import PRESETS
    from snakesim.framework import Harness

    robot = RobotModel.load(design="eels-1.0")
    h = Harness(SensorScene, {"robot_visible": False, "extent": 8.0}, uses={"robot": robot})
    h.inputs.terrain = terrain
    poses = np.zeros((robot.nl, 7))
    poses[:, 6] = 1.0
    h.inputs.link_poses = poses
    d = PRESETS["spinning-64"]["beams"].beams().directions
    return h.outputs()["world"], np.broadcast_to(np.asarray(position, dtype=float), d.shape).copy(), d


def _errors(world, o, d, reference, repeats: int = 0, keep=None):
    """Per mode, the range error against ``reference`` (n,) m over rays both hit (and ``keep`` (n,)
    bool, if given), and the cast's time."""
    out = {}
    for mode in ("exact", "mesh"):
        cast = (lambda: world.cast_from(np.eye(3), np.zeros(3), o, d, 20.0, exact=mode == "exact")[0].distance.copy())
        t = cast()
        both = np.isfinite(t) & np.isfinite(reference) & (True if keep is None else keep)
        err = np.abs(t[both] - reference[both])
        out[mode] = {"max_m": float(err.max(initial=0.0)), "rms_m": float(np.sqrt(np.mean(err ** 2))),
                     "rays": int(both.sum()), "distance": t}
        if repeats:
            out[mode]["rays_per_s"] = len(o) / best(cast, repeats)
    return out


def accuracy(repeats: int) -> dict:
    from snakesim.components.terrain.spec import load_terrain

    # the tube: reference from the ray-cylinder quadratic (axis x): |o⊥ + t d⊥| = R
    radius = 0.3
    tube = load_terrain({"kind": "tube", "radius": radius, "axis": (1.0, 0.0, 0.0)})
    world, o, d = _lidar_world(tube, (0.0, 0.05, 0.0))
    a, b, c = (d[:, 1:] ** 2).sum(1), (o[:, 1:] * d[:, 1:]).sum(1), (o[:, 1:] ** 2).sum(1) - radius ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        ref = (-b + np.sqrt(b * b - a * c)) / a                   # from inside: the positive root
    surf = world.terrain.surfaces
    tri = surf.vertices[surf.faces]
    tri = tri[np.abs(tri[:, :, 0].mean(axis=1)) < 0.2]            # one ring: every ring is alike
    w = np.array([(i, j, 20 - i - j) for i in range(21) for j in range(21 - i)]) / 20.0
    sag = float(np.abs(tube.query((w @ tri).reshape(-1, 3)).distance).max())
    tube_err = _errors(world, o, d, np.where(ref <= 20.0, ref, np.inf))
    hit = np.isfinite(tube_err["mesh"]["distance"]) & (ref <= 20.0)
    p = o[hit] + ref[hit, None] * d[hit]
    sin = np.abs((p[:, 1:] / radius * d[hit, 1:]).sum(1))        # |n·d|, n radial
    ratio = float((np.abs(tube_err["mesh"]["distance"][hit] - ref[hit]) / (sag / sin)).max())

    # the fractal DEM: the first sign change of z_ray − h (the contact's height), bisected
    dem = load_terrain("terrains/fractal-dem.yaml")
    centre = np.array([0.0, 0.0, float(dem.height(0.0, 0.0)[0]) + 0.2])
    world_d, o_d, d_d = _lidar_world(dem, centre)
    below = (d_d[:, 2] < 0) & (np.arange(len(d_d)) % 16 == 0)   # every 16th beam that can meet the ground
    lo_xy, hi_xy = dem.bounds().lo[:2], dem.bounds().hi[:2]
    step, reach = 5e-4, float(np.hypot(*(hi_xy - lo_xy)))         # 0.5 mm over the grid's diagonal
    ref_d = np.full(len(d_d), np.inf)
    for part in np.array_split(np.flatnonzero(below), 64):
        s = np.arange(0.0, reach, step)
        q = o_d[part, None] + s[None, :, None] * d_d[part, None]
        g = q[..., 2] - dem.height(q[..., 0], q[..., 1])[0]
        inside = np.all((q[..., :2] >= lo_xy) & (q[..., :2] <= hi_xy), axis=-1)     # the grid (the mesh's)
        neg = (g < 0) & inside
        k = np.where(neg.any(1), neg.argmax(1), -1)
        ok = k > 0
        lo, hi = s[k[ok] - 1], s[k[ok]]
        oo, dd = o_d[part[ok]], d_d[part[ok]]
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            m = oo + mid[:, None] * dd
            up = m[:, 2] - dem.height(m[:, 0], m[:, 1])[0] > 0
            lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
        ref_d[part[ok]] = 0.5 * (lo + hi)
    # exact hits left on the mesh: no crossing within refine_limit past it (a triangle bulging above a
    # grazing beam's path over the bilinear surface): counted apart, left out of the errors
    t = world_d.cast(o_d, d_d, 20.0).distance
    hit = np.isfinite(t)
    p = o_d + np.where(hit, t, 0.0)[:, None] * d_d
    on = np.abs(p[:, 2] - dem.height(p[:, 0], p[:, 1])[0]) <= 1e-9
    kept = int(np.sum(hit & ~on))
    dem_err = _errors(world_d, o_d, d_d, ref_d, repeats, keep=on)
    for e in (tube_err, dem_err):
        for m in e.values():
            m.pop("distance")
    return {"tube": {"radius_m": radius, "sag_m": sag, "mesh_error_over_sag_per_sin": ratio, **tube_err},
            "dem": {"terrain": "terrains/fractal-dem.yaml", "rays": len(o_d), "hits": int(hit.sum()),
                    "exact_hits_left_on_the_mesh": kept, **dem_err}}


def rtf(duration: float, repeats: int) -> dict:
    reg = default_registry()

    def session(sensors: bool, ray_caster: str = "raster", robot_geometry: str = "visual") -> Session:
        r = resolve(DEFAULT, search_path=reg.assembly_paths(), sim_overrides={"duration": duration})
        if sensors:
            attach_lidar(r, "spinning-64", reg, rate=RTF_LIDAR_RATE)
            attach_stereo(r, "640x480", reg, rate=RTF_STEREO_RATE)
            r.components["sensors"].params.update(ray_caster=ray_caster, robot_geometry=robot_geometry)
        return Session(r, reg)

    # on: what `snakesim run --lidar spinning-64 --stereo 640x480 --stereo-rate 10` builds (ray_caster
    # raster: the stereo pair rasterised); on_embree: the same cast by Embree alone (before raster)
    runs = {"off": session(False), "on": session(True), "on_embree": session(True, "embree"),
            "on_collision": session(True, robot_geometry="collision")}
    for s in runs.values():
        s.run()                                         # warm-up: JIT, caches, first-run opening
    walls = {k: [] for k in runs}
    for _ in range(repeats):
        for key, s in runs.items():
            t0 = time.perf_counter()
            s.run()
            walls[key].append(time.perf_counter() - t0)
    w = {k: min(v) for k, v in walls.items()}
    return {"scene": DEFAULT, "sim_time_s": duration, **{f"wall_{k}_s": v for k, v in w.items()},
            **{f"rtf_{k}": duration / v for k, v in w.items()}, "ratio_on_off": w["on"] / w["off"],
            "sensors": f"lidar spinning-64 (64x1024) at {RTF_LIDAR_RATE:g} Hz, "
                       f"stereo 640x480 at {RTF_STEREO_RATE:g} Hz"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--duration", type=float, default=2.0, help="simulated s per real-time-factor run")
    ap.add_argument("--json", dest="json_path")
    ap.add_argument("--only", choices=("rays", "accuracy", "rtf"), help="one part (default: all)")
    a = ap.parse_args(argv)
    results = [rays(name, a.repeats) for name in SCENES] if a.only in (None, "rays") else []
    print(f"{'scene':>28} {'sensor':>8} {'rays':>8} {'raw Mray/s':>10} {f'raw x{THREADS}':>8} {'pipe Mray/s':>11} "
          f"{'pipe/raw':>8} {f'pipe/raw x{THREADS}':>13} {'frame ms':>9}")
    for r in results:
        for key, name, n, frame in (("lidar", "lidar", "lidar_rays", "lidar_frame_s"),
                                    ("lidar_mesh", "li. mesh", "lidar_rays", "lidar_mesh_frame_s"),
                                    ("camera", "stereo", "camera_rays", "stereo_frame_s"),
                                    ("camera_mesh", "st. mesh", "camera_rays", "stereo_mesh_frame_s")):
            print(f"{r['scene'] if key == 'lidar' else '':>28} {name:>8} {r[n]:8d} {r[key + '_raw_rays_per_s'] / 1e6:10.2f} "
                  f"{r[key + '_raw_threads_rays_per_s'] / 1e6:8.2f} {r[key + '_pipeline_rays_per_s'] / 1e6:11.2f} "
                  f"{r[key + '_efficiency']:8.2f} {r[key + '_efficiency_threads']:13.2f} {1e3 * r[frame]:9.1f}")
        print(f"{'':>28} lidar terrain_hits mesh vs exact: range error max {1e3 * r['mesh_range_error_max_m']:.2f} mm, "
              f"rms {1e3 * r['mesh_range_error_rms_m']:.3f} mm, p99 {1e3 * r['mesh_range_error_p99_m']:.3f} mm "
              f"({r['mesh_returns_compared']} returns in both); {r['mesh_status_changed']} beams change status")
        print(f"{'':>28} robot: {r['robot_faces']} faces in per-link scenes built once "
              f"({1e3 * r['robot_scenes_build_s']:.0f} ms); terrain {r['terrain_faces']} faces")
    print(f"target: pipeline/raw >= 0.7; raw = one embreex run() call, raw x{THREADS} = the rays split in {THREADS} "
          "threads as the pipeline splits them; frame = pipeline with the instant's link spheres computed")
    acc = accuracy(a.repeats) if a.only in (None, "accuracy") else {}
    if acc:
        tb, dm = acc["tube"], acc["dem"]
        print("\nrange error against the reference (spinning-64; rays both hit; DEM: every 16th beam), "
              "max / rms mm:")
        print(f"{'terrain':>28} {'exact':>16} {'mesh':>16}")
        for name, e in ((f"tube r {tb['radius_m']:g} m (sag {1e3 * tb['sag_m']:.2f} mm)", tb),
                        ("fractal DEM", dm)):
            print(f"{name:>28} " + " ".join(f"{1e3 * e[m]['max_m']:7.3g} / {1e3 * e[m]['rms_m']:<6.2g}"
                                             for m in ("exact", "mesh")))
        print(f"{'':>28} tube mesh: worst error / (sag / sin θ) = {tb['mesh_error_over_sag_per_sin']:.4f}")
        print(f"{'':>28} DEM cast {dm['rays']} rays: exact {dm['exact']['rays_per_s'] / 1e6:.2f} Mray/s, "
              f"mesh {dm['mesh']['rays_per_s'] / 1e6:.2f} Mray/s; {dm['exact_hits_left_on_the_mesh']} of "
              f"{dm['hits']} exact hits left on the mesh (no crossing within refine_limit past it; not in the table)")
    t = rtf(a.duration, a.repeats) if a.only in (None, "rtf") else {}
    if t:
        print(f"\n{t['scene']}, {t['sim_time_s']:g} s, best of {a.repeats} (alternating): sensors off "
              f"{t['rtf_off']:.2f}x real time; on ({t['sensors']}) {t['rtf_on']:.2f}x (ray_caster raster), "
              f"{t['rtf_on_embree']:.2f}x (embree), {t['rtf_on_collision']:.2f}x (raster, robot's collision shapes); "
              f"wall ratio on/off {t['ratio_on_off']:.2f} (goal: on >= 5x)")
    if a.json_path:
        with open(a.json_path, "w") as f:
            json.dump({"machine": platform.platform(), "python": sys.version.split()[0], "rays": results,
                       "accuracy": acc, "rtf": t},
                      f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
