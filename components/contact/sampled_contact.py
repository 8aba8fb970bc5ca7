"""The sampled contact back ends (screw_sdf_contact, body_contact): their shared component base
(:class:`SampledContact`: the evaluation, the law inputs' check, the depth watch, the Jacobian) and
their run (:class:`SampledContactRun`): the per-row scratch, the counters, the kernels bound to this
plan's port buffers, the terrain they are bound to, and the evaluation on a terrain other than a plane.

Both back ends place samples fixed in links (owners: a screw, a body piece), query the terrain's SDF
at them and reduce the forces to link wrenches; they differ in their sample tables, records and
kernels, which a subclass names (:class:`SampledKernels`) and builds (``work_record``,
``ports_record``). Rows: the first m of the per-row arrays are the last evaluation's samples
(work.counts[4] = m); ``force_point`` is where each row's force acts.

Per terrain object (``use_terrain``, on the first evaluation and whenever the input carries another
terrain): the material table, the plane record, and the step kernels bound to it: one numba call
against a plane (Terrain.fast_plane), else the broad phase, the sample rows, Terrain.query in Python
and the force kernel (``_evaluate``). Terrain *state* is not a reason to rebind: Terrain.query reads
it at every call (terrain/base.py).

The contact law record (contact_law.py) rides in the ports record, one on the outputs and one on
scratch outputs, so an evaluation for the contact set alone leaves the numeric outputs untouched.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Callable

import numpy as np

from pydantic import Field

from snakesim.framework import Input, Output

from ..kernel_args import bind
from ..kernel_reductions import least_distance
from .contact_law import ContactLaw
from .kernels import MODES
from .link_contact import LinkContact, LinkContactParams, P
from .screw_contact_kernels import Surface


def law_ports(shape, names) -> tuple[Input, Input, Input, Output, Output]:
    """The contact law's ports on rows of ``shape`` named ``names`` (contact_law.py): the inputs μ scale
    (1, default 1), ‖e_v‖ scale (1, default 1), sinkage (m, default 0) and the outputs slip power (W) and
    load-weighted slip speed (m/s)."""
    return (Input(shape=shape, unit="1", default=1.0, names=names),
            Input(shape=shape, unit="1", default=1.0, names=names),
            Input(shape=shape, unit="m", default=0.0, names=names),
            Output(shape=shape, unit="W", feedthrough=True, names=names),
            Output(shape=shape, unit="m/s", feedthrough=True, names=names))


class SampledContactParams(LinkContactParams):
    broad_phase: bool = True
    margin: float = Field(0.0, ge=0, description="m added to each owner's (screw's, piece's) bounding sphere")


class SampledContact(LinkContact[P]):
    """A back end whose contacts are samples fixed in links (module docstring). A subclass sets in
    ``setup()``: ``table`` (its constant record), ``kernels`` (:class:`SampledKernels`), ``owner_link``
    and ``law_row_of_owner`` (per owner: its link row, its contact-law row), and names ``run_class``,
    ``law_ports`` (mu_scale, ev_scale, sinkage inputs; slip_power, slip_speed outputs), ``depth_what``
    and ``jacobian_inputs``."""

    run_class: type["SampledContactRun"]
    law_ports: tuple[str, str, str, str, str]
    depth_what = "link"
    jacobian_inputs: tuple[str, ...] = ("link_poses", "link_velocities")

    def make_cache(self, x, u, y):
        """Per-row scratch, the counters, and the kernels bound to this plan's port buffers (and, for
        the contact set when the last evaluation saw other inputs, to scratch outputs)."""
        return self.run_class(self, u, y)

    def output(self, t, x, u, y):
        u.cache.evaluate(self, t, u)

    def port_jacobian(self, port, t, x, u, y):
        """∂wrenches/∂(link twist, displacement): per link 6×6 blocks from the last evaluation's contacts
        (jacobian_kernels.py), for linearly implicit integrators."""
        return u.cache.jacobian(self, self.jacobian_inputs) if port == "wrenches" else None

    def stop_on_law_input(self, t: float, row: int, values: list[float]) -> None:
        """Stop: the contact law's inputs (mu_scale ≥ 0, ev_scale > 0, sinkage ≥ 0, finite) are out of
        range at ``row``."""
        names = ", ".join(f"{n} = {v:g}" for n, v in zip(self.law_ports[:3], values))
        self.stop(f"contact law input out of range for {self.law_row_names[row]} at t = {t:.6g} s: {names}; "
                  "valid: mu_scale ≥ 0, ev_scale > 0, sinkage ≥ 0 m, all finite")


@dataclasses.dataclass(frozen=True)
class SampledKernels:
    """A sampled back end's numba steps, on (table, work, ports[, surface]) records:
    ``plane`` one whole evaluation against a plane; ``centres`` the owners' bounding-sphere centres;
    ``sample`` the sample rows (returns m); ``wrench`` the forces of queried rows; ``seen`` the last
    evaluation saw these inputs; ``jacobian`` the per-link blocks (…, d_twist, d_pose, on_link)."""

    plane: Callable
    centres: Callable
    sample: Callable
    wrench: Callable
    seen: Callable
    jacobian: Callable


_UNSET = object()


class SampledContactRun:
    """One run's scratch and bound kernels of a sampled back end (module docstring). ``stats``:
    evaluations, owners tested and samples queried (tests and benches)."""

    #: the per-owner name of ``stats``' second counter
    owners_tested = "owners_tested"

    def __init__(self, comp, u, y, n_rows: int, n_owners: int, radii: np.ndarray, law_ports: tuple[str, ...]):
        """``n_rows`` per-row capacity, ``n_owners`` screws or pieces (broad-phase spheres of ``radii``),
        ``law_ports``: the names of the law's inputs mu_scale, ev_scale, sinkage and outputs slip_power,
        slip_speed on this component."""
        self.comp, self.table, self.radii, self.kernels = comp, comp.table, radii, comp.kernels
        self.terrain = _UNSET                                     # not even None: output() checks it first
        self.surface = self.step = self.step_scratch = self.mats = self.jac = None
        self.active = np.arange(n_owners, dtype=np.int64)        # every owner, unless the broad phase says
        self.centres = np.zeros((n_owners, 3))
        self.points, self.vel, self.force, self.normal = (np.zeros((n_rows, 3)) for _ in range(4))
        self.distance, self.fn = np.zeros(n_rows), np.zeros(n_rows)
        self.material, self.sample, self.owner = (np.zeros(n_rows, dtype=np.int64) for _ in range(3))
        self.counts = np.zeros(7, dtype=np.int64)   # evaluations, owners tested, rows queried, active owners, m, …
        self.counts[3] = n_owners
        self.work = self.work_record(comp)
        self.law_inputs = [getattr(u, name) for name in law_ports[:3]]
        #: the law inputs' first row out of range (−1: none), as the last evaluation into the outputs found
        self.bad_law_row = np.full(1, -1, dtype=np.int64)
        law = self._law(comp, y, law_ports, self.bad_law_row)
        self.ports = self.ports_record(comp, u, y, law)
        scratch = _ScratchOutputs({name: np.zeros_like(getattr(y, name)) for name in comp.outputs
                                   if name != "contact_set"})
        self.scratch_ports = self.ports_record(comp, u, scratch, self._law(comp, scratch, law_ports,
                                                                                np.full(1, -1, dtype=np.int64)))
        k = self.kernels
        self.seen = bind(k.seen, self.work, self.ports)
        self.deepest = bind(least_distance, self.distance, self.counts)
        self.centres_call = bind(k.centres, self.table, self.work, self.ports)
        self.sample_call = bind(k.sample, self.table, self.work, self.ports)

    # -- what a subclass builds ----------------------------------------------------------------------
    def work_record(self, comp):
        """This run's work record (per-row scratch, counters, what the last evaluation saw)."""
        raise NotImplementedError

    def ports_record(self, comp, u, y, law):
        """The ports record on the input views ``u``, the output buffers ``y`` and the law record."""
        raise NotImplementedError

    @property
    def force_point(self) -> np.ndarray:
        """Where each row's force acts (world, m)."""
        return self.points

    # -- the contact law ---------------------------------------------------------------------------
    def _law(self, comp, y, names, bad_row):
        """The contact law record on this run's law inputs and the outputs ``y`` (real or scratch), its
        check's answer into ``bad_row``."""
        p = comp.p
        power, speed = getattr(y, names[3]), getattr(y, names[4])
        law = ContactLaw(v_eps=float(p.v_eps), mode=MODES[p.regularisation], ev_floor=float(p.ev_floor),
                         row_of_owner=comp.law_row_of_owner, mu_scale=self.law_inputs[0], ev_scale=self.law_inputs[1],
                         sinkage=self.law_inputs[2], slip_power=power, slip_speed=speed,
                         row_fn=np.zeros_like(power), bad_row=bad_row)
        return law

    # -- per terrain object --------------------------------------------------------------------------
    def use_terrain(self, comp, terrain) -> None:
        """The terrain-dependent records (material table; a plane's origin and normal, queried in numba;
        every other kind through Terrain.query) and the steps bound to them."""
        terrain = comp.checked_terrain(terrain)
        self.jac = None                                            # its Jacobian call binds the new surface
        self.mats = mats = comp.material_table(terrain)
        fast = terrain.fast_plane() if comp.fast_plane else None     # the kind says: one plane
        plane = fast is not None
        self.surface = Surface(origin=np.array(fast[0] if plane else (0.0, 0.0, 0.0), dtype=float),
                               n=np.array(fast[1] if plane else (0.0, 0.0, 1.0), dtype=float),
                               region_material=int(terrain.region_material[0]) if plane else 0, mats=mats)
        t, k = self.table, self.kernels
        if plane:       # the whole evaluation in one numba call
            self.step = bind(k.plane, t, self.work, self.ports, self.surface)
            self.step_scratch = bind(k.plane, t, self.work, self.scratch_ports, self.surface)
        else:
            self.step = functools.partial(self._evaluate, bind(k.wrench, t, self.work, self.ports, self.surface))
            self.step_scratch = functools.partial(self._evaluate, bind(k.wrench, t, self.work, self.scratch_ports,
                                                                       self.surface))
        self.terrain = terrain

    def _evaluate(self, wrench) -> None:
        """One evaluation on a terrain other than a plane: the broad phase, the samples' points,
        Terrain.query (and ``after_query``), then the forces (``wrench``, bound to outputs or scratch)."""
        terrain = self.terrain
        if self.comp.p.broad_phase:
            self.centres_call()
            active = np.flatnonzero(terrain.distance_lower_bound(self.centres, self.radii) <= 0.0)
            self.active[:active.size] = active
            self.counts[3] = active.size
        m = self.sample_call()
        if m:
            query_into(terrain, self.points[:m], self.distance, self.normal, self.material)
            self.after_query(terrain)
        wrench()

    def after_query(self, terrain) -> None:
        """More queries a back end makes once the samples are known (the screws' exact rings)."""

    # -- the evaluation, as the component runs it ---------------------------------------------------
    def evaluate(self, comp, t, u) -> None:
        """One evaluation into the outputs, then the law inputs' check and the depth watch."""
        if u.terrain is not self.terrain:
            self.use_terrain(comp, u.terrain)
        self.step()
        bad = self.bad_law_row[0]
        if bad >= 0:
            comp.stop_on_law_input(t, bad, [float(a[bad]) for a in self.law_inputs])
        m = int(self.counts[4])
        if m and comp.p.max_depth is not None:
            deepest = -self.deepest()
            if deepest > comp.p.max_depth:
                comp.watch_depth(t, self.distance[:m], comp.owner_link[self.owner[:m]], deepest, comp.depth_what)

    def jacobian(self, comp, d_inputs):
        """The per-link blocks from the last evaluation (kernels.jacobian, bound once per terrain)."""
        from snakesim.components.multibody.linearization import LinkWrenchJacobian

        if self.terrain is _UNSET:
            return None
        if self.jac is None:
            nl = comp.robot.nl
            d_twist, d_pose, on = np.zeros((nl, 6, 6)), np.zeros((nl, 6, 6)), np.zeros(nl, dtype=np.bool_)
            self.jac = d_twist, d_pose, on, bind(self.kernels.jacobian, self.table, self.work, self.ports,
                                                 self.surface, d_twist, d_pose, on)
        d_twist, d_pose, on, call = self.jac
        call()
        return LinkWrenchJacobian(rows=np.flatnonzero(on), d_twist=d_twist, d_pose=d_pose, inputs=d_inputs)

    # -- ContactRun --------------------------------------------------------------------------------------
    def describes(self, u) -> bool:
        return u.terrain is self.terrain and bool(self.seen())

    def evaluate_scratch(self, t, x, u) -> None:
        if u.terrain is not self.terrain:
            self.use_terrain(self.comp, u.terrain)
        self.step_scratch()

    def active_contacts(self) -> dict:
        m = int(self.counts[4])
        on = np.flatnonzero(self.distance[:m] < 0.0)
        return dict(points=self.force_point[on].copy(), normals=self.normal[on].copy(), forces=self.force[on].copy(),
                    normal_force=self.fn[on].copy(), depth=-self.distance[on], slip=self.vel[on].copy(),
                    link=self.comp.owner_link[self.owner[on]], material=self.material[on].copy())

    @property
    def stats(self) -> dict:
        return {"evaluations": int(self.counts[0]), self.owners_tested: int(self.counts[1]),
                "samples_queried": int(self.counts[2])}


def query_into(terrain, points: np.ndarray, distance: np.ndarray, normal: np.ndarray, material: np.ndarray) -> None:
    """Terrain.query at ``points`` (n, 3) into the first n rows of the per-row arrays."""
    q = terrain.query(points)
    n = points.shape[0]
    distance[:n] = q.distance
    normal[:n] = q.normal
    material[:n] = q.material


class _ScratchOutputs:
    """Output buffers of an evaluation whose numeric outputs nobody reads (the contact set's)."""

    def __init__(self, buffers: dict):
        self.__dict__.update(buffers)
