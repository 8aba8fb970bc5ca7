"""Screw visual meshes: referenced files exist, are valid STL, and their helix
has the hand and lead angle the metadata claims."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml

from snakesim.robots import DESIGNS, generate_robot, write_robot
from snakesim.robots.description import MESH_DIR, URDF_DIR


def referenced_meshes(urdf_path: Path) -> list[Path]:
    root = ET.parse(urdf_path).getroot()
    return [urdf_path.parent / m.get("filename") for m in root.iter("mesh")]


def committed_screws() -> list[tuple[Path, dict]]:
    """(mesh path, metadata entry) for every screw of every committed robot."""
    out = []
    for design in DESIGNS:
        meta = yaml.safe_load((URDF_DIR / f"{design}.yaml").read_text())
        out += [(URDF_DIR / s["visual_mesh"], s) for s in meta["screws"]]
    return out


SCREWS = {path.name: (path, entry) for path, entry in committed_screws()}  # one per distinct mesh


@pytest.mark.parametrize("design", list(DESIGNS))
def test_referenced_meshes_exist_and_load(design):
    urdf = URDF_DIR / f"{design}.urdf"
    for path in referenced_meshes(urdf):
        assert path.resolve().parent == MESH_DIR  # ../meshes/ relative to the URDF
        assert path.exists(), path
        assert not path.read_bytes()[:5].lower().startswith(b"solid")  # binary STL, not ASCII
        mesh = trimesh.load(path, force="mesh")
        assert len(mesh.faces) > 0
        assert len(mesh.faces) <= 5000  # "a few thousand triangles at most"


def test_every_committed_mesh_is_used():
    used = {p.resolve() for d in DESIGNS for p in referenced_meshes(URDF_DIR / f"{d}.urdf")}
    assert set(MESH_DIR.glob("*.stl")) == used


@pytest.mark.parametrize("name", sorted(SCREWS))
def test_mesh_is_closed_with_the_volume_of_core_and_blades(name):
    path, s = SCREWS[name]
    mesh = trimesh.load(path, force="mesh")
    assert mesh.is_watertight and mesh.is_winding_consistent
    r_o, r_i, length = s["radius"], s["core_radius"], s["length"]
    bounds = mesh.bounds
    assert bounds[1][0] - bounds[0][0] == pytest.approx(length, rel=1e-4)  # axis = x
    assert np.max(np.hypot(mesh.vertices[:, 1], mesh.vertices[:, 2])) == pytest.approx(r_o, rel=1e-4)
    # volume: core drum plus blades. A blade is a rectangle (radial r_i..r_o,
    # axial thickness t) swept through angle 2 pi (L - t) / lead, which encloses
    # t (r_o^2 - r_i^2)/2 per radian.
    lead = 2 * math.pi * r_o * math.tan(s["lead_angle"])
    t = s["blade_thickness"]
    assert _blade_thickness(_tip_vertices(mesh, r_o), lead, s["hand"], s["starts"]) == pytest.approx(t, rel=0.01)
    blades = s["starts"] * t * (r_o**2 - r_i**2) / 2 * 2 * math.pi * (length - t) / lead
    assert mesh.volume == pytest.approx(math.pi * r_i**2 * length + blades, rel=0.01)


@pytest.mark.parametrize("name", sorted(SCREWS))
def test_mesh_helix_has_metadata_hand_and_lead(name):
    path, s = SCREWS[name]
    mesh = trimesh.load(path, force="mesh")
    tips = _tip_vertices(mesh, s["radius"])
    lead = 2 * math.pi * s["radius"] * math.tan(s["lead_angle"])
    other = "left" if s["hand"] == "right" else "right"
    assert _helix_coherence(tips, lead, s["hand"], s["starts"]) > 0.9
    assert _helix_coherence(tips, lead, other, s["starts"]) < 0.5
    assert _helix_coherence(tips, 2 * lead, s["hand"], s["starts"]) < 0.5


def _tip_vertices(mesh: trimesh.Trimesh, r_o: float) -> np.ndarray:
    radius = np.hypot(mesh.vertices[:, 1], mesh.vertices[:, 2])
    return mesh.vertices[radius > r_o * (1 - 1e-4)]


def _phase(tips: np.ndarray, lead: float, hand: str, starts: int) -> np.ndarray:
    """For a helix x = s lead theta / 2pi (s = +1 right, -1 left), the angle
    theta - s 2pi x / lead is constant along a blade; blades differ by 2pi/starts."""
    sign = 1 if hand == "right" else -1
    theta = np.arctan2(tips[:, 2], tips[:, 1])
    return starts * (theta - sign * 2 * math.pi * tips[:, 0] / lead)


def _helix_coherence(tips: np.ndarray, lead: float, hand: str, starts: int) -> float:
    """Mean resultant length of the blade phases: ~1 when every tip vertex lies
    on helices of this hand and lead, small otherwise."""
    return float(abs(np.mean(np.exp(1j * _phase(tips, lead, hand, starts)))))


def _blade_thickness(tips: np.ndarray, lead: float, hand: str, starts: int) -> float:
    phase = _phase(tips, lead, hand, starts)
    spread = np.angle(np.exp(1j * (phase - np.angle(np.mean(np.exp(1j * phase))))))
    # phase offset across the blade is starts * 2pi t / lead
    return float((spread.max() - spread.min()) * lead / (2 * math.pi * starts))


def test_write_robot_makes_meshes_pinocchio_can_load(tmp_path):
    import pinocchio as pin

    robot = generate_robot("eels-1.0", modules=2, lead_angle=0.5, screw_radius=0.1)
    assert robot.missing_meshes()  # a non-default screw has no committed mesh
    path = write_robot(robot, tmp_path)
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    visual = pin.buildGeomFromUrdf(model, str(path), pin.GeometryType.VISUAL, package_dirs=[str(path.parent)])
    screws = [g for g in visual.geometryObjects if g.name.startswith("screw_")]
    assert len(screws) == 4 and all(Path(g.meshPath).exists() for g in screws)
    assert (tmp_path / "urdf" / "eels-1.0.yaml").exists()
