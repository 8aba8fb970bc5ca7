"""A near-massless link against the step size (issue 6; bench/extremes.py has the full table).

EELS 1.0 with one module floats in zero gravity; the tail cap's mass and inertia are scaled by
1e-6 and a torsion spring K on bend_00 (the only joint between the tail and the rest) is the
one force. The tail swings on the joint pin against a body 1e6 times heavier, so the mode's
inertia is the tail's about the pin axis, I = a·I_c·a + m·|a × (c − o)|² (from the URDF;
the heavy side's recoil changes it by ~1e-6), and ω = √(K/I). Classical RK4 on ẍ = −ω²x is
stable iff h·ω ≤ 2√2 (|R(iy)|² = 1 − y⁶/72 + y⁸/576).

- Without armature, a step at h·ω = 2·2√2 grows the mode by |R| ≈ 37 per step: the run must
  end as a reported failure naming the multibody, with its last good state kept: a blow-up
  (the multibody's guard: the kinetic energy grows ~|R|² per step with nothing to supply it)
  within a few steps, or, with the guard off, a non-finite state.
- Without armature at h·ω = 2 (inside the bound) the same run completes, bounded: the bound is
  where the derivation puts it, not an accident of the scene.
- With the default armature (>= armature_floor = 1e-3 kg·m² on bend_00: the rotor spins with
  the joint) the mode's inertia is >= 1e-3 kg·m² and the unstable step above is h·ω' < 0.02:
  the run completes and conserves energy, kinetic (links + rotor) + ½Kq².
"""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from snakesim.framework.assembly import resolve
from snakesim.framework.registry import default_registry
from snakesim.framework.session import Session
from snakesim.robots import load_robot

SCALE = 1e-6
K = 200.0                 # N·m/rad, the bend PID's kp
Q0 = 0.01                 # rad: small, so the swing stays linear
STEPS = 400               # at |R| ≈ 37 per step, 0.01 rad passes 1e300 within ~200 steps
RK4_BOUND = 2.0 * math.sqrt(2.0)
NO_ARMATURE = {"armature_floor": 0.0, "armature_per_effort": {"bend": 0.0, "twist": 0.0, "screw": 0.0, "other": 0.0}}


def _vec(text, default="0 0 0"):
    return np.array([float(v) for v in (text or default).split()])


def light_tail_urdf() -> tuple[str, float]:
    """(URDF text with the tail scaled by SCALE, the tail's inertia about bend_00's axis, kg·m²)."""
    root = ET.fromstring(load_robot("eels-1.0", modules=1).urdf)
    tail = next(link for link in root.findall("link") if link.get("name") == "tail")
    inertial = tail.find("inertial")
    mass, inertia = inertial.find("mass"), inertial.find("inertia")
    mass.set("value", repr(float(mass.get("value")) * SCALE))
    for key, value in inertia.attrib.items():
        inertia.set(key, repr(float(value) * SCALE))
    joint = next(j for j in root.findall("joint") if j.get("name") == "bend_00")
    assert joint.find("parent").get("link") == "tail"
    assert not _vec(joint.find("origin").get("rpy")).any() and not _vec(inertial.find("origin").get("rpy")).any()
    a = _vec(joint.find("axis").get("xyz"))
    a /= np.linalg.norm(a)
    o, c = _vec(joint.find("origin").get("xyz")), _vec(inertial.find("origin").get("xyz"))
    i = inertia.attrib
    ic = np.array([[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]], [i["ixz"], i["iyz"], i["izz"]]],
                  dtype=float)
    i_axis = a @ ic @ a + float(mass.get("value")) * float(np.sum(np.cross(a, c - o) ** 2))
    return ET.tostring(root, encoding="unicode"), float(i_axis)


@pytest.fixture(scope="module")
def light_tail(tmp_path_factory):
    text, i_axis = light_tail_urdf()
    path = tmp_path_factory.mktemp("light") / "eels-light-tail.urdf"
    path.write_text(text, encoding="utf-8")
    return path, i_axis


def run(tmp_path, urdf, dt, armature, guard=True):
    robot = {"urdf": str(urdf), "gravity": [0.0, 0.0, 0.0], "q0": {"bend_00": Q0}, **({} if armature else NO_ARMATURE),
             "blowup_guard": {"enabled": guard}}
    assembly = {
        "sim": {"duration": STEPS * dt, "dt": dt, "integrator": "rk4"},
        "components": {
            "robot": {"type": "multibody", "params": robot},
            "spring": {"type": "joint_spring_damper", "params": {"stiffness": {"bend_00": K}}},
        },
        "connections": ["robot.joint_q -> spring.q", "robot.joint_v -> spring.v", "spring.tau -> robot.tau"],
        "record": ["robot.energy", "robot.joint_q"],
    }
    path = tmp_path / f"light-{dt:.6g}-{armature}-{guard}.yaml"
    path.write_text(json.dumps(assembly), encoding="utf-8")       # JSON is YAML
    reg = default_registry()
    session = Session(resolve(str(path), search_path=reg.assembly_paths()), reg)
    return session, session.run()


def test_light_tail_is_its_own_mode(light_tail):
    _, i_axis = light_tail
    # iyy·s + m·s·(joint x − com x)²: 0.00295859375 + 1.5·0.05² from the generator's tail cap
    assert i_axis == pytest.approx((0.00295859375 + 1.5 * 0.05 ** 2) * SCALE, rel=1e-9)


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")   # the framework's own finiteness test
@pytest.mark.parametrize("guard", [True, False], ids=["blow-up-guard", "guard-off"])
def test_without_armature_a_step_past_the_rk4_bound_is_reported_as_a_failure(light_tail, tmp_path, guard):
    urdf, i_axis = light_tail
    omega = math.sqrt(K / i_axis)
    session, r = run(tmp_path, urdf, 2.0 * RK4_BOUND / omega, armature=False, guard=guard)
    assert session.plan.components["robot"].armature_user["bend_00"] == 0.0
    sm = r.summary
    assert not sm["completed"] and sm["outcome"] == "failure"
    if guard:
        # |R|² ≈ 1400 per step: the kinetic energy passes what the spring's end powers could supply at once
        assert sm["failure_kind"] == "blow_up"
        assert re.search(r"^robot: blow-up in the step from t = .* link '(tail|module_00)'", sm["stop_reason"]), \
            sm["stop_reason"]
        assert sm["steps"] < 20
    else:
        # the first non-finite value is the multibody's state or an output derived from it (its energy, recorded)
        assert sm["failure_kind"] == "non_finite"
        assert re.search(r"non-finite (state in|recorded output of) component 'robot'", sm["stop_reason"]), \
            sm["stop_reason"]
    assert r.last_good_state is not None and np.isfinite(r.last_good_state["components"]["robot"]).all()
    assert sm["steps"] < STEPS


def test_without_armature_a_step_inside_the_rk4_bound_runs_bounded(light_tail, tmp_path):
    urdf, i_axis = light_tail
    omega = math.sqrt(K / i_axis)
    session, r = run(tmp_path, urdf, 2.0 / omega, armature=False)
    assert r.summary["completed"], r.summary["stop_reason"]
    q = np.asarray(r["robot.joint_q"])[:, session.plan.components["robot"].dof_index("bend_00")]
    # RK4 inside its region only damps the mode (|R(2i)| ≈ 0.75): never past the release angle
    assert np.abs(q).max() <= Q0 * (1 + 1e-6)


def test_default_armature_runs_the_same_step_and_conserves_energy(light_tail, tmp_path):
    urdf, i_axis = light_tail
    dt = 2.0 * RK4_BOUND / math.sqrt(K / i_axis)
    session, r = run(tmp_path, urdf, dt, armature=True)
    robot = session.plan.components["robot"]
    arm = robot.armature_user["bend_00"]
    assert arm >= 1e-3
    assert r.summary["completed"], r.summary["stop_reason"]
    q = np.asarray(r["robot.joint_q"])[:, robot.dof_index("bend_00")]
    energy = np.asarray(r["robot.energy"]).sum(axis=1) + 0.5 * K * q ** 2
    e0 = 0.5 * K * Q0 ** 2
    assert energy[0] == pytest.approx(e0, rel=1e-12)
    # the stiffest mode now has h·ω' <= dt·√(K/arm) < 0.02: RK4 loses (hω')⁶/72 < 1e-12 of the
    # energy per step, so over the run only roundoff remains; a rotor missing from the energy or
    # the dynamics would show at O(1)
    assert dt * math.sqrt(K / arm) < 0.02
    assert np.abs(energy - e0).max() <= 1e-6 * e0
    # and the swing is the slow one: the tail did move (not frozen), at most to its release angle
    assert np.abs(q).max() <= Q0 * (1 + 1e-6) and q.min() < Q0 * (1 - 1e-6)
