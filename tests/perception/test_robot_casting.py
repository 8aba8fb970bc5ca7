"""The robot is cast link by link (each link's static Embree scene, rays moved into its frame,
culled by bounding spheres, direction bins and boxes, in threads, into reused buffers): every
one of those shortcuts must give the hits of one Embree scene of the terrain and the posed
robot in the world, to float32 precision."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from scenes import F32, ROBOT, initial_link_poses, terrain, world_at
from snakesim.components.perception import ray_caster as rc
from snakesim.components.perception.hit_kernels import link_candidates
from snakesim.components.perception.mount import rigid_links
from snakesim.components.perception.ray_caster import CastBuffers, RayBundle, embree_scene

MAX_RANGE = 30.0


def bent_poses(seed=0) -> np.ndarray:
    """The robot's initial link poses with every link turned and shifted at random (a pose no chain
    takes, which is the point: each link's frame differs from the world's)."""
    rng = np.random.default_rng(seed)
    poses = initial_link_poses()
    poses[:, :3] += rng.normal(scale=0.03, size=(len(poses), 3))
    poses[:, 3:] = Rotation.random(len(poses), random_state=rng).as_quat()
    return poses


def reference(world, o, d, lo, hi):
    """One Embree scene of the terrain and the robot posed in the world (what the caster used to
    build every instant): (distance from o, inf on a miss; link row, -1 for terrain)."""
    ter, rob = world.terrain.surfaces, world.robot.surfaces
    posed = rob.posed(world.rotations, world.link_poses[:, :3])
    scene = embree_scene((ter.vertices, ter.faces), (posed, rob.faces))
    start = (o + lo * d).astype(np.float32)
    r = scene.run(start, d.astype(np.float32), dists=np.full(len(o), hi - lo, np.float32), query="INTERSECT", output=1)
    hit = r["geomID"] >= 0
    dist = np.where(hit, r["tfar"].astype(float) + lo, np.inf)
    link = np.where(r["geomID"] == 1, rob.face_link[np.maximum(r["primID"], 0)], -1)
    n = r["Ng"].astype(float)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    n *= -np.sign(np.einsum("ij,ij->i", n, d))[:, None]             # facing the ray, as the caster's
    return dist, np.where(hit, link, -1), n


def sphere_directions(n_el=48, n_az=256):
    el, az = np.meshgrid(np.linspace(-1.4, 1.4, n_el), np.linspace(-np.pi, np.pi, n_az, endpoint=False), indexing="ij")
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1).reshape(-1, 3)


def compare(hits, dist, link, normal, o):
    """Same rays hit, same links, same distances to float32 rounding of coordinates up to |o| + r,
    same normals (float32 cross products of small faces: within a milliradian)."""
    got = hits.distance
    both = np.isfinite(got) & np.isfinite(dist)
    differ = np.isfinite(got) != np.isfinite(dist)
    # a ray grazing a silhouette may round either way in the two frames: a few per 10 000
    assert differ.sum() <= 1e-4 * len(got) + 1, differ.sum()
    scale = np.linalg.norm(o[both], axis=1) + dist[both]
    np.testing.assert_allclose(got[both], dist[both], rtol=0, atol=1e-5)
    assert np.all(np.abs(got[both] - dist[both]) <= 16 * F32 * scale + 1e-6)
    with np.errstate(invalid="ignore"):
        same_surface = both & (np.abs(got - dist) < 1e-4)
    assert np.mean(hits.link[same_surface] == link[same_surface]) > 0.999
    cos = np.einsum("ij,ij->i", hits.normal[same_surface], normal[same_surface])
    assert np.mean(cos > 1 - 5e-7) > 0.999
    return both.sum(), (link[both] >= 0).sum()


@pytest.fixture(scope="module")
def world():
    return world_at(terrain({"kind": "plane", "origin": (0.0, 0.0, -0.3)}), bent_poses(), robot_visible=True)


@pytest.mark.parametrize("threads", [1, 2])
def test_a_lidar_bundle_gives_the_hits_of_one_posed_scene(world, threads, monkeypatch):
    monkeypatch.setattr(rc, "THREADS", threads)
    monkeypatch.setattr(rc, "CAST_CHUNK_MIN", 2048)         # 12k rays: split into chunks on two threads
    monkeypatch.setattr(rc, "CHUNK_MIN", 2048)
    head = world.link_poses[ROBOT.link_index("head"), :3]
    d = sphere_directions()
    rng = np.random.default_rng(1)
    o_s = rng.normal(scale=0.01, size=d.shape)                        # beams from a small ball (ρ > 0)
    R = Rotation.from_rotvec([0.3, -0.2, 1.0]).as_matrix()
    p = head + np.array([-0.3, 0.0, 0.4])
    hits, o_w, d_w = world.cast_from(R, p, o_s, d, MAX_RANGE, 1e-6, RayBundle(o_s, d), CastBuffers(len(d)))
    n_hit, n_robot = compare(hits, *reference(world, o_w, d_w, 1e-6, MAX_RANGE), o_w)
    assert n_robot > 500 and n_hit - n_robot > 1000            # the test sees both the robot and the ground


def test_rays_from_inside_a_links_box_and_sphere(world):
    """A sensor inside a link's bounding sphere and box (every direction can meet it)."""
    row = ROBOT.link_index("module_03")
    R_l, p_l = world.link_pose(row)
    k = int(np.flatnonzero(world.robot.rows == row)[0])
    inside = world.robot.centre[k] + [0.01, 0.003, -0.002]            # link frame: off the mesh's own points
    d = sphere_directions(32, 128)
    o_s = np.zeros_like(d)
    hits, o_w, d_w = world.cast_from(R_l, p_l + R_l @ inside, o_s, d, MAX_RANGE, 0.0, RayBundle(o_s, d))
    _, n_robot = compare(hits, *reference(world, o_w, d_w, 0.0, MAX_RANGE), o_w)
    assert n_robot > 100


def test_any_rays_without_a_bundle(world):
    """Shadow-ray-like casts: origins all over the robot, one direction per ray."""
    rng = np.random.default_rng(2)
    lo_, hi_ = world.link_poses[:, :3].min(axis=0) - 0.2, world.link_poses[:, :3].max(axis=0) + 0.2
    o = rng.uniform(lo_, hi_, size=(20000, 3))
    d = rng.normal(size=o.shape)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    hits = world.cast(o, d, MAX_RANGE, 0.01)
    _, n_robot = compare(hits, *reference(world, o, d, 0.01, MAX_RANGE), o)
    assert n_robot > 1000


def test_bundle_link_rays_hold_every_ray_that_meets_a_links_sphere_and_box(world):
    """The direction bins, cones and box test only leave out rays that cannot meet a link: what
    they keep contains every ray whose segment meets both the link's sphere (the exact segment–
    sphere test) and its box within range, moved into the link's frame as Rᵀ(o − p), Rᵀd, with
    the box entry distance of the slab test."""
    rob = world.robot
    d = sphere_directions(64, 512)
    rng = np.random.default_rng(3)
    o_s = rng.normal(scale=0.002, size=d.shape)            # origin ball ρ ≈ 1 cm
    bundle = RayBundle(o_s, d)
    R = Rotation.from_rotvec([0.1, 0.4, -0.7]).as_matrix()
    # 2 cm off the side of module_05's box: inside its bounding sphere (every direction), outside its box
    row = ROBOT.link_index("module_05")
    k5 = int(np.flatnonzero(rob.rows == row)[0])
    lo5, hi5 = rob.box[k5]
    side = np.array([0.5 * (lo5[0] + hi5[0]), hi5[1] + 0.02, 0.5 * (lo5[2] + hi5[2])])
    R5, p5 = world.link_pose(row)
    p = p5 + R5 @ side
    assert np.linalg.norm(side - rob.centre[k5]) < rob.radius[k5]
    o_w, d_w = p + o_s @ R.T, d @ R.T
    lo = 1e-3
    centres = world.spheres()[0]
    exact_off, exact = link_candidates(o_w, d_w, lo, np.full(len(d), MAX_RANGE - lo, np.float32), centres,
                                       rob.radius, np.array([0, len(rob.rows)]), centres.mean(axis=0, keepdims=True),
                                       np.array([1e9]))
    rows = rob.rows
    links = np.arange(len(rows))[::-1].copy()              # any order: the output follows it
    offsets, count, ids, o_l, d_l, entry = bundle.link_rays(R, p, centres, rob.radius, MAX_RANGE, world.rotations[rows],
                                                            world.link_poses[rows, :3], rob.boxes, links, lo)
    total = 0
    for j, k in enumerate(links):
        Rl, pl = world.link_pose(rows[k])
        s, v = (o_w + lo * d_w - pl) @ Rl, d_w @ Rl                      # link frame
        box_lo, box_hi = rob.box[k]
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (box_lo - s) / v, (box_hi - s) / v
        t0 = np.nanmax(np.where(np.isnan(np.minimum(ta, tb)), -np.inf, np.minimum(ta, tb)), axis=1)
        t1 = np.nanmin(np.where(np.isnan(np.maximum(ta, tb)), np.inf, np.maximum(ta, tb)), axis=1)
        meets = set(np.flatnonzero(np.maximum(t0, 0) <= np.minimum(t1, MAX_RANGE - lo)).tolist())
        meets &= set(exact[exact_off[k]:exact_off[k + 1]].tolist())
        sl = slice(offsets[j], offsets[j] + count[j])
        got = ids[sl]
        assert meets <= set(got.tolist()), (k, len(meets - set(got.tolist())))
        total += len(meets)
        # the kept rays in the link frame, to float32 rounding of the link-frame coordinates
        np.testing.assert_allclose(o_l[sl], s[got], rtol=0, atol=4 * F32 * (1 + np.abs(s[got]).max(initial=0)))
        np.testing.assert_allclose(d_l[sl], v[got], rtol=0, atol=4 * F32)
        np.testing.assert_allclose(entry[sl], np.maximum(t0[got], 0), rtol=1e-6, atol=1e-6)
    assert total > 1000
    # the box culls where the sphere cannot (the sphere holds the origin: every ray)
    assert count[list(links).index(k5)] < 0.6 * len(d)


def test_a_bundle_fixed_to_a_link_takes_its_hits_on_that_link_cast_once(world):
    """A lidar inside its housing link: the housing's hits are cast once in the link frame and
    must be those of one posed scene, whatever the link's pose; posing the bundle anywhere but
    its mount is an error."""
    row = ROBOT.link_index("module_03")
    k = int(np.flatnonzero(world.robot.rows == row)[0])
    R_ls = Rotation.from_rotvec([0.2, -0.1, 0.3]).as_matrix()
    p_ls = world.robot.centre[k] + [0.01, 0.003, -0.002]               # inside the link's box
    d = sphere_directions(32, 128)
    o_s = np.zeros_like(d)
    bundle = RayBundle(o_s, d, mount=(row, R_ls, p_ls))
    for seed in (0, 1):                            # the same bundle at two poses of the robot
        w = world_at(terrain({"kind": "plane", "origin": (0.0, 0.0, -0.3)}), bent_poses(seed), robot_visible=True)
        R_wl, p_wl = w.link_pose(row)
        hits, o_w, d_w = w.cast_from(R_wl @ R_ls, p_wl + R_wl @ p_ls, o_s, d, MAX_RANGE, 1e-6, bundle)
        _, n_robot = compare(hits, *reference(w, o_w, d_w, 1e-6, MAX_RANGE), o_w)
        assert np.count_nonzero(hits.link == row) > 100 and n_robot > 100
    with pytest.raises(ValueError, match="mount pose"):
        w.cast_from(R_wl @ R_ls, p_wl + R_wl @ p_ls + [0.0, 0.0, 0.01], o_s, d, MAX_RANGE, 1e-6, bundle)


def test_links_fixed_to_the_mount_are_cast_once_while_they_stay_in_place():
    """A lidar on its link on the head (the head, its module and cameras fixed to it:
    .mount.rigid_links): their hits are cast once in their frames and taken while each link is where
    the URDF puts it on the mount link, and must be the hits of casting every link at the instant
    (a bundle without ``rigid``: the head and its module meet at coincident faces, where one posed
    scene may report either); a head moved off its place (by 10 µm and 10 µrad, past
    RayBundle.RIGID_TOLERANCE) is cast as any other link, with the same result."""
    row, head = ROBOT.link_index("lidar"), ROBOT.link_index("head")
    rigid = rigid_links(ROBOT, row)
    assert {ROBOT.links[r] for r, _, _ in rigid} >= {"head", "module_09", "camera_left"}
    R_ls, p_ls = np.eye(3), np.zeros(3)
    d = sphere_directions(32, 128)
    o_s = np.zeros_like(d)
    bundle = RayBundle(o_s, d, mount=(row, R_ls, p_ls), rigid=rigid)
    each_instant = RayBundle(o_s, d, mount=(row, R_ls, p_ls))
    ground = terrain({"kind": "plane", "origin": (0.0, 0.0, -0.3)})
    moved = initial_link_poses()
    moved[head, :3] += [1e-5, 0.0, 0.0]
    moved[head, 3:] = (Rotation.from_rotvec([0.0, 0.0, 1e-5]) * Rotation.from_quat(moved[head, 3:])).as_quat()
    for poses, in_place in ((initial_link_poses(), True), (moved, False)):
        w = world_at(ground, poses, robot_visible=True)
        assert (head in bundle.rigid_in_place(w.rotations, w.link_poses[:, :3])) == in_place
        R_wl, p_wl = w.link_pose(row)
        R, p = R_wl @ R_ls, p_wl + R_wl @ p_ls
        hits = {k: v.copy() for k, v in vars(w.cast_from(R, p, o_s, d, MAX_RANGE, 1e-6, bundle)[0]).items()}
        ref = w.cast_from(R, p, o_s, d, MAX_RANGE, 1e-6, each_instant)[0]
        assert np.count_nonzero(ref.link == head) > 100
        np.testing.assert_array_equal(np.isfinite(hits["distance"]), np.isfinite(ref.distance))
        hit = np.isfinite(ref.distance)
        # the rays in a link's frame from the URDF's pose, not the instant's: float32 rounding of them
        np.testing.assert_allclose(hits["distance"][hit], ref.distance[hit], rtol=0, atol=16 * F32)
        np.testing.assert_array_equal(hits["link"], ref.link)
        np.testing.assert_allclose(hits["normal"][hit], ref.normal[hit], rtol=0, atol=1e-6)


def test_terrain_rays_that_cannot_reach_its_bounds_are_left_out_with_the_same_hits(world):
    """``intersect_near`` casts only the rays whose segment up to their far limit reaches the terrain's
    bounds: the same hits, distances and faces as casting them all (rays up and down, far limits from
    a centimetre to past the ground)."""
    rng = np.random.default_rng(3)
    d = sphere_directions(24, 96)
    start = (np.array([0.0, 0.0, 0.05]) + rng.normal(scale=0.02, size=d.shape)).astype(np.float32)
    far = rng.choice([0.01, 0.1, 0.5, 5.0, MAX_RANGE], size=len(d)).astype(np.float32)
    ter = world.terrain
    a_far, b_far = far.copy(), far.copy()
    a = rc._intersect(ter.scene, start, d.astype(np.float32), a_far)
    b = ter.intersect_near(start, d.astype(np.float32), b_far, CastBuffers(len(d)).near())
    hit = a[0] != -1
    assert 100 < hit.sum() < 0.8 * len(d)          # some rays reach the ground, most do not
    np.testing.assert_array_equal(b[0], a[0])
    np.testing.assert_array_equal(b[1][hit], a[1][hit])
    np.testing.assert_array_equal(b[2][hit], a[2][hit])
    np.testing.assert_array_equal(b_far, a_far)


def test_buffers_are_reused_without_leaking_the_previous_cast(world):
    d = sphere_directions(16, 64)
    o_s = np.zeros_like(d)
    head = world.link_poses[ROBOT.link_index("head"), :3]
    buffers = CastBuffers(len(d))
    a = world.cast_from(np.eye(3), head + [0, 0, 0.2], o_s, d, MAX_RANGE, 0.0, None, buffers)[0]
    a = {k: v.copy() for k, v in vars(a).items()}
    b = world.cast_from(np.eye(3), head + [0, 0, 5.0], o_s, d, MAX_RANGE, 0.0, None, buffers)[0]
    fresh_b = world.cast_from(np.eye(3), head + [0, 0, 5.0], o_s, d, MAX_RANGE, 0.0)[0]
    fresh_a = world.cast_from(np.eye(3), head + [0, 0, 0.2], o_s, d, MAX_RANGE, 0.0)[0]
    np.testing.assert_array_equal(b.distance, fresh_b.distance)
    np.testing.assert_array_equal(a["distance"], fresh_a.distance)
    np.testing.assert_array_equal(b.link, fresh_b.link)
    assert not np.array_equal(a["distance"], b.distance)


def _cast_in_child(world, queue):
    d = sphere_directions(64, 512)                       # 32k rays: split over the threads
    queue.put(float(np.nansum(np.where(np.isfinite(h := world.cast(np.zeros_like(d), d, MAX_RANGE).distance), h, 0))))


def test_casts_work_in_a_forked_child(world, monkeypatch):
    """A fork copies the thread pool but not its threads: the child makes its own."""
    import multiprocessing

    monkeypatch.setattr(rc, "THREADS", 2)
    monkeypatch.setattr(rc, "CHUNK_MIN", 4096)
    d = sphere_directions(64, 512)
    here = world.cast(np.zeros_like(d), d, MAX_RANGE).distance               # the parent's pool exists
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_cast_in_child, args=(world, queue))
    child.start()
    child.join(120)
    if child.is_alive():           # hung on the copied pool's missing threads
        child.kill()
    assert child.exitcode == 0
    assert queue.get(timeout=5) == pytest.approx(float(np.sum(here[np.isfinite(here)])), rel=1e-12)
