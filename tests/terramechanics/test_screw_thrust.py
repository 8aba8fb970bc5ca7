"""A screw's axial thrust at a given slip against an independent integration of Janosi–Hanamoto shear
along its helix (the textbook formula, numpy only); the kernel's declared Jacobian against central
differences of its own wrench; and the contact's check of the terrain's cell.

The reference: a horizontal screw (axis +x, radius r, length L, lead angle λ, right hand) pressed p below
a virgin soil, its centre moving at v_a along the axis and spinning at ω. On its envelope at the angle θ
from the bottom (y = r sin θ across the footprint) the surface moves at v = v_a x̂ + ω r ê_θ; across the
thread (ê_x = cos λ x̂ − sin λ ê_θ) it moves at v_x = v_a cos λ − ω r sin λ, along it (ê_h = sin λ x̂ +
cos λ ê_θ) at v_h = v_a sin λ + ω r cos λ. A soil element met by the thread at the patch's upstream edge
θ = −θ0 has been sheared, after the helix path ℓ = r (θ + θ0) / cos λ, by j = |v_x| ℓ / |v_h| (Wong's
j = i x along a track, here along the helix). Bekker–Wong pressure σ = (k_c / b + k_φ) zⁿ (capped by the
elastic trial K_e z, SCM's unloading law) at the depth z of the envelope, b the smaller of the patch's
chord and L; τ_max = c + σ tan φ; τ = τ_max (1 − e^(−j/K)) opposing v_x across the thread; along the thread
the skin's share τ_h = ρ τ_max (1 − e^(−ℓ/K)) opposing v_h. Thrust: the x component of the shear over the
footprint's horizontal area (the soil's nodes carry horizontal cells, as in SCM):

    T = ∫∫ (−sgn(v_x) τ cos λ − τ_h sin λ) dx dy.

The kernel sums the same over the terrain's nodes; the difference is the footprint's border: at most the
cells a one-cell-wide band round the footprint holds, a fraction perimeter·Δ / area of the total.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from snakesim.components.terrain.deformable import DeformableTerrain, SoilSpec
from snakesim.components.terramechanics.contact import NO_LOG
from snakesim.components.terramechanics.kernels import (SCRATCH_COLUMNS, SINKAGE, SLIP, THRUST, scratch_rows,
                                                        screw_soil)

SNOW = SoilSpec(k_c=4.37e3, k_phi=196.72e3, n=1.6, cohesion=1.03e3, friction_angle=19.7, janosi_k=0.025,
                elastic_k=5.0e5)
R, L, LEAD = 0.09, 0.3, math.radians(20.0)       # m, m, rad: a screw of EELS 1.0's size
PEN = 0.03                                        # m, the envelope's bottom below the virgin surface
OMEGA = 3.0                                       # rad/s
RATIO = 0.5                                       # helix_shear_ratio
CELL = 0.002                                      # m: 150 × 134 nodes under the screw


def reference_thrust(slip, soil=SNOW, n=801):
    """T (N) by the module docstring's double integral (midpoint rule over y, exact over x: the integrand
    does not vary along the axis), ∫∫ |integrand| (N, the scale of the quadrature error) and the chord."""
    v_ideal = OMEGA * R * math.tan(LEAD)
    v_a = (1.0 - slip) * v_ideal
    vx = v_a * math.cos(LEAD) - OMEGA * R * math.sin(LEAD)
    vh = v_a * math.sin(LEAD) + OMEGA * R * math.cos(LEAD)
    theta0 = math.acos(1.0 - PEN / R)
    chord = 2.0 * R * math.sin(theta0)
    b = min(chord, L)
    y = (np.arange(n) + 0.5) / n * chord - 0.5 * chord
    theta = np.arcsin(y / R)
    z = PEN - R * (1.0 - np.cos(theta))                       # depth of the envelope below the surface
    sigma = np.minimum(soil.elastic_k * z, (soil.k_c / b + soil.k_phi) * z ** soil.n)
    # the thread enters the patch at the edge it moves away from: v_h > 0 moves it towards +θ
    ell = R * (theta + theta0 if vh >= 0 else theta0 - theta) / math.cos(LEAD)
    j = abs(vx) * ell / abs(vh)
    tau_max = soil.cohesion + sigma * math.tan(math.radians(soil.friction_angle))
    tau = tau_max * (1.0 - np.exp(-j / soil.janosi_k))
    tau_h = RATIO * tau_max * (1.0 - np.exp(-ell / soil.janosi_k)) * np.sign(vh)
    per_y = -np.sign(vx) * tau * math.cos(LEAD) - tau_h * math.sin(LEAD)      # N/m² of footprint
    return float(per_y.sum() * (chord / n) * L), float(np.abs(per_y).sum() * (chord / n) * L), chord


def soil_call(vels, soil=SNOW, cell=CELL, v_eps=1e-9, poses=None, terrain=None):
    """The contact kernel for the docstring's screw (link 0, its own spin's parent) on a terrain of ``cell``
    nodes (or ``terrain``): (wrenches, per_screw, d_twist, d_pose)."""
    t = terrain or DeformableTerrain(0.0, (-1.0, -1.0), (2.0, 2.0), cell, soil, max_tiles=1)
    rows = np.array([[0, 0, 0]], dtype=np.int64)
    geo = np.array([[R, L, LEAD, 1.0, 1.0]])
    mount_R, mount_p = np.eye(3)[None].copy(), np.zeros((1, 3))
    if poses is None:
        poses = np.array([[0.0, 0.0, R - PEN, 0.0, 0.0, 0.0, 1.0]])
    st = t.state
    scratch = np.zeros((scratch_rows(np.array([R]), np.array([L]), cell), SCRATCH_COLUMNS))
    wrenches, per_screw, totals = np.zeros((1, 6)), np.zeros((1, 5)), np.zeros(2)
    d_twist, d_pose, on = np.zeros((1, 6, 6)), np.zeros((1, 6, 6)), np.zeros(1, dtype=np.bool_)
    screw_soil(t.grid, t.base_z, t.soil, st.tile_of, st.plastic, st.yield_p, st.lift, st.used, rows, geo, mount_R,
               mount_p, poses, np.asarray(vels, dtype=float), np.array([OMEGA]), RATIO, v_eps, False, *NO_LOG, scratch,
               wrenches, per_screw, totals, True, d_twist, d_pose, on)
    return wrenches[0], per_screw[0], d_twist[0], d_pose[0]


def kernel_thrust(slip, soil=SNOW, cell=CELL):
    """The contact kernel's (thrust, slip, sinkage, f_x) for the same screw on a terrain of ``cell`` nodes."""
    v_ideal = OMEGA * R * math.tan(LEAD)
    w, per_screw, _, _ = soil_call(np.array([[(1.0 - slip) * v_ideal, 0.0, 0.0, 0.0, 0.0, 0.0]]), soil, cell)
    return per_screw[THRUST], per_screw[SLIP], per_screw[SINKAGE], w[0]


@pytest.mark.parametrize("slip", [-0.3, 0.05, 0.2, 0.5, 0.9])
def test_screw_thrust_equals_janosi_integrated_along_the_helix(slip):
    ref, scale, chord = reference_thrust(slip)
    thrust, s, sink, fx = kernel_thrust(slip)
    assert s == pytest.approx(slip, abs=1e-12)
    assert thrust == fx                                        # axis +x: the thrust is the force's x
    assert sink == pytest.approx(PEN, abs=CELL * CELL / R)     # the deepest node: within the grid's sag
    # the footprint's border band (one cell wide round chord × L) bounds the sum's quadrature error, a
    # fraction of the integrand's magnitude (not of T: the skin's drag and the thread's shear cancel near
    # slip 0.2)
    border = 2.0 * (chord + L) * CELL / (chord * L)
    assert abs(thrust - ref) <= border * scale
    # a driven screw (slip > 0) pushes forward, a braked one (slip < 0) is held back; at small slip the
    # skin's drag along the thread (−τ_h sin λ) outweighs the barely developed shear across it
    if abs(slip) >= 0.2:
        assert math.copysign(1.0, ref) == math.copysign(1.0, slip)


def test_thrust_grows_with_slip_to_the_mohr_coulomb_limit():
    """At full slip the shear across the thread saturates: the thrust tends to Σ τ_max cos λ A less the
    skin's drag, and is monotone in slip on the way."""
    thrusts = [kernel_thrust(s)[0] for s in (0.1, 0.3, 0.6, 0.99)]
    assert all(a < b for a, b in zip(thrusts, thrusts[1:]))
    ref_full, scale, chord = reference_thrust(0.999999)
    assert thrusts[-1] < ref_full + 2.0 * (chord + L) * CELL / (chord * L) * scale


def test_cell_larger_than_a_screw_names_file_and_key(tmp_path):
    from snakesim.framework.errors import SnakesimError
    from snakesim.framework.session import load_session

    text = (Path(__file__).parents[2] / "terrains" / "snow-field.yaml").read_text()
    assert "cell: 0.02" in text
    path = tmp_path / "coarse-snow.yaml"
    path.write_text(text.replace("cell: 0.02", "cell: 0.25"))
    s = load_session("snow-screw-traverse", overrides=[f"terrain={path}", "robot.modules=2"],
                     sim_overrides={"duration": 0.02})
    with pytest.raises(SnakesimError) as e:
        s.run()
    msg = str(e.value)
    assert "coarse-snow.yaml" in msg and "cell" in msg and "0.25" in msg


@pytest.mark.parametrize("slip,v_eps", [(0.3, 0.01), (1.0, 0.01), (-0.5, 0.05)])
def test_jacobian_blocks_match_finite_differences(slip, v_eps):
    """The declared ∂W/∂V (a twist of the screw's link, here also its spin's parent: the kernel adds the
    spin ω â × r) against central differences of the kernel's wrench, on a coarse grid (the contact set
    does not change under the small perturbation); and ∂W_z/∂z, the normal stiffness, likewise."""
    v_ideal = OMEGA * R * math.tan(LEAD)
    V = np.array([(1.0 - slip) * v_ideal, 0.004, -0.002, 0.01, -0.02, 0.03])
    w0, _, d_twist, d_pose = soil_call(V[None], cell=0.01, v_eps=v_eps)
    h = 1e-7
    fd = np.empty((6, 6))
    for k in range(6):
        dv = np.zeros(6)
        dv[k] = h
        fd[:, k] = (soil_call((V + dv)[None], cell=0.01, v_eps=v_eps)[0]
                    - soil_call((V - dv)[None], cell=0.01, v_eps=v_eps)[0]) / (2 * h)
    assert np.abs(d_twist - fd).max() <= 1e-5 * np.abs(fd).max()
    # height: a move too small to change the node set. The declaration leaves out that the patch's b and
    # the helix path ℓ follow the depth (kernels.py): with σ ∝ k_c / b + k_φ, b the chord ∝ √pen, their
    # share is (k_c / b) / (k_c / b + k_φ) / 2 / n ≈ 4 % of the pressure's slope here, hence 5 %
    dz = 1e-8
    up = np.array([[0.0, 0.0, R - PEN + dz, 0.0, 0.0, 0.0, 1.0]])
    dn = np.array([[0.0, 0.0, R - PEN - dz, 0.0, 0.0, 0.0, 1.0]])
    fdz = (soil_call(V[None], cell=0.01, v_eps=v_eps, poses=up)[0]
           - soil_call(V[None], cell=0.01, v_eps=v_eps, poses=dn)[0]) / (2 * dz)
    assert d_pose[2, 2] == pytest.approx(fdz[2], rel=5e-2)
    assert d_pose[2, 2] < 0.0 and w0[2] > 0.0          # the soil pushes up, less as the screw rises
