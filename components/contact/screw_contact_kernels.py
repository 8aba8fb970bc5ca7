"""numba kernels of the screw–SDF contact (screw_sdf.py) that every terrain path ends with: the forces on
the queried samples reduced to link wrenches (contact_wrenches), the argument records the steps take,
and the end of an evaluation (outputs and counters: finish_evaluation).

Frames: link_poses rows are [x, y, z, qx, qy, qz, qw] (world), link_velocities rows
[v of the link origin, ω] (world axes), as the multibody outputs them. Sample
quantities in the body frame B (the screw's parent link): points_B, ringc_B (centre of
the sample's ring, on the axis), radial_B; per screw axis_B and mount_p (screw centre).

Material table ``mats`` (nm, 5): columns k N/m, c N·s/m, μ, ev_a, ev_b 1/N (materials.py); row = the
terrain's material index of the sample.
"""

from __future__ import annotations

import math

from numba import njit

from ..kernel_args import record
from ..multibody.pose_quaternions import pose_rotation
from .evaluation_kernels import count_evaluation
from .contact_law import add_slip, begin_law, finish_law, law_locals, material_law
from .kernels_numba import add_wrench, point_contact_force
from .point_kernels import world_axis


@njit(cache=True)
def contact_wrenches(samples, work, ports, mats, near, m):
    """Forces on the first m samples (work's rows: distance, normal, material, sample, owner queried) and their
    wrenches about each screw link's origin o_S; ``samples``, ``work``, ``ports`` are the records below
    (Samples, SdfWork, SdfPorts), ``mats`` the terrain's material table.

    A sample in contact (φ < 0) gives the depth d = −φ and the terrain normal n̂. The
    screw's envelope is a surface of revolution, so the force acts where the envelope
    faces the terrain in the sample's ring: ê_c = unit(−n̂ + (n̂·â)â) (the sample's own
    radial if n̂ ∥ â), p_c = c_ring + r ê_c. There

        v    = v_B + ω_B × (p_c − o_B) + ω_s r â × ê_c        (spin slides along the surface:
                                                              no normal component, magnitude ω_s r)
        ê_v  = cos λ â − h sin λ (â × ê_c)                   (normal to the thread line)
        F_n  = max(0, k d − c v·n̂);  F_t by eq. 6 (kernels.py)

    so the sampling sets only where and how deep the contact is, never a spurious
    normal velocity or spin torque from a sample that lies off the envelope's lowest line.
    k, c, μ, ‖e_v‖ come from the material row through the contact law record ``law`` (contact_law.py: its
    per-screw μ and ‖e_v‖ scales; begin_law checks its inputs and adds its sinkage to the first m distances
    here, first; its slip outputs are written here). Wrench [f, (p_c − o_S) × f] into ports.wrenches[screw_row[s]]
    (zeroed first). Writes work.point (p_c), work.vel, work.force, work.fn for samples in contact, and p_c and v (no
    force) for samples within ``near`` of the surface (the implicit step's look-ahead:
    jacobian_kernels.contact_jacobian_blocks); zeros elsewhere. Returns the number of samples in contact.
    """
    # the records' arrays into locals, once (contact_law.py: a field read in the loop costs a reference count)
    distance, normal, material, sample, owner = work.distance, work.normal, work.material, work.sample, work.owner
    R, out_point, out_vel, out_force, out_fn = work.R, work.point, work.vel, work.force, work.fn
    poses, vels, joint_v, law = ports.poses, ports.vels, ports.joint_v, ports.law
    out_wrench, out_screw_fn = ports.wrenches, ports.screw_fn
    ringc_B, radial_B, axis_B, parent_row = samples.ringc_B, samples.radial_B, samples.axis_B, samples.parent_row
    screw_row, radius, lead_angle, hand = samples.screw_row, samples.radius, samples.lead_angle, samples.hand
    spin_dof, spin_mult = samples.spin_dof, samples.spin_mult
    out_wrench[:, :] = 0.0
    out_screw_fn[:] = 0.0
    begin_law(law, m, distance, owner)
    mu_scale, ev_scale, power, speed, row_fn, v_eps, mode, ev_floor = law_locals(law)
    n_contact = 0
    last = -1                  # rows come grouped by screw: its rotation, axis and thread once per screw
    b = 0
    ax = ay = az = cl = sl = 0.0
    for i in range(m):
        d = -distance[i]
        if not d > -near:
            out_fn[i] = 0.0
            for j in range(3):
                out_force[i, j] = 0.0
                out_vel[i, j] = 0.0
                out_point[i, j] = 0.0
            continue
        s = owner[i]
        q = sample[i]
        if s != last:
            last = s
            b = parent_row[s]
            pose_rotation(poses, b, R)
            ax, ay, az = world_axis(R, axis_B, s)
            cl, sl = math.cos(lead_angle[s]), hand[s] * math.sin(lead_angle[s])
        nx, ny, nz = normal[i, 0], normal[i, 1], normal[i, 2]
        na = nx * ax + ny * ay + nz * az
        ux, uy, uz = -(nx - na * ax), -(ny - na * ay), -(nz - na * az)
        un = math.sqrt(ux * ux + uy * uy + uz * uz)
        if un > 1e-9:
            ux, uy, uz = ux / un, uy / un, uz / un
        else:                                           # terrain normal along the axis: a screw end
            ux = R[0, 0] * radial_B[q, 0] + R[0, 1] * radial_B[q, 1] + R[0, 2] * radial_B[q, 2]
            uy = R[1, 0] * radial_B[q, 0] + R[1, 1] * radial_B[q, 1] + R[1, 2] * radial_B[q, 2]
            uz = R[2, 0] * radial_B[q, 0] + R[2, 1] * radial_B[q, 1] + R[2, 2] * radial_B[q, 2]
        r = radius[s]
        # contact point p_c, relative to the body origin
        rx = R[0, 0] * ringc_B[q, 0] + R[0, 1] * ringc_B[q, 1] + R[0, 2] * ringc_B[q, 2] + r * ux
        ry = R[1, 0] * ringc_B[q, 0] + R[1, 1] * ringc_B[q, 1] + R[1, 2] * ringc_B[q, 2] + r * uy
        rz = R[2, 0] * ringc_B[q, 0] + R[2, 1] * ringc_B[q, 1] + R[2, 2] * ringc_B[q, 2] + r * uz
        px, py, pz = poses[b, 0] + rx, poses[b, 1] + ry, poses[b, 2] + rz
        # â × ê_c: the circumferential direction at p_c
        cx, cy, cz = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux
        wr = spin_mult[s] * joint_v[spin_dof[s]] * r
        wx, wy, wz = vels[b, 3], vels[b, 4], vels[b, 5]
        vx = vels[b, 0] + (wy * rz - wz * ry) + wr * cx
        vy = vels[b, 1] + (wz * rx - wx * rz) + wr * cy
        vz = vels[b, 2] + (wx * ry - wy * rx) + wr * cz
        out_point[i, 0], out_point[i, 1], out_point[i, 2] = px, py, pz
        out_vel[i, 0], out_vel[i, 1], out_vel[i, 2] = vx, vy, vz
        if not d > 0.0:                                 # near, not touching: no force
            out_fn[i] = 0.0
            out_force[i, 0], out_force[i, 1], out_force[i, 2] = 0.0, 0.0, 0.0
            continue
        n_contact += 1
        k, cd, mu, ev_a, ev_b = material_law(mats, material[i], mu_scale[s], ev_scale[s])
        # ê_v: normal to the thread line at p_c (lead angle, hand; cl, sl above), projected in the kernel
        fn, fx, fy, fz = point_contact_force(
            d, nx, ny, nz, vx, vy, vz, cl * ax - sl * cx, cl * ay - sl * cy, cl * az - sl * cz,
            k, cd, mu, ev_a, ev_b, v_eps, mode, ev_floor)
        out_fn[i] = fn
        out_force[i, 0], out_force[i, 1], out_force[i, 2] = fx, fy, fz
        out_screw_fn[s] += fn
        add_slip(power, speed, row_fn, s, fn, fx, fy, fz, nx, ny, nz, vx, vy, vz)
        o = screw_row[s]
        add_wrench(out_wrench, o, px - poses[o, 0], py - poses[o, 1], pz - poses[o, 2], fx, fy, fz)
    finish_law(law)
    return n_contact


# -- the component's kernels, on argument records (kernel_args.py) ----------------------------------
#   samples  Samples        the sample tables and contact parameters (built once per component)
#   work     SdfWork        this run's per-sample scratch, the counters and what the last evaluation saw
#   ports    SdfPorts       this run's input views and output buffers (or scratch outputs), and the contact
#                           law record (contact_law.py) on the same inputs and outputs
#   surface  Surface        per terrain object: the material table and, for a plane, its origin,
#                           normal and material
# work.counts: [evaluations, screws tested, samples queried, active screws, samples m of the last
# evaluation]; the generic path (Terrain.query in Python) sets the active screws and m there.

Samples = record("Samples", ("broad_phase", "sphere_r", "start", "points_B", "mount_p", "ringc_B", "radial_B",
                             "axis_B", "parent_row", "screw_row", "radius", "lead_angle", "hand", "spin_dof",
                             "spin_mult", "ring_start", "ring_first", "cos_sep", "near", "lookahead_time"))
SdfWork = record("SdfWork", ("active", "centres", "points", "distance", "normal", "material", "sample", "owner", "R",
                             "point", "vel", "force", "fn", "counts", "track", "seen_poses", "seen_vels",
                             "seen_joint_v", "ring_row", "ring_dir", "ext_points", "ext_row", "ext_distance",
                             "ext_normal", "ext_material"))
SdfPorts = record("SdfPorts", ("poses", "vels", "joint_v", "wrenches", "screw_fn", "normal_force", "contacts", "law"))
Surface = record("Surface", ("origin", "n", "region_material", "mats"))


@njit(cache=True)
def finish_evaluation(work, ports, n_active, m, n_contact):
    """The end of every evaluation (evaluation_kernels.count_evaluation), the spin rates seen included."""
    count_evaluation(work, ports, n_active, m, n_contact, ports.screw_fn)
    if work.track:
        work.seen_joint_v[:] = ports.joint_v
