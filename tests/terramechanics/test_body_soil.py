"""Body links on the soil (soil_body_contact, body_kernels.py) against an independent integration, and the
Mini EELS sand scene at its own settings.

Reference: a horizontal cylinder (radius r, length L, axis +x) pressed p into virgin soil, sliding along its
axis at v ≫ v_ε. Across the footprint (y = r sin θ, the chord 2 r sin θ0, cos θ0 = 1 − p/r) the depth is
z(y) = p − r (1 − cos θ); σ = min(K_e z, (k_c/b + k_φ) zⁿ), b = min(chord, L); the soil under a point x of
the footprint has been sheared by the path since the leading edge (x_lead = +L/2 for a body moving +x), so
j = x_lead − x, τ = (c + σ tan φ)(1 − e^(−j/K)) against the motion:

    F_z = ∫∫ σ dx dy,     F_x = −∫∫ τ dx dy.

The kernel sums over the nodes; its difference is the footprint's border, one cell wide, at most a fraction
perimeter·Δ / area of ∫∫ |integrand| (as test_screw_thrust.py), plus the half cell its j starts at (Δ/2).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from snakesim.components.terrain.deformable import DeformableTerrain
from snakesim.components.terramechanics.body_kernels import L_NODES, L_NORMAL, L_SINKAGE, body_soil
from snakesim.components.terramechanics.contact import NO_LOG
from snakesim.components.terramechanics.kernels import SCRATCH_COLUMNS, scratch_rows

from test_rigid_wheel import SAND

R, L, PEN, CELL = 0.03, 0.12, 0.006, 0.001


def reference(n=2001):
    th0 = math.acos(1.0 - PEN / R)
    chord = 2.0 * R * math.sin(th0)
    b = min(chord, L)
    y = (np.arange(n) + 0.5) / n * chord - 0.5 * chord
    z = PEN - R + np.sqrt(R * R - y * y)
    sigma = np.minimum(SAND.elastic_k * z, (SAND.k_c / b + SAND.k_phi) * z ** SAND.n)
    tau_max = SAND.cohesion + sigma * math.tan(math.radians(SAND.friction_angle))
    # ∫ (1 − e^(−(L/2 − x)/K)) dx over −L/2 … L/2 = L − K (1 − e^(−L/K))
    k = SAND.janosi_k
    along = L - k * (1.0 - math.exp(-L / k))
    dy = chord / n
    return float(sigma.sum() * dy * L), float(-(tau_max * dy).sum() * along), float((tau_max * dy).sum() * L), chord


def kernel(across=1.0, v=(0.5, 0.0, 0.0), yaw=0.0, soil=SAND, cell=CELL, v_eps=1e-6, pose=None, blocks=False,
           terrain=None, walls=(0.0, 0.0), commit=False):
    t = terrain or DeformableTerrain(0.0, (-0.5, -0.5), (1.0, 1.0), cell, soil, max_tiles=64)
    st = t.state
    # the cylinder along the link's x: its frame's z axis (the URDF cylinder's) turned onto x
    piece_R = np.array([[[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]])
    q = np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])
    poses = np.array([[0.0003, -0.0004, R - PEN, *q]]) if pose is None else np.asarray(pose, float)[None]
    vels = np.array([[*v, 0.0, 0.0, 0.0]]) if len(v) == 3 else np.asarray(v, float)[None]
    scratch = np.zeros((scratch_rows(np.array([R]), np.array([L]), cell), SCRATCH_COLUMNS))
    w, per_link, totals = np.zeros((1, 6)), np.zeros((1, 3)), np.zeros(2)
    d_twist, d_pose, on = np.zeros((1, 6, 6)), np.zeros((1, 6, 6)), np.zeros(1, dtype=np.bool_)
    body_soil(t.grid, t.base_z, t.soil, st.tile_of, st.plastic, st.yield_p, st.lift, st.used, np.array([0]),
              np.array([[R, L, 1.0, across]]), piece_R, np.zeros((1, 3)), poses, vels, v_eps, np.asarray(walls, float),
              commit, *NO_LOG, scratch, w, per_link, totals, blocks, d_twist, d_pose, on)
    return (w[0], per_link[0], d_twist[0], d_pose[0]) if blocks else (w[0], per_link[0])


def test_a_sliding_cylinder_carries_bekkers_load_and_drags_janosis_shear():
    fz, fx, scale, chord = reference()
    w, per_link = kernel()
    border = 2.0 * (chord + L) * CELL / (chord * L)
    assert abs(w[2] - fz) <= border * fz
    assert per_link[L_NORMAL] == w[2] and per_link[L_NODES] > 0
    assert per_link[L_SINKAGE] == pytest.approx(PEN, abs=CELL * CELL / R)
    # j starts half a cell in: the shear's sum is off by at most that much path, (Δ/2)/K of the border's scale
    assert abs(w[0] - fx) <= (border + 0.5 * CELL / SAND.janosi_k) * scale
    assert abs(w[1]) < 1e-9 * abs(w[0])                    # no sideways force from a slide along the axis


def test_across_factor_scales_the_sideways_shear_only():
    w_side, _ = kernel(across=3.0, v=(0.0, 0.5, 0.0))
    w_side1, _ = kernel(across=1.0, v=(0.0, 0.5, 0.0))
    w_along, _ = kernel(across=3.0)
    w_along1, _ = kernel(across=1.0)
    assert w_side[1] == pytest.approx(3.0 * w_side1[1], rel=1e-12) and w_side1[1] < 0.0
    assert w_along[0] == w_along1[0]
    assert w_side[2] == w_along[2]                         # the pressure does not depend on the slip


WALLS = (1600.0 * 9.81, math.tan(math.radians(45.0 + 28.0 / 2.0)) ** 2)     # γ N/m³, K_p for SAND's φ = 28°


@pytest.mark.parametrize("v_eps, walls", [(0.01, (0.0, 0.0)), (1e-3, (0.0, 0.0)), (0.01, WALLS)])
def test_jacobian_blocks_match_finite_differences(v_eps, walls):
    """The declared ∂W/∂V against central differences of the kernel's wrench (a coarse grid: the node set
    does not change under the perturbation), with K tiny so that the shear is saturated and j's dependence
    on the sliding direction (left out of the declaration) does not show, with and without the rut walls;
    and ∂W/∂(displacement, rotation)."""
    from snakesim.components.terrain.deformable import SoilSpec

    soil = SoilSpec(**{**SAND.model_dump(), "janosi_k": 1e-9, "damping": 3e4})
    V = np.array([0.004, -0.003, 0.001, 0.02, -0.01, 0.05])          # near rest: the stiff regime
    pose = np.array([0.0003, -0.0004, R - PEN, 0.0, 0.0, 0.0, 1.0])
    args = dict(across=2.5, soil=soil, cell=0.004, v_eps=v_eps, pose=pose, walls=walls)
    w0, _, d_twist, d_pose = kernel(v=V, blocks=True, **args)
    h = 1e-8
    fd = np.empty((6, 6))
    for k in range(6):
        dv = np.zeros(6)
        dv[k] = h
        fd[:, k] = (kernel(v=V + dv, **args)[0] - kernel(v=V - dv, **args)[0]) / (2 * h)
    assert np.abs(d_twist - fd).max() <= 1e-5 * np.abs(fd).max()
    # pose: δp of the origin, then δθ (world axes; exp(δθ) ⊗ q for q = identity). Declared: the height
    # column and the tilt about y (the axis is x), each within 5 % of its scale (b following the depth:
    # k_c / b, a few % for sand's small k_c). Left out: a horizontal shift and the roll about the axis (the
    # node set, the lever arms turning: ∝ |ω| × the shear's slope, 0 at rest)
    dz = 1e-9
    fdp = np.empty((6, 2))
    for c, k in enumerate((2, 4)):
        up, dn = pose.copy(), pose.copy()
        if k < 3:
            up[k] += dz
            dn[k] -= dz
        else:
            for sign, p in ((1.0, up), (-1.0, dn)):
                p[3:] = 0.0
                p[k], p[6] = math.sin(0.5 * sign * dz), math.cos(0.5 * sign * dz)
        fdp[:, c] = (kernel(v=V, **{**args, "pose": up})[0] - kernel(v=V, **{**args, "pose": dn})[0]) / (2 * dz)
    assert np.all(np.abs(d_pose[:, [2, 4]] - fdp).max(axis=0) <= 5e-2 * np.abs(fdp).max(axis=0))
    assert d_pose[2, 2] == pytest.approx(fdp[2, 0], rel=5e-2)
    assert d_pose[2, 2] < 0.0 and w0[2] > 0.0


@pytest.mark.parametrize("k_c", [0.0, SAND.k_c])
def test_height_slope_after_a_commit_is_the_load_the_node_follows(k_c):
    """A tick's commit leaves each pressed node at its yield memory σ_y: σ(s) has a kink there, Bekker's
    (18× softer than K_e on SAND) for a further load. The declared ∂F_z/∂z is Bekker's slope, what a step
    sinking further sees: the kernel's own secant over 1 mm, within 2 % (Bekker's curvature, n = 1.1: 1.4 %;
    with k_c, b's growth with the depth, left out, takes 0.5 % off), not K_e (what made rosenbrock_w hold a
    sinking link as on rock). (While b came from the depth below the fresh rut, it shrank at each commit and
    σ_B rose by k_c / b: an elastic stretch of ~10 µm before Bekker's.) A node raised below its yield memory is
    elastic: the declaration is the exact derivative there."""
    from snakesim.components.terrain.deformable import SoilSpec

    soil = SoilSpec(**{**SAND.model_dump(), "k_c": k_c})
    t = DeformableTerrain(0.0, (-0.5, -0.5), (1.0, 1.0), 0.004, soil, max_tiles=64)
    pose = np.array([0.0003, -0.0004, R - PEN, 0.0, 0.0, 0.0, 1.0])
    args = dict(v=(0.01, 0.0, -0.005), soil=soil, cell=0.004, v_eps=0.01, terrain=t)
    kernel(pose=pose, commit=True, **args)
    w0, per_link, _, d_pose = kernel(pose=pose, blocks=True, **args)
    dz = 1e-3
    deeper = pose.copy()
    deeper[2] -= dz
    secant = (w0[2] - kernel(pose=deeper, **args)[0][2]) / dz
    assert d_pose[2, 2] == pytest.approx(secant, rel=2e-2)
    elastic = -soil.elastic_k * 0.004 ** 2 * per_link[L_NODES]        # K_e A over every loaded node
    assert abs(elastic) > 10.0 * abs(d_pose[2, 2])
    raised = pose.copy()
    raised[2] += 1e-4                                                 # unloading: σ < σ_y at every node
    _, _, _, d_raised = kernel(pose=raised, blocks=True, **args)
    h = 1e-8
    up, dn = raised.copy(), raised.copy()
    up[2] += h
    dn[2] -= h
    fdz = (kernel(pose=up, **args)[0][2] - kernel(pose=dn, **args)[0][2]) / (2 * h)
    assert d_raised[2, 2] == pytest.approx(fdz, rel=1e-6)


def test_mini_eels_on_sand_carries_its_weight_and_leaves_a_rut(tmp_path):
    from snakesim.framework.session import load_session

    s = load_session("mini-eels-sand-crawl", sim_overrides={"duration": 1.0})
    result = s.run(out_dir=tmp_path / "run")
    assert result.summary["outcome"] == "success"
    model = s.plan.components["robot"].dyn.model
    weight = sum(inertia.mass for inertia in model.inertias) * 9.81
    t = result["t"]
    fn = result["contact.normal_force"][:, 0]
    # the gait's vertical accelerations are small: the soil carries the weight within 10 % once settled
    assert np.abs(fn[t > 0.3].mean() / weight - 1.0) < 0.1
    rep = result.summary["reports"]["contact"]
    assert 0.0 < rep["rut"]["max_rut_depth_m"] <= rep["max_sinkage_m"] < 0.028     # sunk, not buried
    assert result.summary["files"]["contact"] == ["soil_state.npz", "rut.png"]


def test_two_runs_are_bit_identical_and_a_run_starts_on_a_saved_soil(tmp_path):
    from snakesim.framework.session import load_session

    runs = []
    for k in range(2):
        s = load_session("mini-eels-sand-crawl", sim_overrides={"duration": 0.4})
        r = s.run(out_dir=tmp_path / f"run{k}")
        runs.append((r["robot.com"].copy(), s.plan.caches["contact"].terrain.snapshot()))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert all(np.array_equal(runs[0][1][key], runs[1][1][key]) for key in runs[0][1])
    # a terrain file naming the first run's soil_state.npz: the next run starts on its rut
    from pathlib import Path

    text = (Path(__file__).parents[2] / "terrains" / "sand-field.yaml").read_text()
    (tmp_path / "sand-after.yaml").write_text(text + "initial_state: run0/soil_state.npz\n")
    s = load_session("mini-eels-sand-crawl", overrides=[f"terrain={tmp_path / 'sand-after.yaml'}"],
                     sim_overrides={"duration": 0.02})
    s.run()
    start = s.plan.caches["contact"].terrain.snapshot()
    saved = runs[0][1]
    on = saved["plastic"] > 0.0
    # the saved rut is there (one more tick of loading can only deepen it)
    assert np.all(start["plastic"][: saved["plastic"].shape[0]][on] >= saved["plastic"][on])
