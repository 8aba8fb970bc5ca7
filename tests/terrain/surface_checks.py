import numpy as np
import pytest


@pytest.fixture(autouse=True)
def _tmp_store(tmp_path, monkeypatch):
    """Every test gets its own terrain store (never the user's ~/.cache)."""
    monkeypatch.setenv("SNAKESIM_TERRAIN_STORE", str(tmp_path / "store"))


def fd_gradient(f, p, eps=1e-6):
    """Central finite-difference gradient of a scalar field f((n,3)) -> (n,)."""
    g = np.empty_like(p)
    for a in range(3):
        e = np.zeros(3)
        e[a] = eps
        g[:, a] = (f(p + e) - f(p - e)) / (2 * eps)
    return g


def onto_surface(terrain, p, iters=6):
    """Move points onto the surface by repeated p <- p - d n."""
    for _ in range(iters):
        q = terrain.query(p)
        p = p - q.distance[:, None] * q.normal
    return p


def assert_distance_lower_bound_holds(terrain, c, r, rng, samples):
    """distance_lower_bound(c, r) is at most the distance of every one of ``samples`` points drawn uniformly in
    each ball (centre c, radius r)."""
    bound = terrain.distance_lower_bound(c, r)
    dirs = rng.standard_normal((samples, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    for ci, ri, b in zip(c, r, bound):
        pts = ci + ri * dirs * rng.uniform(0, 1, (samples, 1)) ** (1 / 3)
        assert b <= terrain.distance(pts).min() + 1e-12
