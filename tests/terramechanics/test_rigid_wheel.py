"""A rigid wheel at a given slip on a Bekker–Wong soil against Wong's analytic integration (the
terramechanics textbook check; Wong, Theory of Ground Vehicles, ch. 2; Wong & Reece 1967), computed here
independently with scipy.integrate.quad.

Reference (θ from the bottom, positive ahead; entry θ1, rear θ2 = 0, peak θm = (c1 + c2 i) θ1):
    σ(θ) = min(K_e z, (k_c/b + k_φ) zⁿ),  z = r (cos θ − cos θ1)                         θm ≤ θ ≤ θ1
    σ(θ) = σ at θ1 − (θ/θm)(θ1 − θm)                                                      0 ≤ θ < θm
    j(θ) = r [(θ1 − θ) − (1 − i)(sin θ1 − sin θ)],  τ = (c + σ tan φ)(1 − e^(−j/K))
    W = r b ∫ (σ cos θ + τ sin θ) dθ,  DP = r b ∫ (τ cos θ − σ sin θ) dθ,  T = r² b ∫ τ dθ.

The kernel samples these at the terrain's nodes: in x = r sin θ each node stands for its cell of width Δ
(its y-weight makes the width exact), so the difference is the cell-centred rule's error on f(x), the
integrand per unit length along the heading: per cell Δ · TV_cell(f) where f jumps (the rear's shear at
x = 0), Δ²/4 · TV_cell(f') elsewhere (Wong.grid_bounds). That is the tolerance, computed from the reference
at the test's node lattice; a 1 % change of the slip moves the load by ~7× it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from snakesim.components.terrain.deformable import DeformableTerrain, SoilSpec
from snakesim.components.terramechanics.wheel import RigidWheel, wheel_forces

# Wong's dry sand (Land Locomotion Lab., Theory of Ground Vehicles table 2.3; terrains/sand-field.yaml)
SAND = SoilSpec(k_c=0.99e3, k_phi=1528.43e3, n=1.1, cohesion=1.04e3, friction_angle=28.0, janosi_k=0.01,
                elastic_k=2.0e7)
WHEEL = RigidWheel(radius=0.3, width=0.15)
CELL = 0.002
CX, CY = 0.0037, -0.0113          # off the node lattice on purpose
LOAD = 500.0                     # N


def terrain():
    return DeformableTerrain(0.0, (-1.0, -1.0), (2.0, 2.0), CELL, SAND, max_tiles=64)


class Wong:
    """The reference integrals for a sinkage z0 (m) and slip i."""

    def __init__(self, z0, slip, soil=SAND, w=WHEEL):
        self.r, self.s, self.i = w.radius, soil, slip
        self.th1 = math.acos(1.0 - z0 / self.r)
        self.thm = (w.c1 + w.c2 * slip) * self.th1
        self.width = w.width
        self.b = min(w.width, 2.0 * self.r * math.sin(self.th1))
        self.k = soil.k_c / self.b + soil.k_phi
        self.tan_phi = math.tan(math.radians(soil.friction_angle))

    def sigma(self, th):
        th = np.where(th < self.thm, self.th1 - th / self.thm * (self.th1 - self.thm), th)
        z = np.maximum(0.0, self.r * (np.cos(th) - math.cos(self.th1)))
        return np.minimum(self.s.elastic_k * z, self.k * z ** self.s.n)

    def tau(self, th):
        j = self.r * ((self.th1 - th) - (1.0 - self.i) * (math.sin(self.th1) - np.sin(th)))
        return (self.s.cohesion + self.sigma(th) * self.tan_phi) * (1.0 - np.exp(-j / self.s.janosi_k))

    def integrands(self, th):
        """(W, DP, T) per dθ."""
        sg, ta, rb = self.sigma(th), self.tau(th), self.r * self.width
        return np.array([rb * (sg * np.cos(th) + ta * np.sin(th)), rb * (ta * np.cos(th) - sg * np.sin(th)),
                         rb * self.r * ta])

    def integrals(self):
        return [quad(lambda t, k=k: float(self.integrands(t)[k]), 0.0, self.th1, points=[self.thm], epsabs=1e-10,
                     epsrel=1e-12, limit=200)[0] for k in range(3)]

    def grid_bounds(self, cell, along0):
        """Bound on |node sum − integral| for (W, DP, T). f(x) = integrand / (r cos θ) per unit length
        along the heading (0 outside 0 ≤ x ≤ r sin θ1); the node k at x_k = along0 + kΔ stands for its cell
        [x_k ± Δ/2]. A cell's error ∫ (f(x_k) − f(x)) dx is at most Δ · TV_cell(f) (any f), and where f is
        continuous in the cell, since ∫ (x − x_k) dx = 0, at most Δ²/4 · TV_cell(f') (f(x) − f(x_k) −
        f'(x_k)(x − x_k) = ∫ (f' − f'(x_k))). f jumps only at x = 0 (the rear's shear): that cell takes
        the first bound. TVs on 400 samples a cell (a sampled TV is a lower estimate: × 1.25)."""
        x1 = self.r * math.sin(self.th1)
        k0 = math.floor((-0.5 * cell - along0) / cell)
        k1 = math.ceil((x1 + 0.5 * cell - along0) / cell)
        total = np.zeros(3)
        for k in range(k0, k1 + 1):
            xk = along0 + k * cell
            x = np.linspace(xk - 0.5 * cell, xk + 0.5 * cell, 401)
            inside = (x >= 0.0) & (x <= x1)
            th = np.arcsin(np.clip(x, 0.0, x1) / self.r)
            f = np.where(inside, self.integrands(th) / (self.r * np.cos(th)), 0.0)
            if x[0] < 0.0 <= x[-1]:
                total += cell * np.abs(np.diff(f, axis=1)).sum(axis=1)
            else:
                df = np.diff(f, axis=1) / (x[1] - x[0])
                total += 0.25 * cell * cell * np.abs(np.diff(df, axis=1)).sum(axis=1)
        return 1.25 * total


ALONG0 = -1.0 + CELL * math.ceil((CX + 1.0 - 0.5 * CELL) / CELL) - CX     # a node's x − CX (the lattice's phase)


def kernel(t, z0, slip, commit=False):
    return wheel_forces(t, WHEEL, (CX, CY, WHEEL.radius - z0), 0.0, slip, commit=commit)


@pytest.mark.parametrize("slip", [0.1, 0.3, 0.6])
def test_prescribed_sinkage_gives_wongs_load_pull_and_torque(slip):
    t = terrain()
    ref = Wong(0.05, slip)
    assert ref.b == WHEEL.width                            # the chord is wider than the wheel here
    got = kernel(t, 0.05, slip)
    want = ref.integrals()
    tol = ref.grid_bounds(CELL, ALONG0)
    assert np.all(tol < 0.01 * np.abs(want))                         # the bound is tight enough to mean something
    for name, g, w, e in zip(("load", "drawbar_pull", "torque"), (got["load"], got["drawbar_pull"], got["torque"]),
                             want, tol):
        assert abs(g - w) <= e, (name, g, w, e)
    assert got["theta1"] == pytest.approx(ref.th1, rel=1e-12)


@pytest.mark.parametrize("slip", [0.1, 0.4])
def test_equilibrium_sinkage_and_drawbar_pull_at_a_load(slip):
    t = terrain()
    # the kernel: bisection on the axle height until the soil carries LOAD
    lo, hi = 0.0, 0.2
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if kernel(t, mid, slip)["load"] > LOAD else (mid, hi)
    z_k = 0.5 * (lo + hi)
    # the reference: W(z0) = LOAD by brentq on the quadrature
    z_q = brentq(lambda z: Wong(z, slip).integrals()[0] - LOAD, 1e-4, 0.2, xtol=1e-12)
    ref = Wong(z_q, slip)
    e_w, e_dp, _ = ref.grid_bounds(CELL, ALONG0)
    # |W_k − W_q| ≤ e_w everywhere, so |z_k − z_q| ≤ e_w / (the slope of W below z_q; W is convex in z)
    dz = 2.0 * e_w / ((ref.integrals()[0] - Wong(0.9 * z_q, slip).integrals()[0]) / (0.1 * z_q))
    slope = (ref.integrals()[0] - Wong(z_q - dz, slip).integrals()[0]) / dz
    z_tol = e_w / slope
    assert abs(z_k - z_q) <= z_tol and z_tol < 0.01 * z_q
    # the pull at the kernel's sinkage: the grid's bound plus the reference's change over the sinkage error
    dp_q = ref.integrals()[1]
    ddp = abs(Wong(z_q + z_tol, slip).integrals()[1] - Wong(z_q - z_tol, slip).integrals()[1]) / 2.0
    assert abs(kernel(t, z_k, slip)["drawbar_pull"] - dp_q) <= e_dp + ddp
    assert dp_q > 0.0                                      # a driven wheel at this slip pulls


def test_commit_leaves_the_plastic_rut_under_the_wheel():
    t = terrain()
    z0 = 0.03
    kernel(t, z0, 0.2, commit=True)
    # the node under the axle (along = 0 … Δ ahead): loaded to its sinkage there, rebounds by σ / K_e
    x = -1.0 + CELL * math.ceil((CX + 1.0) / CELL)            # the first node at or ahead of the axle
    s = z0 - WHEEL.radius * (1.0 - math.cos(math.asin((x - CX) / WHEEL.radius)))
    sig = (SAND.k_c / WHEEL.width + SAND.k_phi) * s ** SAND.n
    assert float(t.rut_depth(x, CY)) == pytest.approx(s - sig / SAND.elastic_k, rel=1e-9)
    # behind the axle the soil was not touched (θ2 = 0), ahead of the entry neither
    assert float(t.rut_depth(x - 2 * CELL, CY)) == 0.0
    assert float(t.rut_depth(CX + WHEEL.radius * math.sin(math.acos(1 - z0 / WHEEL.radius)) + CELL, CY)) == 0.0
    assert t.state.version == 1
