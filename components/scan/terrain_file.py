"""The files an import writes: the mesh (``<stem>.ply``, binary) next to the terrain YAML, and the YAML
(``kind: mesh``) with a provenance comment block.

Frame and sign: the mesh is written with its faces' normals pointing **into the ice**, away from the
scanned void, so the void is the mesh's inside and ``inside: free`` makes it free space (> 0), the same
convention as a closed tunnel mesh. ``open_surface: true``: a scan is open (a shaft's mouth and bottom,
holes), so the sign comes from the surface near a point (pseudonormals, or the generalised winding
number where the mesh terrain offers ``sign: winding_number``) and is only meaningful near the wall.
Materials: the screws' ice bite of the moulin terrains (terrains/moulin-slot.yaml, mu 1.5) on the one
region a mesh terrain has, ``surface``.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from snakesim.framework.output_files import make_dir, write_file

MATERIAL = "{name: ice-bite, k: 1.0e5, c: 1.0e3, mu: 1.5}"
PADDING = 0.1


def mesh_bytes(v: np.ndarray, f: np.ndarray) -> bytes:
    """A binary little-endian PLY of the mesh (trimesh's writer, no processing)."""
    import trimesh

    buf = io.BytesIO()
    trimesh.Trimesh(v, f, process=False).export(buf, file_type="ply", encoding="binary")
    return buf.getvalue()


def default_resolution(v: np.ndarray) -> float:
    """SDF grid spacing: the padded box's longest side over 128 cells, at least 5 mm (2 significant digits)."""
    ext = float(np.ptp(v, axis=0).max()) + 2 * PADDING
    return float(f"{max(ext / 128, 0.005):.2g}")


def terrain_yaml(mesh_name: str, description: str, resolution: float, provenance: list[str],
                 extra_keys: dict | None = None) -> str:
    """The terrain file's text: provenance comments, then the mesh terrain's keys."""
    lines = [f"# {line}".rstrip() for line in provenance]
    lines += ["kind: mesh",
              f"description: {json.dumps(description)}",      # a JSON string is a YAML string, quoted
              f"file: {json.dumps(mesh_name)}",
              f"resolution: {resolution:g}",
              f"padding: {PADDING:g}",
              "inside: free            # faces face the ice: the scanned void is the mesh's inside, free space",
              "open_surface: true      # a scan is open (ends, holes): signed near the wall only"]
    for key, value in (extra_keys or {}).items():
        lines.append(f"{key}: {value}")
    lines += ["materials:",
              f"  - {MATERIAL}   # the screws' bite, as terrains/moulin-slot.yaml",
              "regions: {surface: ice-bite}", ""]
    return "\n".join(lines)


def write_terrain(out_yaml: Path, v: np.ndarray, f: np.ndarray, description: str, resolution: float,
                  provenance: list[str], extra_keys: dict | None = None) -> tuple[Path, Path]:
    """Write ``<stem>.ply`` and ``out_yaml`` (whole or not at all, each); returns both paths."""
    out_yaml = Path(out_yaml)
    mesh_path = out_yaml.with_suffix(".ply")
    make_dir(out_yaml.parent)
    write_file(mesh_path, mesh_bytes(v, f))
    write_file(out_yaml, terrain_yaml(mesh_path.name, description, resolution, provenance, extra_keys))
    return out_yaml, mesh_path
