"""numba kernels of the body contact step (body_contact.py): per-piece broad phase, sample
kinematics, forces reduced to link wrenches. All write into preallocated arrays.

Frames as in screw_contact_kernels.py: link_poses rows [x, y, z, qx, qy, qz, qw] (world),
link_velocities rows [v of the link origin, ω] (world axes); sample tables in the link
frame. The sample placement (sample_points), the plane query and broad phase (plane_query,
plane_broad_phase) and the one contact law (kernels_numba.point_contact_force) are the screw
back end's, imported; only the force loop is body-specific.

Material table ``mats`` (nm, 5): columns k, c, μ, ev_a, ev_b (materials.py); bodies read
k, c and μ (ev_a, ev_b describe screw threads), through the contact law record (contact_law.skin_law). Per piece: ``mu_scale`` (μ_across / μ of
the material) and ``skin_ratio`` (μ_along / μ_across), which eq. 6 takes as ‖e_v‖ with
ê_v the skin axis: friction −F_n μ (s + (‖e_v‖ − 1)(s·ê)ê) is μ_along along the axis
and μ_across across it.
"""

from __future__ import annotations

from numba import njit

from ..kernel_args import record
from ..kernel_reductions import same_bits
from .contact_law import add_slip, begin_law, finish_law, law_locals, skin_law
from .jacobian_kernels import body_jacobian_blocks
from .kernels_numba import add_wrench, point_contact_force
from ..multibody.pose_quaternions import pose_rotation
from .evaluation_kernels import count_evaluation
from .plane_kernels import plane_broad_phase, plane_query
from .point_kernels import link_fixed_points, sample_points, world_axis


@njit(cache=True)
def body_contact_wrenches(table, work, ports, mats, m):
    """Forces on the first m samples (work's rows: world points in work.points, distance, normal, material
    queried) and their wrenches about each link's origin, on the records below (BodyTable, BodyWork,
    BodyPorts; ``mats`` the terrain's material table). A sample with φ < 0 is a contact of depth d = −φ,
    terrain normal n̂; its velocity v = v_l + ω_l × (p − o_l); F_n = max(0, k d − c v·n̂) (eq. 2); friction by eq. 6 with ê_v the skin
    axis (R_l axis_B), μ = μ_material · mu_scale, ‖e_v‖ = skin_ratio, each scaled by the contact law
    record ``law`` (contact_law.skin_law; its rows are links; begin_law checks it and adds its sinkage to
    the distances here, first; its slip outputs are written here). Wrench [f, (p − o_l) × f] into ports.wrenches[l]
    (zeroed first); work.vel, work.force, work.fn per sample, ports.link_fn per link. Returns the number of samples
    in contact."""
    # the records' arrays into locals, once (contact_law.py: a field read in the loop costs a reference count)
    distance, normal, material, sample, owner = work.distance, work.normal, work.material, work.sample, work.owner
    R, out_point, out_vel, out_force, out_fn = work.R, work.points, work.vel, work.force, work.fn
    poses, vels, law, out_wrench, out_link_fn = ports.poses, ports.vels, ports.law, ports.wrenches, ports.link_fn
    piece_link, axis_B, mu_scale, skin_ratio = table.piece_link, table.axis_B, table.mu_scale, table.skin_ratio
    out_wrench[:, :] = 0.0
    out_link_fn[:] = 0.0
    begin_law(law, m, distance, owner)
    law_mu, law_ev, power, speed, row_fn, v_eps, mode, ev_floor = law_locals(law)
    n_contact = 0
    for i in range(m):
        d = -distance[i]
        if not d > 0.0:
            out_fn[i] = 0.0
            for j in range(3):
                out_force[i, j] = 0.0
                out_vel[i, j] = 0.0
            continue
        n_contact += 1
        k = owner[i]
        q = sample[i]
        b = piece_link[k]
        pose_rotation(poses, b, R)
        rx, ry, rz = out_point[i, 0] - poses[b, 0], out_point[i, 1] - poses[b, 1], out_point[i, 2] - poses[b, 2]
        wx, wy, wz = vels[b, 3], vels[b, 4], vels[b, 5]
        vx = vels[b, 0] + (wy * rz - wz * ry)
        vy = vels[b, 1] + (wz * rx - wx * rz)
        vz = vels[b, 2] + (wx * ry - wy * rx)
        out_vel[i, 0], out_vel[i, 1], out_vel[i, 2] = vx, vy, vz
        ax, ay, az = world_axis(R, axis_B, q)
        kk, c, mu, ev_a, ev_b = skin_law(mats, material[i], mu_scale[k], skin_ratio[k], law_mu[b], law_ev[b])
        nx, ny, nz = normal[i, 0], normal[i, 1], normal[i, 2]
        fn, fx, fy, fz = point_contact_force(d, nx, ny, nz, vx, vy, vz, ax, ay, az, kk, c, mu, ev_a, ev_b, v_eps, mode,
                                             ev_floor)
        out_fn[i] = fn
        out_force[i, 0], out_force[i, 1], out_force[i, 2] = fx, fy, fz
        out_link_fn[b] += fn
        add_slip(power, speed, row_fn, b, fn, fx, fy, fz, nx, ny, nz, vx, vy, vz)
        add_wrench(out_wrench, b, rx, ry, rz, fx, fy, fz)
    finish_law(law)
    return n_contact


# -- the component's kernels, on argument records (kernel_args.py) ----------------------------------
#   table    BodyTable   the sample tables and friction parameters (built once per component)
#   work     BodyWork    this run's per-sample scratch and counters, and what the last evaluation saw
#   ports    BodyPorts   this run's input views and output buffers (or scratch outputs)
#   surface  screw_contact_kernels.Surface   per terrain object: material table; a plane's origin, normal, material
# work.counts: [evaluations, pieces tested, samples queried, active pieces, samples m of the last evaluation]

BodyTable = record("BodyTable", ("broad_phase", "piece_link", "centre_B", "piece_r", "start", "points_B", "axis_B",
                                 "mu_scale", "skin_ratio"))
BodyWork = record("BodyWork", ("active", "centres", "points", "distance", "normal", "material", "sample", "owner", "R",
                               "vel", "force", "fn", "counts", "track", "seen_poses", "seen_vels"))
BodyPorts = record("BodyPorts", ("poses", "vels", "wrenches", "link_fn", "normal_force", "contacts", "law"))


@njit(cache=True)
def body_plane_step(table, work, ports, surface):
    """One whole evaluation against a plane: broad phase, sample points, plane query, forces, outputs."""
    t, w, io, f = table, work, ports, surface
    n_active = plane_broad_phase(t.broad_phase, io.poses, t.piece_link, t.centre_B, t.piece_r, f.origin, f.n, w.R,
                                 w.centres, w.active)
    m = 0
    if n_active:
        m = sample_points(io.poses, w.active, n_active, t.start, t.points_B, t.piece_link, w.R, w.points,
                          w.sample, w.owner)
        plane_query(m, w.points, f.origin, f.n, w.distance, w.normal, w.material)
        for i in range(m):
            w.material[i] = f.region_material
    count_evaluation(w, io, n_active, m, body_contact_wrenches(t, w, io, f.mats, m), io.link_fn)


@njit(cache=True)
def body_centres_step(table, work, ports):
    """Broad phase, generic terrain: every piece's sphere centre into work.centres."""
    link_fixed_points(ports.poses, table.piece_link, table.centre_B, work.R, work.centres)


@njit(cache=True)
def body_sample_step(table, work, ports):
    """World points of the active pieces' samples into work.points; sets and returns m."""
    n_active = work.counts[3]
    m = 0
    if n_active:
        m = sample_points(ports.poses, work.active, n_active, table.start, table.points_B, table.piece_link, work.R,
                          work.points, work.sample, work.owner)
    work.counts[4] = m
    return m


@njit(cache=True)
def body_wrench_step(table, work, ports, surface):
    """Forces and wrenches of the m samples queried (distance, normal, material filled in), outputs."""
    m = work.counts[4]
    count_evaluation(work, ports, work.counts[3], m, body_contact_wrenches(table, work, ports, surface.mats, m),
                     ports.link_fn)


@njit(cache=True)
def body_jacobian_step(table, work, ports, surface, d_twist, d_pose, on_link):
    """jacobian_kernels.body_jacobian_blocks on the last evaluation's contacts (work), from the records.
    Returns the number of links marked."""
    return body_jacobian_blocks(table, work, ports, surface.mats, work.counts[4], d_twist, d_pose, on_link)


@njit(cache=True)
def body_seen_step(work, ports):
    """True if the last evaluation saw exactly these inputs (bit for bit)."""
    return same_bits(work.seen_poses, ports.poses) and same_bits(work.seen_vels, ports.vels)
