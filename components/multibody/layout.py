"""What the ports look like for a given robot source: names and sizes, cached per source.

Port shapes and element names are functions of the parameters (resolved at
build time, several times), so the URDF is read and parsed once per robot
source and kept here.
"""

from __future__ import annotations

import fnmatch
import json
import math
from dataclasses import dataclass

import numpy as np

from .urdf import LinkTree, MultibodyModelError, parse_urdf, read_urdf_text

_CACHE: dict[str, "Layout"] = {}

#: Default reflected rotor inertia per joint kind, kg·m² per N·m of the joint's URDF effort limit.
#: A geared actuator's reflected inertia J_m·N² and peak torque T_m·N scale together:
#: J/T = (J_m/T_m)·N ≈ 2e-3 s² for harmonic-drive bend/twist actuators (BLDC J_m/T_m ~ 2e-5 s²,
#: N ~ 100) and hobby servos alike, less for the lower-ratio screw drives. Joints without an
#: effort limit get armature_floor.
ARMATURE_PER_EFFORT = {"bend": 2e-3, "twist": 2e-3, "screw": 7e-4, "other": 1e-3}
_SOURCE_KEYS = ("urdf", "design", "modules", "head", "robot", "fts_cuts")


def robot_text(p) -> tuple[str, str]:
    """(URDF text, source label) from the params' robot source."""
    if p.design is None:
        if p.urdf is None:
            raise MultibodyModelError("multibody needs a robot: give 'urdf' (text or path) or 'design' "
                                      "(a snakesim.robots design, with 'modules')")
        if p.modules is not None or p.head is not None or p.robot:
            raise MultibodyModelError("'modules', 'head' and 'robot' apply to a 'design'; with a bare 'urdf' leave them out")
        return read_urdf_text(p.urdf)
    from snakesim.robots import load_robot

    if p.urdf is not None and p.urdf.lstrip().startswith("<"):
        raise MultibodyModelError("with 'design', 'urdf' must be a path to a user URDF of that design, not URDF text")
    try:
        desc = load_robot(p.design, modules=p.modules, head=p.head, urdf=p.urdf, **p.robot)
    except TypeError as e:
        raise MultibodyModelError(f"robot parameters {sorted(p.robot)}: {e}") from None
    except (KeyError, ValueError, FileNotFoundError) as e:
        raise MultibodyModelError(str(e.args[0]) if e.args else str(e)) from None
    label = f"{desc.design} ({desc.modules} modules)" + (f" from {desc.urdf_path}" if desc.source == "user" else "")
    return desc.urdf, label


def layout_of(p) -> "Layout":
    key = json.dumps({k: getattr(p, k) for k in _SOURCE_KEYS}, sort_keys=True, default=str)
    lay = _CACHE.get(key)
    if lay is None:
        text, source = robot_text(p)
        lay = Layout(parse_urdf(text, source), text, list(p.fts_cuts))
        if len(_CACHE) > 32:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = lay
    return lay


@dataclass
class Layout:
    tree: LinkTree
    text: str
    cut_patterns: list[str]

    def __post_init__(self):
        from .model import analyse_mimic_groups, build_pin_model, coordinate_names

        tree = self.tree
        self.links = [ln.name for ln in tree.links]
        self.joints = [j.name for j in tree.dof_joints()]
        self.nl, self.nj = len(self.links), len(self.joints)
        self.groups = analyse_mimic_groups(tree)
        ref = build_pin_model(tree, mimic=True)
        self.nq, self.nv = ref.nq, ref.nv
        self.q_names, self.v_names = coordinate_names(ref)
        self.cuts, self.cut_links = self._resolve_cuts()

    def _resolve_cuts(self) -> tuple[list[str], list[str]]:
        tree = self.tree
        joint_names = [j.name for j in tree.joints]
        names: list[str] = []
        for pat in self.cut_patterns:
            if pat in tree.joint_by_name:
                hits = [pat]
            elif pat in tree.link_index:
                if pat == tree.root:
                    raise MultibodyModelError(f"fts_cuts: '{pat}' is the root link; it has no parent to cut from")
                hits = [tree.parent_joint[pat].name]
            else:
                hits = fnmatch.filter(joint_names, pat) or [tree.parent_joint[ln].name for ln in
                                                            fnmatch.filter(self.links, pat) if ln != tree.root]
            if not hits:
                raise MultibodyModelError(f"fts_cuts: '{pat}' matches no joint or link of {tree.source}; "
                                          f"joints: {', '.join(joint_names)}")
            names += [h for h in hits if h not in names]
        return names, [tree.joint_by_name[n].child for n in names]

    # -- per-joint parameters ------------------------------------------------------------------
    def armature(self, p) -> dict[str, float]:
        from .model import joint_kind, match_values

        explicit = match_values(self.joints, p.armature, "armature")
        per_kind = {**ARMATURE_PER_EFFORT, **p.armature_per_effort}
        unknown = set(per_kind) - set(ARMATURE_PER_EFFORT)
        if unknown:
            raise MultibodyModelError(f"armature_per_effort: unknown joint kind(s) {sorted(unknown)}; "
                                      "kinds: bend, twist, screw, other")
        out = {}
        for name in self.joints:
            if name in explicit:
                out[name] = explicit[name]
                continue
            per = per_kind[joint_kind(name)]
            out[name] = max(p.armature_floor, per * self.tree.joint_by_name[name].effort)
        bad = {k: v for k, v in out.items() if not (v >= 0 and math.isfinite(v))}
        if bad:
            raise MultibodyModelError(f"armature must be finite and >= 0: {bad}")
        return out

    def damping(self, p) -> dict[str, float]:
        from .model import match_values

        out = match_values(self.joints, p.damping, "damping")
        bad = {k: v for k, v in out.items() if not (v >= 0 and math.isfinite(v))}
        if bad:
            raise MultibodyModelError(f"damping must be finite and >= 0: {bad}")
        return out

    # -- initial state ---------------------------------------------------------------------------
    def _joint_values(self, spec, what: str) -> dict[str, float]:
        from .model import match_values

        if isinstance(spec, dict):
            return match_values(self.joints, spec, what)
        if len(spec) != self.nj:
            raise MultibodyModelError(f"{what}: a vector needs {self.nj} values (DOF joints {', '.join(self.joints)}), "
                                      f"got {len(spec)}")
        return dict(zip(self.joints, map(float, spec)))

    def initial_state(self, p, model) -> np.ndarray:
        import pinocchio as pin

        q = pin.neutral(model)
        q[:3] = p.base_position
        if p.base_quaternion is not None:
            quat = np.array(p.base_quaternion, dtype=float)
            n = np.linalg.norm(quat)
            if not (n > 1e-9 and np.isfinite(n)):
                raise MultibodyModelError(f"base_quaternion {p.base_quaternion} has no direction (norm {n:g})")
            quat /= n
        else:
            quat = np.array([0.0, 0.0, math.sin(p.base_yaw / 2), math.cos(p.base_yaw / 2)])
        q[3:7] = quat
        for name, angle in self._joint_values(p.q0, "q0").items():
            jm = model.joints[model.getJointId(name)]
            if jm.nq == 2:
                q[jm.idx_q], q[jm.idx_q + 1] = math.cos(angle), math.sin(angle)
            else:
                q[jm.idx_q] = angle
        v = np.zeros(model.nv)
        rot = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).toRotationMatrix()
        bv = np.array(p.base_velocity, dtype=float)
        v[:3], v[3:6] = rot.T @ bv[:3], rot.T @ bv[3:]
        for name, rate in self._joint_values(p.v0, "v0").items():
            v[model.joints[model.getJointId(name)].idx_v] = rate
        x = np.concatenate([q, v])
        if not np.all(np.isfinite(x)):
            raise MultibodyModelError(f"initial state is not finite: {x}")
        return x

    def check_mass_matrix(self, dyn, owner: str) -> None:
        """Every DOF must carry inertia (mass below it or armature), or ABA divides by zero."""
        import pinocchio as pin

        m = pin.crba(dyn.model, dyn.data, pin.neutral(dyn.model))
        diag = np.diag(m)
        bad = [self.v_names[i] for i in range(6, dyn.model.nv) if not diag[i] > 1e-12 * max(1.0, diag.max())]
        if bad:
            raise MultibodyModelError(f"{owner}: joint(s) {', '.join(bad)} move no mass and have no armature; "
                                      "give them armature (params.armature) or mass")
