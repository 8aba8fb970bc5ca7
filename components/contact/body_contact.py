"""Body–terrain contact, SDF back end: samples on every body link's collision shape against the terrain's SDF.

Model (paper §2.2.2, eq. 2; friction as eq. 6 with the skin axis in place of the thread
normal). Each selected link's URDF collision shapes (cylinders, capsules, spheres, boxes;
end caps, the tail and the head included) carry samples ≤ ``spacing`` apart, fixed in the
link (body_samples.py). The design's screw links are left out by default
(``exclude_screws``): ``screw_sdf_contact`` models them with eq. 6, and a scene sums the
two with ``wrench_sum``. A sample p with terrain signed distance φ(p) < 0 is a contact of
depth d = −φ, outward normal n̂ and the terrain material there (k, c, μ):

    slip       v = v_l + ω_l × (p − o_l)                        (world; the link's material point)
    normal     F_n = max(0, k d − c v·n̂)                        (eq. 2, per sample, never pulls)
    friction   F_t = −F_n (μ_along (s·â)â + μ_across (s − (s·â)â))   s = v_t / sqrt(‖v_t‖² + v_ε²)

with â the link's skin axis projected on the tangent plane (a cylinder's axis: snake skin
or scales, wheels or skids), μ_along = μ·along, μ_across = μ·across, the factors of
``friction`` (or of the first ``link_friction`` pattern matching the link). That is eq. 6
(kernels_numba.point_contact_force) with μ → μ·across, ‖e_v‖ → along/across, ê_v → â;
along = across = 1 is isotropic Coulomb friction (eq. 1), regularised in slip like the
screws'. The force acts at p on the link: wrench [f, (p − o_l) × f] about the link origin.

Accuracy: k is per sample, as in both other back ends (a face resting on n samples sinks
F/(n k)); a curved surface rests on its samples' polygon, which lies inside the true
surface by at most the sag r(1 − cos(π/n_around)) (body_samples.py).

Watch (``max_depth``): a sample deeper than max_depth in the terrain ends the run with a
named reason (a bounce from a step too large for k, or a material too soft), never
believable garbage.

Broad phase (``broad_phase``): one bounding sphere per piece (collision element) against
``terrain.distance_lower_bound``; only pieces whose bound is ≤ 0 are sampled and queried.
A plane is queried inside numba in one call.

Jacobian (``port_jacobian``, for rosenbrock_w): per link, Σ over its samples in contact of
X_pᵀ (∂F/∂v) X_p and X_pᵀ (∂F/∂p) X_p about the link origin (X_p = [I, −[p − o_l]×]; ∂F from eq. 2
and the regularised eq. 6 with the skin axis, jacobian_kernels.body_jacobian_blocks), read by the
multibody as the screw contact's are. Left out, as there: the turning of lever arms, normals and
skin axes with the link (tests/contact/test_body_contact_jacobian.py).

Contact law inputs and outputs (contact_law.py), per link: ``link_mu_scale`` (μ × it),
``link_ev_scale`` (along/across × it), ``link_sinkage`` (m, the surface lowered under the link) in,
``link_slip_power`` (W) and ``link_slip_speed`` (m/s, load-weighted) out.

Material: the terrain's per-sample material (materials.Material: k, c, μ; its ev_a, ev_b
describe screw threads and are not read here); any field of ``material`` (MaterialPatch)
overrides it for every terrain material.

uses robot: RobotModel      (the multibody's: links, URDF collision shapes, screw links)
in   link_poses[nl,7]       multibody link_poses (xyz + quaternion xyzw, world)
     link_velocities[nl,6]  multibody link_velocities ([v origin, ω], world)
     terrain                structured Terrain (terrain component)
     link_mu_scale[nl]      1, default 1; link_ev_scale[nl] 1, default 1; link_sinkage[nl] m, default 0
out  wrenches[nl,6]         N, N·m: [f, τ] world, τ about each link origin (multibody.wrenches,
                            directly or through wrench_sum with the screw contact's)
     normal_force[1]        N, Σ F_n over all body samples
     contacts[1]            body samples in contact
     link_normal_force[nl]  N, Σ F_n per link
     link_slip_power[nl]    W, Σ −F_t·v per link;  link_slip_speed[nl] m/s, Σ F_n‖v_t‖ / Σ F_n
     contact_set            ContactSet of the active contacts (computed once per step)
all feedthrough from all inputs. The ports, the terrain switching, the contact set and the depth watch
are every back end's (link_contact.py); the run, its records and the law check the sampled back ends'
(sampled_contact.py).
"""

from __future__ import annotations

import fnmatch

import numpy as np
from pydantic import Field, model_validator

from snakesim.framework import Output, Params
from snakesim.components.multibody.robot_ports import link_shape

from .body_kernels import (BodyPorts, BodyTable, BodyWork, body_centres_step, body_jacobian_step, body_plane_step,
                           body_sample_step, body_seen_step, body_wrench_step)
from .body_samples import BodySampleOptions, body_samples
from .sampled_contact import SampledContact, SampledContactParams, SampledContactRun, SampledKernels, law_ports


class Skin(Params):
    """Body friction factors on the terrain material's μ: along and across the link's skin axis."""

    along: float = Field(1.0, gt=0, description="μ_along / μ (along the link's axis: a snake's belly scales)")
    across: float = Field(1.0, gt=0, description="μ_across / μ (across it)")


class BodyContactParams(SampledContactParams):
    links: list[str] = Field(default_factory=lambda: ["*"], min_length=1,
                             description="link name patterns (fnmatch) that get samples")
    exclude: list[str] = Field(default_factory=list, description="link name patterns left out")
    exclude_screws: bool = Field(True, description="leave out the design's screw links (screw_sdf_contact's)")
    spacing: float = Field(0.03, gt=0, le=1.0, description="m, largest distance between neighbouring samples")
    min_around: int = Field(8, ge=3, description="least samples around a cylinder")
    friction: Skin = Field(default_factory=Skin, description="skin friction factors of every link")
    link_friction: dict[str, Skin] = Field(default_factory=dict,
                                           description="skin friction by link pattern (first match wins)")

    @model_validator(mode="after")
    def _ratios_above_floor(self):
        for where, skin in [("friction", self.friction), *((f"link_friction['{k}']", v)
                                                          for k, v in self.link_friction.items())]:
            if skin.along / skin.across < self.ev_floor:
                raise ValueError(f"{where}: along / across = {skin.along:g} / {skin.across:g} is below "
                                 f"ev_floor = {self.ev_floor:g}; give along a larger share")
        return self


def _link_names(c):
    return c.robot.links


class BodyContact(SampledContact[BodyContactParams]):
    type_name = "body_contact"

    link_normal_force = Output(shape=link_shape(), unit="N", feedthrough=True, names=_link_names)
    link_mu_scale, link_ev_scale, link_sinkage, link_slip_power, link_slip_speed = law_ports(link_shape(), _link_names)

    law_ports = ("link_mu_scale", "link_ev_scale", "link_sinkage", "link_slip_power", "link_slip_speed")

    # -- set-up ------------------------------------------------------------------------------
    def setup(self):
        p = self.p
        for pat in p.link_friction:
            if not fnmatch.filter(self.robot.links, pat):
                raise ValueError(f"{self.name}: link_friction pattern '{pat}' matches no link of {self.robot.label}; "
                                 f"links: {', '.join(self.robot.links)}")
        opts = BodySampleOptions(spacing=p.spacing, min_around=p.min_around, links=tuple(p.links),
                                 exclude=tuple(p.exclude), exclude_screws=p.exclude_screws, margin=p.margin)
        try:
            self.samples = s = self.robot.derived(body_samples, opts)
        except ValueError as e:
            raise ValueError(f"{self.name}: {e}") from None
        skins = [self._skin(self.robot.links[row]) for row in s.piece_link]
        self.n_samples = s.n
        self.table = BodyTable(
            broad_phase=p.broad_phase, piece_link=s.piece_link, centre_B=s.piece_centre, piece_r=s.piece_radius,
            start=s.start, points_B=s.points, axis_B=s.axis,
            mu_scale=np.array([k.across for k in skins], dtype=np.float64),
            skin_ratio=np.array([k.along / k.across for k in skins], dtype=np.float64))
        self.kernels = SampledKernels(plane=body_plane_step, centres=body_centres_step, sample=body_sample_step,
                                      wrench=body_wrench_step, seen=body_seen_step, jacobian=body_jacobian_step)
        self.owner_link = self.law_row_of_owner = s.piece_link
        self.law_row_names = self.robot.links

    def stiffness_hint(self, u, readers):
        """Penalty contact on the sampled links, each with as many samples at once as lie on its flattest
        side (:func:`flat_side_samples`): a box face on a plane pushes with all of them
        (:mod:`.stiffness_hint`)."""
        from .stiffness_hint import penalty_modes

        return penalty_modes(self, u, flat_side_samples(self.samples), "contact point(s)")

    def _skin(self, link: str) -> Skin:
        for pat, skin in self.p.link_friction.items():
            if fnmatch.fnmatch(link, pat):
                return skin
        return self.p.friction

    @property
    def run_class(self):
        return BodyContactRun


def flat_side_samples(samples, tol: float = 1e-3) -> list[tuple[int, int]]:
    """(link row, n) per sampled link: n the most samples within ``tol`` m of the link's extreme along one
    of its frame's six axis directions, the count that meets a plane at once when the link lies on
    that side (a box's face; a cylinder's line along its length)."""
    s = samples
    per_link: dict[int, list[np.ndarray]] = {}
    for k, row in enumerate(s.piece_link.tolist()):
        per_link.setdefault(row, []).append(s.points[s.start[k]:s.start[k + 1]])
    out = []
    for row, parts in per_link.items():
        p = np.concatenate(parts)
        heights = np.concatenate([p, -p], axis=1)            # along ±x, ±y, ±z of the link frame
        out.append((row, int((heights >= heights.max(axis=0) - tol).sum(axis=0).max())))
    return out


class BodyContactRun(SampledContactRun):
    """One run of the body contact: the sampled run's rows; forces act at the samples themselves."""

    owners_tested = "pieces_tested"

    def __init__(self, comp: BodyContact, u, y):
        super().__init__(comp, u, y, comp.n_samples, comp.samples.n_pieces, comp.samples.piece_radius,
                         comp.law_ports)

    def work_record(self, comp):
        nl = comp.robot.nl
        return BodyWork(active=self.active, centres=self.centres, points=self.points, distance=self.distance,
                        normal=self.normal, material=self.material, sample=self.sample, owner=self.owner,
                        R=np.zeros((3, 3)), vel=self.vel, force=self.force, fn=self.fn, counts=self.counts,
                        track="contact_set" in comp.used_outputs, seen_poses=np.full((nl, 7), np.nan),
                        seen_vels=np.full((nl, 6), np.nan))

    def ports_record(self, comp, u, y, law):
        return BodyPorts(poses=u.link_poses, vels=u.link_velocities, wrenches=y.wrenches, link_fn=y.link_normal_force,
                         normal_force=y.normal_force, contacts=y.contacts, law=law)
