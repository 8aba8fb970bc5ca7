"""The shipped scanned moulin (terrains/moulin-slot-scan.yaml, imported from terrains/scans/moulin-slot-scan.laz)
against the shape it was scanned from (terrains/moulin-slot.yaml, an analytic slot with exact distance).

Where the robot braces (x 0..2.4 m, z −6..−2.5 m) the scan has ~1.4 cm point spacing and 3 mm range noise;
screened Poisson averages the noise over its ~2-spacing cells, so the surface should lie well inside the
noise: RMS < σ/2 = 1.5 mm and every vertex within 4σ = 12 mm. The terrain's signed distance (exact within
its band, winding-number sign) then equals the truth's to the same reconstruction error, with the same sign
wherever the truth is farther from the wall than that error.
"""

from __future__ import annotations

import numpy as np
import pytest

from snakesim.components.terrain.spec import load_terrain

pytestmark = pytest.mark.slow    # a cold terrain store computes the scan's SDF grid (~15 s)

SIGMA = 0.003    # m, the scan's range noise (terrains/scans/moulin-slot-scan.md)


@pytest.fixture(scope="module")
def terrains():
    return load_terrain("moulin-slot-scan"), load_terrain("moulin-slot")


def _brace_region(rng, n, margin):
    return np.column_stack([rng.uniform(0.0, 2.4, n), rng.uniform(-0.172 - margin, 0.172 + margin, n),
                            rng.uniform(-6.0, -2.5, n)])


def test_reconstructed_walls_lie_inside_the_scan_noise(terrains):
    import trimesh

    scan, truth = terrains
    mesh = trimesh.load(scan.source, process=False)
    v = np.asarray(mesh.vertices)
    box = (v[:, 0] > 0.0) & (v[:, 0] < 2.4) & (v[:, 2] > -6.0) & (v[:, 2] < -2.5)
    assert box.sum() > 5000, "the brace region of the scan was not reconstructed"
    d = truth.query(v[box]).distance
    assert np.sqrt(np.mean(d ** 2)) < SIGMA / 2
    assert np.abs(d).max() < 4 * SIGMA


def test_signed_distance_matches_the_truth_on_both_sides(terrains):
    scan, truth = terrains
    p = _brace_region(np.random.default_rng(7), 4000, margin=0.08)
    a, b = scan.query(p).distance, truth.query(p).distance
    near = np.abs(b) < 0.05          # within the exact band (0.06 m) of the wall
    assert near.sum() > 300
    assert np.sqrt(np.mean((a - b)[near] ** 2)) < SIGMA / 2
    clear = np.abs(b) > 4 * SIGMA    # clear of the reconstruction error: the sign must agree
    assert np.all(np.sign(a[clear]) == np.sign(b[clear]))
    assert (b[clear] < 0).sum() > 100 and (b[clear] > 0).sum() > 100   # both sides sampled
