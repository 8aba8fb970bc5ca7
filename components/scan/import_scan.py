"""The import pipeline: a scan file → a mesh terrain (mesh, YAML, SDF store entry) and its report.

    read (readers.py) → terrain frame: units, up, offset (frames.py)
    a point cloud:  outliers, voxel (cleaning.py) → density check → normals into the void (normals.py)
                    → reconstruction + trimming (reconstruction.py)
    a mesh:         winding checked; faces wound into the void by the void-axis rule (normals.py)
    → decimation to the face budget (decimation.py) → holes (holes.py) → report (report.py)
    → faces turned to face the ice, files written (terrain_file.py) → the terrain loaded once, which
      computes its SDF grid into the terrain store (terrain/store.py), so a first run starts quickly.

Mesh-terrain keys written when the mesh terrain supports them (terrain/spec_models.py's MeshSpec):
``sign: winding_number`` (an open shaft's sign from the generalised winding number) and
``exact_band`` (exact point–triangle distance near the wall, where contact happens).
"""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

import numpy as np

from . import cleaning, frames, holes, normals, readers, reconstruction, report
from .decimation import decimate
from .errors import ScanError
from .terrain_file import PADDING, default_resolution, write_terrain

#: the exact-distance band written when MeshSpec has ``exact_band``: two SDF grid cells (beyond the grid's
#: own error of up to a cell, so every point of contact is inside it), at most the padding (MeshSpec's rule)
EXACT_BAND_CELLS = 2


@dataclasses.dataclass(frozen=True)
class ImportOptions:
    """units: m | mm | cm | ft | us-ft (None: the file's, else metres); up: +z, -z, +y, -y, +x, -x;
    offset: (x, y, z) file units, 'none', or None (a LAS header's, rounded); voxel: m (None: no
    downsampling); outliers: (k, std) or None; reconstruction: a registered name; depth, trim_quantile,
    max_gap: see reconstruction.py; faces: face budget (0: none); scanner_positions: CSV path;
    resolution: SDF grid spacing m (None: terrain_file.default_resolution); tolerance: coverage m
    (None: 2 spacings); store: terrain store folder (None: the default)."""

    units: str | None = None
    up: str = "+z"
    offset: object = None
    voxel: float | None = None
    # std 3, not the common 2: at 2 the filter drops ~3 % of a clean random cloud, clustered where the
    # sampling is sparse, and the trimming turns those spots into ~0.1 m holes (measured on the test shaft)
    outliers: tuple[int, float] | None = (20, 3.0)
    reconstruction: str = "poisson"
    depth: int | None = None
    trim_quantile: float = 0.02
    max_gap: float | None = None
    faces: int = 100_000
    scanner_positions: str | None = None
    resolution: float | None = None
    tolerance: float | None = None
    store: object = None


@dataclasses.dataclass(frozen=True)
class ImportResult:
    terrain: Path
    mesh: Path
    report: report.ImportReport
    notes: tuple[str, ...]
    store: Path
    sdf_computed: bool
    keys: dict


def _mesh_keys(resolution: float) -> dict:
    """The optional MeshSpec keys this snakesim supports (module docstring)."""
    from snakesim.components.terrain.spec_models import MeshSpec

    fields, keys = MeshSpec.model_fields, {}
    if "sign" in fields:
        keys["sign"] = "winding_number"
    if "exact_band" in fields:
        keys["exact_band"] = float(f"{min(EXACT_BAND_CELLS * resolution, PADDING):.3g}")
    return keys


def _check_winding(path, v, f) -> None:
    import trimesh

    mesh = trimesh.Trimesh(v, f, process=False)
    if not mesh.is_winding_consistent:
        raise ScanError(path, "the mesh's winding is inconsistent (neighbouring faces list their shared edge in "
                              "the same direction, so their normals disagree): inside and outside are undefined; "
                              "fix the winding (e.g. trimesh.repair.fix_winding) or import the points instead")


def _cloud_surface(scan: frames.Scan, opt: ImportOptions, notes: list):
    """Cleaned points, spacing and the reconstructed (v, f), faces wound into the void."""
    pts, scanner, hint = scan.points, scan.scanner, scan.normals
    if opt.outliers is not None:
        keep = cleaning.outlier_mask(pts, *opt.outliers)
        notes.append(f"outliers: {int((~keep).sum())} removed (k {opt.outliers[0]}, std {opt.outliers[1]:g})")
        pts, scanner, hint = pts[keep], None if scanner is None else scanner[keep], None if hint is None else hint[keep]
    if opt.voxel:
        pts, scanner, hint = cleaning.voxel_downsample(pts, opt.voxel, scanner, hint)
        notes.append(f"voxel {opt.voxel * 1e3:.3g} mm: {len(pts)} points")
    if len(pts) == 0:
        raise ScanError(scan.path, "no points left after cleaning: loosen --outliers or --voxel")
    spacing = cleaning.mean_spacing(pts) if len(pts) > 1 else float("inf")
    cleaning.check_density(scan.path, pts, spacing)
    nrm, rule = normals.estimate_normals(pts, scanner, hint)
    notes.append(f"normals oriented by {rule}")
    settings = reconstruction.ReconstructionSettings(spacing, opt.depth, opt.trim_quantile, opt.max_gap)
    try:
        v, f, rec_notes = reconstruction.reconstruct(opt.reconstruction, pts, nrm, settings)
    except ValueError as e:
        raise ScanError(scan.path, str(e)) from None
    notes.append(f"reconstruction {opt.reconstruction}: " + ", ".join(rec_notes))
    if len(f) == 0:
        raise ScanError(scan.path, f"the {opt.reconstruction} reconstruction left no faces (mean spacing "
                                   f"{spacing * 1e3:.3g} mm): try the other reconstruction or a larger --max-gap")
    return pts, spacing, v, f


def _mesh_surface(scan: frames.Scan, notes: list):
    v, f = scan.points, scan.faces
    _check_winding(scan.path, v, f)
    tri = v[f]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    if np.sum(np.sign(normals.toward_axis(tri.mean(axis=1), face_n))) < 0:
        f = f[:, ::-1]
    notes.append("a mesh: faces wound towards the void by the void-axis rule")
    edges = np.linalg.norm(v[f[:, 1]] - v[f[:, 0]], axis=1)
    return v, float(np.mean(edges)), v, f


def sha256_of(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def import_scan(scan_path, out_yaml, options: ImportOptions = ImportOptions(), command: str = "") -> ImportResult:
    """Import ``scan_path`` into the terrain ``out_yaml`` (module docstring); a ScanError naming the file
    for anything wrong with the input."""
    scan_path, out_yaml = Path(scan_path), Path(out_yaml)
    if out_yaml.suffix.lower() not in (".yaml", ".yml"):
        raise ScanError(out_yaml, "the terrain file is a .yaml (its mesh is written next to it as .ply)")
    if out_yaml.with_suffix(".ply").resolve() == scan_path.resolve():
        raise ScanError(out_yaml, f"its mesh {out_yaml.with_suffix('.ply').name} would overwrite the scan itself; "
                                  "name the terrain differently")
    if options.reconstruction not in reconstruction.RECONSTRUCTORS:
        raise ScanError(scan_path, f"reconstruction '{options.reconstruction}' is not registered; valid: "
                                   f"{', '.join(reconstruction.RECONSTRUCTORS)}")
    raw = readers.read_raw(scan_path)
    scanner = None
    if options.scanner_positions is not None:
        scanner = readers.scanner_csv(options.scanner_positions, raw)
    scan = frames.to_terrain_frame(raw, options.units, options.up, options.offset, scanner)
    notes = list(scan.notes)
    if scan.is_mesh:
        pts, spacing, v, f = _mesh_surface(scan, notes)
    else:
        pts, spacing, v, f = _cloud_surface(scan, options, notes)
    n_before = len(f)
    v, f = decimate(v, f, options.faces)
    if len(f) < n_before:
        notes.append(f"decimated {n_before} → {len(f)} faces")
    band = max(3 * spacing, 0.02 * float(np.ptp(pts @ normals.principal_axis(pts)[1])))
    found = holes.find_holes(v, f, pts, band)
    rep = report.make_report(v, f, pts, spacing, found, options.tolerance, notes)
    resolution = options.resolution or default_resolution(v)
    keys = _mesh_keys(resolution)
    provenance = _provenance(scan_path, scan, command, rep, keys)
    # faces turned to face the ice: the void is the mesh's inside (terrain_file.py)
    terrain, mesh_path = write_terrain(out_yaml, v, f[:, ::-1], f"imported scan {scan_path.name}", resolution,
                                       provenance, keys)
    from snakesim.components.terrain import mesh as mesh_terrain
    from snakesim.components.terrain import store as terrain_store
    from snakesim.components.terrain.spec import load_terrain

    computed = mesh_terrain.compute_count
    load_terrain(str(terrain), store=options.store)
    return ImportResult(terrain, mesh_path, rep, tuple(notes), terrain_store.store_dir(options.store),
                        mesh_terrain.compute_count > computed, keys)


def _provenance(scan_path: Path, scan: frames.Scan, command: str, rep: report.ImportReport, keys: dict) -> list[str]:
    lines = [f"Imported scan {scan_path.name} (snakesim terrain import; docs/scan.md)",
             f"command: {command or '(Python: snakesim.components.scan.import_scan)'}",
             f"input: {scan_path.name} sha256 {sha256_of(scan_path)}",
             "frame: " + "; ".join(scan.notes),
             "steps: " + "; ".join(rep.notes[len(scan.notes):]),
             "report:"]
    lines += [f"  {line}" for line in rep.summary_lines()]
    if not keys:
        lines.append("sign: pseudonormal (this snakesim's mesh terrain has no winding-number sign)")
    return lines
