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
rtf       the default scene (surface-screw-traverse, its dt and integrator) with a 64x1024 lidar
          at 10 Hz and a 640x480 stereo pair at 5 Hz (``--lidar spinning-64 --stereo 640x480``),
          the same with the sensors seeing the robot's collision shapes (``robot_geometry:
          collision``: screw envelopes instead of blades), and without, alternately in this
          process, best of ``--repeats`` after a warm-up; the ratio (goal: the sensors on at
          >= 1x real time on this 2-core machine).

    python bench/perception.py [--repeats 3] [--duration 2] [--only rays|rtf] [--json FILE]
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


def rtf(duration: float, repeats: int) -> dict:
    reg = default_registry()

    def session(sensors: bool, robot_geometry: str = "visual") -> Session:
        r = resolve(DEFAULT, search_path=reg.assembly_paths(), sim_overrides={"duration": duration})
        if sensors:
            attach_lidar(r, "spinning-64", reg)
            attach_stereo(r, "640x480", reg)
            r.components["sensors"].params["robot_geometry"] = robot_geometry
        return Session(r, reg)

    runs = {"off": session(False), "on": session(True), "on_collision": session(True, "collision")}
    for s in runs.values():
        s.run()                                         # warm-up: JIT, caches, first-run opening
    walls = {k: [] for k in runs}
    for _ in range(repeats):
        for key, s in runs.items():
            t0 = time.perf_counter()
            s.run()
            walls[key].append(time.perf_counter() - t0)
    w = {k: min(v) for k, v in walls.items()}
    return {"scene": DEFAULT, "sim_time_s": duration, "wall_on_s": w["on"], "wall_off_s": w["off"],
            "wall_on_collision_s": w["on_collision"], "rtf_on": duration / w["on"], "rtf_off": duration / w["off"],
            "rtf_on_collision": duration / w["on_collision"], "ratio_on_off": w["on"] / w["off"],
            "sensors": "lidar spinning-64 (64x1024) at 10 Hz, stereo 640x480 at 5 Hz"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--duration", type=float, default=2.0, help="simulated s per real-time-factor run")
    ap.add_argument("--json", dest="json_path")
    ap.add_argument("--only", choices=("rays", "rtf"), help="one part (default: both)")
    a = ap.parse_args(argv)
    results = [rays(name, a.repeats) for name in SCENES] if a.only != "rtf" else []
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
    t = rtf(a.duration, a.repeats) if a.only != "rays" else {}
    if t:
        print(f"\n{t['scene']}, {t['sim_time_s']:g} s, best of {a.repeats}: sensors off {t['rtf_off']:.3f}x real time, "
              f"on {t['rtf_on']:.3f}x ({t['sensors']}), on seeing the robot's collision shapes "
              f"{t['rtf_on_collision']:.3f}x; wall ratio on/off {t['ratio_on_off']:.2f} (goal: on >= 1x)")
    if a.json_path:
        with open(a.json_path, "w") as f:
            json.dump({"machine": platform.platform(), "python": sys.version.split()[0], "rays": results, "rtf": t},
                      f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
