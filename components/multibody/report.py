"""The multibody optimisation report (paper 2.1.4) and the unoptimised baselines it is measured against.

Pinocchio merges fixed joints and massless links into frames while parsing;
it has no zero-DOF joint, so an unoptimised model -- every URDF link its own
body -- is built by rewriting the URDF:

* mass-matrix path (``crba``): each fixed joint becomes a revolute joint that
  mimics a DOF joint with multiplier 0, i.e. a locked zero-DOF hinge with its
  own body (DARTS' locked hinge). The dynamics are identical to the optimised
  model's (tests check it), so this baseline is exact. (A fixed joint that
  precedes every revolute DOF in the tree stays merged: Pinocchio needs the
  mimicked joint first.)
* ABA path (``aba``): ABA refuses mimic joints, so each fixed joint becomes a
  free revolute joint (its DOF held in the timing at q = 0, armature 1 so a
  massless frame body is not singular) and rear screws stay separate bodies
  with their own DOF: the per-body work of a recursion that keeps every link.
  It is a cost baseline only (more DOF than the robot has).

The costs are one evaluation of the accelerations (ABA, or CRBA + non-linear
effects + Cholesky) by Pinocchio, in µs, best of several batches.
"""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin

from .model import Dynamics, build_dynamics, build_pin_model, new_data


def time_call(fn, budget_s: float = 0.05, batches: int = 5) -> float:
    """µs per call of ``fn()``: best of ``batches`` batches sized to ~budget_s/batches each."""
    fn()
    t0 = time.perf_counter()
    fn()
    one = max(time.perf_counter() - t0, 1e-7)
    n = max(1, int(budget_s / batches / one))
    best = float("inf")
    for _ in range(batches):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, (time.perf_counter() - t0) / n)
    return best * 1e6


def baseline_model(tree, armature: dict[str, float], path: str) -> Dynamics:
    """The unoptimised model of ``path`` 'crba' or 'aba' (see the module docstring)."""
    if path == "crba":
        m = build_pin_model(tree, mimic=True, fixed="locked")
        _set_armature(m, armature, 1.0)
        return Dynamics("mimic_crba", m, new_data(m), [])
    m = build_pin_model(tree, mimic=False, fixed="free")
    _set_armature(m, armature, 1.0)
    return Dynamics("plain", m, new_data(m), [])


def baseline_models(tree, armature: dict[str, float]) -> dict[str, Dynamics]:
    """The unoptimised models: {'aba': ..., 'crba': ...} (both at once: each holds an O(nv³) Data)."""
    return {path: baseline_model(tree, armature, path) for path in ("crba", "aba")}


def _set_armature(model, armature, other):
    for jid in range(2, model.njoints):
        jm = model.joints[jid]
        if jm.nv:
            model.armature[jm.idx_v] = armature.get(model.names[jid], other)


def time_dynamics(dyn: Dynamics, seed: int = 0, budget_s: float = 0.05) -> float:
    rng = np.random.default_rng(seed)
    model = dyn.model
    q = pin.neutral(model)
    if model.nq > 7:
        lo, hi = -np.ones(model.nq), np.ones(model.nq)
        q = pin.randomConfiguration(model, lo, hi)
    v, tau = rng.standard_normal(model.nv), rng.standard_normal(model.nv)
    return time_call(lambda: dyn.forward(q, v, tau), budget_s)


def counts(tree) -> dict:
    fixed = [j for j in tree.joints if not j.moving]
    mimic = [j for j in tree.joints if j.mimic is not None]
    moving = [j for j in tree.joints if j.moving]
    return {"links": len(tree.links), "massless_links": sum(ln.massless for ln in tree.links),
            "joints": len(tree.joints) + 1, "fixed_joints": len(fixed), "mimic_joints": len(mimic),
            "bodies": len(tree.links), "dof": 6 + len(moving), "dof_with_mimic_embedded": 6 + len(moving) - len(mimic)}


def model_counts(model) -> dict:
    bodies = model.njoints - 1
    massless = sum(1 for j in range(1, model.njoints) if model.inertias[j].mass == 0.0)
    frames = sum(1 for f in model.frames if f.type == pin.FrameType.BODY)
    return {"bodies": bodies, "massless_bodies": massless, "joints": bodies, "dof": model.nv,
            "nq": model.nq, "link_frames": frames}


class OptimisationReport(dict):
    """A dict (``json.dumps``-able) that prints as a short table."""

    def __str__(self) -> str:
        b, a = self["before"], self["after"]
        lines = [f"multibody optimisation: {self['robot']}  (screw pairs: {self['screw_pairs']['mode']}"
                 + (f"; {self['screw_pairs']['why']}" if self["screw_pairs"]["why"] else "") + ")",
                 f"  {'':24s}{'before':>10s}{'after':>10s}",
                 f"  {'bodies':24s}{b['bodies']:>10d}{a['bodies']:>10d}",
                 f"  {'joints':24s}{b['joints']:>10d}{a['joints']:>10d}",
                 f"  {'DOF':24s}{b['dof']:>10d}{a['dof']:>10d}",
                 f"  {'links kept as frames':24s}{0:>10d}{a['links_as_frames']:>10d}",
                 f"  (URDF: {b['links']} links, {b['massless_links']} massless; {b['fixed_joints']} fixed, "
                 f"{b['mimic_joints']} mimic joints)"]
        cost = self.get("cost_us")
        if cost:
            lines.append("  one dynamics evaluation, µs (optimised / unoptimised):")
            for path, c in cost.items():
                lines.append(f"    {path:8s} {c['optimised']:9.1f} / {c['unoptimised']:9.1f}   "
                             f"x{c['unoptimised'] / c['optimised']:.2f}   ({c['unoptimised_dof']} DOF unoptimised)")
        else:
            lines.append("  cost against the unoptimised baselines: snakesim check --baseline")
        lines.append(f"  baseline: {self['baseline']}")
        if self.get("armature"):
            from .joint_values import armature_lines
            lines += armature_lines({j: (a["kg_m2"], a["source"]) for j, a in self["armature"].items()},
                                    {j: a.get("kind") for j, a in self["armature"].items()})
        return "\n".join(lines)


BASELINE_TEXT = ("unoptimised = every URDF link its own body: crba path with fixed joints as locked zero-DOF "
                 "hinges (revolute mimic x0; same dynamics), aba path with fixed joints as free revolute "
                 "joints and rear screws as separate DOFs (cost only)")


def optimisation_report(layout, dyn: Dynamics, mode: str, why: str | None, armature: dict[str, float],
                        timing: bool = True, budget_s: float = 0.05) -> OptimisationReport:
    tree = layout.tree
    before = counts(tree)
    after = model_counts(dyn.model)
    after["links_as_frames"] = before["links"] - after["bodies"]
    rep = OptimisationReport(
        robot=tree.source, before=before, after=after,
        screw_pairs={"mode": mode, "why": why,
                     "groups": [{"primary": g.primary, "followers": g.followers, "body": g.body,
                                 "exact": g.exact, "reason": g.reason,
                                 "spin_inertia": g.spin_inertia} for g in layout.groups]},
        baseline=BASELINE_TEXT, timed=False)
    if timing:
        # one extra model at a time, each dropped once timed: each holds a Data of O(nv³) bytes
        # (model.new_data), so at 100 modules holding the three together peaked at several GB
        cost = {}
        if mode != "mimic_crba":
            base = baseline_model(tree, armature, "aba")
            cost["aba"] = {"optimised": time_dynamics(dyn, budget_s=budget_s),
                           "unoptimised": time_dynamics(base, budget_s=budget_s),
                           "optimised_dof": dyn.model.nv, "unoptimised_dof": base.model.nv}
            del base
        if mode == "mimic_crba":
            crba_opt = dyn
        elif mode == "plain":           # the same model: its own Data's CRBA path
            crba_opt = Dynamics("mimic_crba", dyn.model, dyn.data, [])
        else:
            crba_opt = build_dynamics(tree, "mimic_crba", armature, layout.groups)
        opt_us, opt_nv = time_dynamics(crba_opt, budget_s=budget_s), crba_opt.model.nv
        del crba_opt
        base = baseline_model(tree, armature, "crba")
        cost["crba"] = {"optimised": opt_us, "unoptimised": time_dynamics(base, budget_s=budget_s),
                        "optimised_dof": opt_nv, "unoptimised_dof": base.model.nv}
        del base
        rep["cost_us"] = {k: cost[k] for k in ("aba", "crba") if k in cost}
        rep["timed"] = True
    return rep

