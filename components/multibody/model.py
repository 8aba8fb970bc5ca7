"""Pinocchio dynamics models from a URDF, and the link-tree arrays the kernels use.

Three dynamics models can be built from one URDF (all with a free-flyer at
the root link):

``plain``       no ``<mimic>`` joints in the URDF: Pinocchio's model as
                parsed, integrated with ABA (O(N)).
``embedded``    every mimic group (a primary joint and the joints that mimic
                it: a counter-rotating screw pair) is one DOF, kept on ABA by
                an exact embedding (paper 2.1.3): the followers are locked
                (their mass welded to the body they hang from), the primary's
                mass is welded there too, and the primary DOF keeps a massless
                child with armature Σ m_k² I_a,k (I_a,k a screw's moment about
                its axis, m_k its multiplier, 1 for the primary). A wrench on a
                follower then acts whole on the body, and its axial torque
                enters the primary DOF times m_k: the kernels do exactly that
                through the mimic relation. Exact when each group's rotors are
                axisymmetric about their axes, ride on one rigid body, carry no
                moving joints beneath them and Σ m_k I_a,k a_k = 0 (the
                gyroscopic cross terms cancel); :func:`analyse_mimic_groups`
                checks this and says why not.
``mimic_crba``  Pinocchio's mimic model (rear screw = JointModelMimic), the
                reference: CRBA + non-linear effects + a Cholesky solve,
                O(N³), because Pinocchio 4.1's ABA refuses mimic joints.

Models are built from the parsed link tree (not Pinocchio's URDF parser,
which visits children in joint-name order and so cannot build a mimic model
whose mimic is reached before its primary). Fixed joints and massless links
are merged into their parent body, links kept as frames (the multibody
optimisation of paper 2.1.4; :mod:`.report` measures what it saves).
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import scipy.linalg

from .kernels import FIXED, REVOLUTE, ROOT
from .urdf import LinkTree, MultibodyModelError

ROOT_JOINT = "root_joint"
REL_TOL = 1e-9


# -- mimic groups ---------------------------------------------------------------

@dataclass
class MimicGroup:
    primary: str
    followers: list[tuple[str, float]]        # (joint, multiplier)
    body: str                                 # rigid body (URDF link heading it) they hang from
    axial_inertia: dict[str, float]           # joint -> I_a about its axis, kg·m²
    exact: bool
    reason: str | None = None

    @property
    def spin_inertia(self) -> float:
        """Σ m_k² I_a,k: the group's inertia about its one DOF."""
        mults = {self.primary: 1.0, **dict(self.followers)}
        return float(sum(mults[j] ** 2 * ia for j, ia in self.axial_inertia.items()))


def _rigid_inertia(tree: LinkTree, head: str) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, COM and inertia about the COM of the rigid group under ``head`` (fixed joints only), head frame."""
    mass, first = 0.0, np.zeros(3)
    parts = []
    for name in tree.subtree(head):
        link = tree.links[tree.link_index[name]]
        r, p = tree.placement_in(head, name)
        c = r @ link.com + p
        parts.append((link.mass, c, r @ link.inertia @ r.T))
        mass += link.mass
        first += link.mass * c
    com = first / mass if mass > 0 else np.zeros(3)
    inertia = np.zeros((3, 3))
    for m, c, i_c in parts:
        d = c - com
        inertia += i_c + m * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, com, inertia


def _separating_joints(tree: LinkTree, a: str, b: str) -> list[str]:
    def up(link):
        path = []
        while link in tree.parent_joint:
            path.append(tree.parent_joint[link])
            link = tree.parent_joint[link].parent
        return path
    pa, pb = up(a), up(b)
    common = {j.name for j in pa} & {j.name for j in pb}
    return [j.name for j in pa + pb if j.name not in common and j.moving]


def analyse_mimic_groups(tree: LinkTree) -> list[MimicGroup]:
    """Each primary joint with its mimics, and whether the armature embedding is exact for it."""
    groups = []
    for primary in tree.joints:
        mimics = tree.mimics_of(primary.name)
        if not mimics:
            continue
        members = [(primary, 1.0)] + [(j, j.mimic[1]) for j in mimics]
        body = tree.rigid_root(primary.parent)
        reason = None
        axial, cross = {}, np.zeros(3)
        for joint, mult in members:
            jb = tree.rigid_root(joint.parent)
            if reason is None and jb != body:
                sep = _separating_joints(tree, joint.parent, primary.parent)
                reason = (f"'{joint.name}' and '{primary.name}' do not ride on one rigid body (moving joint(s) "
                          f"{', '.join(sep)} between them): the pair couples to those joints' rates")
            moving_below = [j.name for ln in tree.subtree(joint.child) for j in tree.children.get(ln, []) if j.moving]
            if reason is None and moving_below:
                reason = f"'{joint.name}' carries moving joint(s) {', '.join(moving_below)}"
            mass, com, inertia = _rigid_inertia(tree, joint.child)
            a = joint.axis
            scale = max(np.trace(inertia), 1e-300)
            off_axis = com - (com @ a) * a
            length = np.sqrt(scale / mass) if mass > 0 else 1.0
            if reason is None and mass > 0 and np.linalg.norm(off_axis) > REL_TOL * length:
                reason = f"the mass under '{joint.name}' has its centre of mass {np.linalg.norm(off_axis):.3g} m off the axis"
            i_a = float(a @ inertia @ a)
            proj = np.eye(3) - np.outer(a, a)
            lam = (np.trace(inertia) - i_a) / 2.0
            if reason is None and (np.linalg.norm(inertia @ a - i_a * a) > REL_TOL * scale
                                   or np.linalg.norm(proj @ inertia @ proj - lam * proj) > REL_TOL * scale):
                reason = f"the mass under '{joint.name}' is not axisymmetric about its axis"
            axial[joint.name] = i_a
            r_body, _ = tree.placement_in(body, joint.parent) if jb == body else (np.eye(3), None)
            cross += mult * i_a * (r_body @ joint.rotation @ a)
        total = sum(abs(m) * axial[j.name] for j, m in members)
        if reason is None and np.linalg.norm(cross) > REL_TOL * max(total, 1e-300):
            reason = (f"Σ multiplier·I_a·axis = {np.round(cross, 12).tolist()} is not zero: the gyroscopic "
                      "terms of the group do not cancel")
        groups.append(MimicGroup(primary.name, [(j.name, j.mimic[1]) for j in mimics], body, axial,
                                 reason is None, reason))
    return groups


# -- per-joint parameters ----------------------------------------------------------

def match_values(names: list[str], values: dict[str, float], what: str) -> dict[str, float]:
    """name -> value for each of ``names`` matched by ``values`` (exact names first, then fnmatch
    patterns in the order given). A key that matches nothing raises, listing the valid names."""
    out: dict[str, float] = {}
    for key, val in values.items():
        hits = [n for n in names if n == key] or fnmatch.filter(names, key)
        if not hits:
            raise MultibodyModelError(f"{what}: '{key}' matches no joint; joints: {', '.join(names)}")
    for n in names:
        if n in values:
            out[n] = float(values[n])
            continue
        for key, val in values.items():
            if fnmatch.fnmatchcase(n, key):
                out[n] = float(val)
                break
    return out


# -- building Pinocchio models from the link tree ----------------------------------------

def _axis_rotation(a: np.ndarray) -> np.ndarray:
    """A rotation Q with Q e_z = a (unit)."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(z @ a)
    if c < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    k = np.cross(z, a)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + kx + kx @ kx / (1.0 + c)


def _joint_model(joint) -> tuple[object, np.ndarray]:
    """(Pinocchio joint model, Q): Q rotates Pinocchio's joint frame onto the URDF joint frame's axis."""
    a = joint.axis
    for i, (rev, rub) in enumerate(((pin.JointModelRX, pin.JointModelRUBX), (pin.JointModelRY, pin.JointModelRUBY),
                                    (pin.JointModelRZ, pin.JointModelRUBZ))):
        if abs(a[i] - 1.0) < 1e-15:
            return (rub() if joint.type == "continuous" else rev()), np.eye(3)
    if joint.type != "continuous":
        return pin.JointModelRevoluteUnaligned(a.copy()), np.eye(3)
    return pin.JointModelRUBZ(), _axis_rotation(a)


def _order(tree: LinkTree, body_joints: list, before: list[tuple[str, str]], prefer) -> list:
    """Body joints parents first; among the ready ones the ``prefer`` key (URDF order) wins;
    ``before`` pairs (a, b) put joint a before joint b (a mimic's primary before the mimic)."""
    names = {j.name for j in body_joints}
    parent_of = {}
    for j in body_joints:
        link = j.parent
        while link in tree.parent_joint and tree.parent_joint[link].name not in names:
            link = tree.parent_joint[link].parent
        parent_of[j.name] = tree.parent_joint[link].name if link in tree.parent_joint else None
    deps = {j.name: ({parent_of[j.name]} - {None}) for j in body_joints}
    for a, b in before:
        if a in names and b in names:
            deps[b].add(a)
    by_name = {j.name: j for j in body_joints}
    done, order = set(), []
    while len(order) < len(body_joints):
        ready = [by_name[n] for n in deps if n not in done and deps[n] <= done]
        if not ready:
            raise MultibodyModelError(f"{tree.source}: cannot order joints so that every mimicked joint precedes "
                                      "its mimic and every parent its child")
        pick = min(ready, key=prefer)
        order.append(pick)
        done.add(pick.name)
    return order, parent_of


def build_pin_model(tree: LinkTree, mimic: bool, fixed: str = "merge") -> pin.Model:
    """A Pinocchio model of ``tree`` with a free-flyer at the root.

    mimic: mimic joints become JointModelMimic of their primary (else they are ordinary joints).
    fixed: "merge" (fixed joints and massless links become part of their parent body: the
    optimised model), "locked" (each fixed joint its own body on a zero-DOF hinge, a revolute
    joint mimicking a DOF joint x0, wherever a DOF joint precedes it) or "free" (each fixed
    joint its own body on a free revolute joint: a cost baseline only).
    Joint order: parents first, then URDF document order, mimicked joints before their mimics.
    """
    doc = {j.name: i for i, j in enumerate(tree.joints)}
    body_joints = [j for j in tree.joints if j.moving or fixed != "merge"]
    before = [(j.mimic[0], j.name) for j in tree.joints if j.mimic is not None] if mimic else []
    prefer = (lambda j: (not j.moving, doc[j.name])) if fixed == "locked" else (lambda j: doc[j.name])
    order, parent_of = _order(tree, body_joints, before, prefer)
    model = pin.Model()
    model.name = tree.name
    jid = {None: model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), ROOT_JOINT)}
    jframe = {None: model.addJointFrame(jid[None], 0)}
    frame_of = {None: np.eye(3)}           # Pinocchio joint frame -> URDF child link frame rotation
    head = {None: tree.root}
    for j in order:
        parent = parent_of[j.name]
        r, p = tree.placement_in(head[parent], j.parent)
        qp = frame_of[parent].T            # URDF link frame expressed in the Pinocchio joint frame
        r_o, p_o = qp @ r @ j.rotation, qp @ (r @ j.translation + p)
        if j.moving:
            jm, qrot = _joint_model(j)
        else:
            jm, qrot = pin.JointModelRZ(), np.eye(3)
        jid[j.name] = model.addJoint(jid[parent], jm, pin.SE3(r_o @ qrot, p_o), j.name)
        jframe[j.name] = model.addJointFrame(jid[j.name], jframe[parent])
        frame_of[j.name] = qrot
        head[j.name] = j.child
    names = {j.name for j in body_joints}

    def placed(link: str):
        """(the body joint carrying ``link``: the first one up the tree that is not merged away, None for
        the root body; the link frame in that joint's Pinocchio frame)."""
        h = link
        while h in tree.parent_joint and tree.parent_joint[h].name not in names:
            h = tree.parent_joint[h].parent
        owner = tree.parent_joint[h].name if h in tree.parent_joint else None
        r, p = tree.placement_in(h, link)
        qp = frame_of[owner].T
        return owner, pin.SE3(qp @ r, qp @ p)

    for link in tree.links:
        if link.mass <= 0.0 and not np.any(link.inertia):
            continue
        owner, placement = placed(link.name)
        model.appendBodyToJoint(jid[owner], pin.Inertia(link.mass, link.com, link.inertia), placement)
    for link in tree.links:
        owner, placement = placed(link.name)
        model.addFrame(pin.Frame(link.name, jid[owner], jframe[owner], placement, pin.FrameType.BODY))
    if mimic:
        for j in tree.joints:
            if j.mimic is not None:
                model = pin.transformJointIntoMimic(model, model.getJointId(j.mimic[0]), model.getJointId(j.name),
                                                    j.mimic[1], j.mimic[2])
    if fixed == "locked":
        dofs = [jid[j.name] for j in order if j.is_dof and model.joints[jid[j.name]].nq == 1]
        for j in order:
            if not j.moving:
                earlier = [d for d in dofs if d < model.getJointId(j.name)]
                if earlier:
                    model = pin.transformJointIntoMimic(model, earlier[0], model.getJointId(j.name), 0.0, 0.0)
    return model


# -- dynamics models -------------------------------------------------------------------

DATA_MADE = [0]     # Data objects made by new_data() in this process (tests count them)


def new_data(model: pin.Model) -> pin.Data:
    """A Pinocchio Data for ``model``, built in place.

    ``pin.Data(model)``, never ``model.createData()``: the binding returns createData's Data by
    value and copies it into the Python object, so for a moment there are two. Pinocchio 4.1's
    Data holds four nv×nv×nv second-order derivative tensors (``d2tau_dqdq``, ``d2tau_dvdv``,
    ``d2tau_dqdv``, ``d2tau_dadq``: the second-order RNEA derivatives), allocated and zeroed in
    its constructor and not reachable from Python: 4·8·nv³ bytes, 0.92 GB at nv = 306
    (100 EELS 1.0 modules), 28 MB at nv = 96 (30). createData's copy doubled that at build
    (a 100-module run peaked at 2.0 GB, 1.1 GB after). The constructor zeroes them, so every page
    is touched: no layout or API of 4.1 avoids them; a multibody on its link tree makes no Data
    (:class:`Dynamics`)."""
    DATA_MADE[0] += 1
    return pin.Data(model)


@dataclass
class Dynamics:
    """One Pinocchio model and how to get accelerations from it.

    Its Data is made on first use (``data``): a multibody that integrates on its link tree
    (articulated_solve_kernels.forward_step) never needs one, and at 100 EELS 1.0 modules a Data
    is 0.92 GB of nv³ tensors that its constructor zeroes (so every page is touched)."""

    mode: str                  # plain | embedded | mimic_crba
    model: pin.Model
    data_: pin.Data | None
    groups: list[MimicGroup]
    tree_mass_matrix: object = None     # q -> M on the link tree (set by the multibody), used by mass_matrix

    @property
    def data(self) -> pin.Data:
        if self.data_ is None:
            self.data_ = new_data(self.model)
        return self.data_

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M(q), armature included, dense and symmetric: on the link tree when the multibody set
        ``tree_mass_matrix`` (no Data), else Pinocchio's CRBA."""
        if self.tree_mass_matrix is not None:
            return self.tree_mass_matrix(q)
        m = pin.crba(self.model, self.data, q)
        return np.triu(m) + np.triu(m, 1).T

    def forward(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Generalised accelerations (a new array)."""
        if self.mode != "mimic_crba":
            return pin.aba(self.model, self.data, q, v, tau)
        # WORLD convention: Pinocchio 4.1's default (LOCAL) CRBA is wrong for a mimic joint that has
        # children (checked against RNEA columns; see tests), and WORLD is also faster
        m = pin.crba(self.model, self.data, q, pin.Convention.WORLD)
        b = pin.nonLinearEffects(self.model, self.data, q, v)
        return scipy.linalg.cho_solve(scipy.linalg.cho_factor(m, check_finite=False), tau - b, check_finite=False)


def build_dynamics(tree: LinkTree, mode: str, armature: dict[str, float],
                   groups: list[MimicGroup] | None = None) -> Dynamics:
    """A dynamics model; ``armature`` maps DOF joint names to their reflected rotor inertia."""
    groups = analyse_mimic_groups(tree) if groups is None else groups
    if mode == "plain" and groups:
        raise MultibodyModelError("the URDF has mimic joints; use screw_pairs embedded or mimic_crba")
    model = build_pin_model(tree, mimic=mode == "mimic_crba")
    if mode == "embedded":
        bad = [g for g in groups if not g.exact]
        if bad:
            raise MultibodyModelError("screw_pairs: embedded is not exact for " + "; ".join(
                f"group '{g.primary}': {g.reason}" for g in bad) + " (use screw_pairs: mimic_crba or auto)")
        lock = [model.getJointId(j) for g in groups for j, _ in g.followers]
        if lock:
            model = pin.buildReducedModel(model, lock, pin.neutral(model))
        for g in groups:
            jid = model.getJointId(g.primary)
            parent = model.parents[jid]
            welded = model.jointPlacements[jid].act(pin.Inertia(model.inertias[jid]))
            model.inertias[parent] = pin.Inertia(model.inertias[parent]) + welded
            model.inertias[jid] = pin.Inertia.Zero()
    for name, value in armature.items():
        model.armature[model.joints[model.getJointId(name)].idx_v] = value
    if mode == "embedded":
        for g in groups:
            model.armature[model.joints[model.getJointId(g.primary)].idx_v] += g.spin_inertia
    return Dynamics(mode, model, new_data(model) if mode == "mimic_crba" else None, groups)


def choose_mode(requested: str, groups: list[MimicGroup]) -> tuple[str, str | None]:
    """(mode, why) for screw_pairs = auto | embedded | mimic_crba."""
    if not groups:
        return "plain", None
    if requested == "mimic_crba":
        return "mimic_crba", "requested"
    if requested == "embedded" or all(g.exact for g in groups):
        return "embedded", None
    bad = next(g for g in groups if not g.exact)
    return "mimic_crba", f"armature embedding is not exact for group '{bad.primary}': {bad.reason}"


# -- link-tree arrays for the kernels ---------------------------------------------------------

@dataclass
class TreeArrays:
    order: np.ndarray
    parent: np.ndarray
    jtype: np.ndarray
    R0: np.ndarray
    p0: np.ndarray
    axis: np.ndarray
    qidx: np.ndarray
    qkind: np.ndarray
    vidx: np.ndarray
    mult: np.ndarray
    offset: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray


def tree_arrays(tree: LinkTree, model: pin.Model) -> TreeArrays:
    """Kernel arrays in URDF link order; q/v indices from ``model`` (any of the three: same layout)."""
    n = len(tree.links)
    idx = tree.link_index
    ta = TreeArrays(
        order=np.array([idx[name] for name in tree.topological()], dtype=np.int64),
        parent=np.full(n, -1, dtype=np.int64), jtype=np.zeros(n, dtype=np.int64),
        R0=np.tile(np.eye(3), (n, 1, 1)), p0=np.zeros((n, 3)), axis=np.zeros((n, 3)),
        qidx=np.zeros(n, dtype=np.int64), qkind=np.zeros(n, dtype=np.int64), vidx=np.zeros(n, dtype=np.int64),
        mult=np.ones(n), offset=np.zeros(n),
        mass=np.array([ln.mass for ln in tree.links]), com=np.array([ln.com for ln in tree.links]),
        inertia=np.array([ln.inertia for ln in tree.links]))
    ta.jtype[idx[tree.root]] = ROOT
    for j in tree.joints:
        l = idx[j.child]
        ta.parent[l] = idx[j.parent]
        ta.R0[l], ta.p0[l] = j.rotation, j.translation
        if not j.moving:
            ta.jtype[l] = FIXED
            continue
        ta.jtype[l] = REVOLUTE
        ta.axis[l] = j.axis
        dof = j.name if j.mimic is None else j.mimic[0]
        pj = model.joints[model.getJointId(dof)]
        ta.qidx[l], ta.vidx[l] = pj.idx_q, pj.idx_v
        ta.qkind[l] = 1 if pj.nq == 2 else 0
        if j.mimic is not None:
            ta.mult[l], ta.offset[l] = j.mimic[1], j.mimic[2]
    return ta


def coordinate_names(model: pin.Model) -> tuple[list[str], list[str]]:
    """Element names of q and v, in Pinocchio's order (mimic joints have none)."""
    qn, vn = [], []
    for jid in range(1, model.njoints):
        jm, name = model.joints[jid], model.names[jid]
        if jm.nv == 0:
            continue
        if name == ROOT_JOINT:
            qn += [f"{ROOT_JOINT}.{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw")]
            vn += [f"{ROOT_JOINT}.{c}" for c in ("vx", "vy", "vz", "wx", "wy", "wz")]
        elif jm.nq == 2:
            qn += [f"{name}.cos", f"{name}.sin"]
            vn.append(name)
        else:
            qn.append(name)
            vn.append(name)
    return qn, vn
