"""Gennery's CAHV family: CAHV (Yakimovsky & Cunningham 1978), CAHVOR and CAHVORE (Gennery 2006).

C, A, H, V, O (and E's scalars) are given in the sensor frame; C is the camera centre,
A the unit axis, H = hs·h' + hc·A and V = vs·v' + vc·A carry the scales and image
centre, O is the unit optical axis, R = (r0, r1, r2) the radial distortion and
E = (e0, e1, e2) the entrance-pupil movement. For p = P − C:

CAHV::      x = p·H / p·A,   y = p·V / p·A                                   (p·A > 0)

CAHVOR::    ζ = p·O,  λ = p − ζ O,  τ = |λ|²/ζ²,  μ = r0 + r1 τ + r2 τ²
            p' = p + μ λ,  then CAHV on p'                                   (ζ > 0)

CAHVORE::   solve for θ, the incidence angle of the ray that reaches P through the
            entrance point C + δ(θ) O, δ(θ) = (θ/sin θ − 1)(e0 + e1 θ² + e2 θ⁴):
                (ζ − δ(θ)) sin θ = |λ| cos θ
            χ = tan(Lθ)/L (L > 0) or θ (L = 0)    L: linearity, 1 perspective, 0 fisheye
            χ' = (1 + μ(χ²)) χ,  then CAHV on O + χ' λ/|λ|                   (Lθ < π/2, θ < π)

In all three the distorted tangent is χ' = (1 + r0) χ + r1 χ³ + r2 χ⁵ of the true one
(χ = √τ for CAHVOR), so unprojection solves that odd quintic for χ (bracketed Newton,
to rounding). Where its slope first vanishes (χ_fold) the distortion folds the image
back on itself: points beyond are invalid, and pixels beyond χ'(χ_fold) have no ray.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .base import CameraModel, as_pixels, as_points, check_finite, pinhole_camera_info, unit

Vec3 = tuple[float, float, float]

_UNIT_TOLERANCE = 1e-6  # |A|, |O| must be this close to 1: they are rejected, never normalised


def _vec3(key: str, value) -> np.ndarray:
    vector = np.asarray(value, dtype=np.float64)
    if vector.shape != (3,):
        raise ValueError(f"{key} = {value!r}: must be 3 finite numbers (x, y, z)")
    check_finite(**{key: vector})
    return vector


def _require_unit(key: str, value, vector: np.ndarray) -> None:
    length = float(np.linalg.norm(vector))
    if abs(length - 1) > _UNIT_TOLERANCE:
        raise ValueError(
            f"{key} = {value!r}: |{key.upper()}| = {length:.9g}, must be within {_UNIT_TOLERANCE:g} of 1 "
            "(a unit vector; it is not normalised for you)"
        )


def _bracketed_newton(residual, x, low, high, iterations=100):
    """Per element, the root in [low, high] of an increasing residual(x) -> (value, slope).

    Newton steps, and bisection whenever a step would leave the bracket (kept by the
    residual's sign), so it converges wherever the bracket holds a sign change.
    """
    x = np.clip(x, low, high)
    for _ in range(iterations):
        value, slope = residual(x)
        low = np.where(value < 0, x, low)
        high = np.where(value > 0, x, high)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = x - value / slope
        step = np.where((step >= low) & (step <= high), step, 0.5 * (low + high))
        step[np.isnan(value)] = np.nan  # no residual (no target): no root, not a bisection
        # Settled within a few ulps (rounding can make the last steps hop between neighbours);
        # NaN rows count as settled.
        settled = ~(np.abs(step - x) > 2e-15 * np.abs(x))
        x = step
        if settled.all():
            break
    return x


class _Radial:
    """χ' = (1 + r0) χ + r1 χ³ + r2 χ⁵: the radial distortion CAHVOR and CAHVORE share."""

    def __init__(self, r: np.ndarray):
        self.k1, self.k3, self.k5 = 1 + r[0], r[1], r[2]
        # The slope in s = χ² is k1 + 3 k3 s + 5 k5 s²; its first positive root is the fold.
        roots = np.roots([5 * self.k5, 3 * self.k3, self.k1]) if (self.k3 or self.k5) else []
        folds = [z.real for z in np.atleast_1d(roots) if abs(z.imag) < 1e-12 * abs(z) and z.real > 0]
        self.fold = math.sqrt(min(folds)) if folds else math.inf
        self.fold_image = float(self.distort(self.fold)) if folds else math.inf
        # Without a fold the slope is bounded below, so χ ≤ χ'/min_slope brackets the root.
        candidates = [self.k1]
        if self.k5 > 0 and -3 * self.k3 / (10 * self.k5) > 0:
            s = -3 * self.k3 / (10 * self.k5)
            candidates.append(self.k1 + 3 * self.k3 * s + 5 * self.k5 * s * s)
        self.min_slope = min(candidates)

    def distort(self, chi):
        chi2 = chi * chi
        return chi * (self.k1 + chi2 * (self.k3 + chi2 * self.k5))

    def undistort(self, chi_image: np.ndarray) -> np.ndarray:
        """χ for each χ' (NaN where χ' < 0 or past the fold's image)."""
        reachable = (chi_image >= 0) & (chi_image < self.fold_image)
        target = np.where(reachable, chi_image, np.nan)
        high = self.fold if math.isfinite(self.fold) else target / self.min_slope

        def residual(chi):
            chi2 = chi * chi
            slope = self.k1 + chi2 * (3 * self.k3 + chi2 * 5 * self.k5)
            return self.distort(chi) - target, slope

        return _bracketed_newton(residual, target / self.k1, np.zeros_like(target), high)


@dataclass(frozen=True)
class CahvModel(CameraModel):
    """Linear (perspective) CAHV model; a pinhole is C = 0, A = z, H = (fx, 0, cx), V = (0, fy, cy)."""

    c: Vec3
    a: Vec3
    h: Vec3
    v: Vec3

    def __post_init__(self):
        super().__post_init__()
        C, A, H, V = (_vec3(key, getattr(self, key)) for key in ("c", "a", "h", "v"))
        _require_unit("a", self.a, A)
        h_image, v_image = H - (H @ A) * A, V - (V @ A) * A  # hs·h', vs·v'
        for key, full, image in (("h", H, h_image), ("v", V, v_image)):
            if not np.linalg.norm(image) > 1e-9 * np.linalg.norm(full):
                raise ValueError(
                    f"{key} = {getattr(self, key)!r}: parallel to A = {self.a!r}; "
                    f"{key.upper()} − ({key.upper()}·A)A is the image scale and must be non-zero"
                )
        handedness = float(np.cross(H, V) @ A)
        if not handedness > 1e-6 * np.linalg.norm(h_image) * np.linalg.norm(v_image):
            raise ValueError(
                f"h = {self.h!r}, v = {self.v!r}: (H × V)·A = {handedness:.6g}, must be > 0: H and V must "
                "span a right-handed image plane (u right, v down, A forward), not a mirrored or degenerate one"
            )
        for key, vector in zip("cahv", (C, A, H, V)):
            object.__setattr__(self, key, tuple(float(x) for x in vector))  # canonical, hashable
            object.__setattr__(self, "_" + key, vector)

    @classmethod
    def from_pinhole(cls, pinhole) -> CahvModel:
        """The CAHV model of a ``PinholeModel`` (same pixels, same rays)."""
        return cls(
            pinhole.width, pinhole.height, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0),
            (pinhole.fx, 0.0, pinhole.cx), (0.0, pinhole.fy, pinhole.cy),
        )  # fmt: skip

    @property
    def axis(self):
        return self._a

    def _image_of(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """CAHV pixels of vectors p from C (any positive scale); valid where p·A > 0."""
        alpha = p @ self._a
        valid = alpha > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([p @ self._h / alpha, p @ self._v / alpha], axis=1)
        uv[~valid] = np.nan
        return uv, valid

    def _rays_of(self, uv) -> np.ndarray:
        """Unit CAHV rays of pixels: the intersection of the planes (H − xA)·p = 0 and (V − yA)·p = 0."""
        q = as_pixels(uv)
        # Oriented so that ray·A = (H × V)·A > 0 (checked above): the ray looks forward.
        return unit(np.cross(self._h - q[:, :1] * self._a, self._v - q[:, 1:] * self._a))

    def project(self, points):
        return self._image_of(as_points(points) - self._c)

    def unproject(self, uv):
        directions = self._rays_of(uv)
        return np.broadcast_to(self._c, directions.shape).copy(), directions

    def camera_info(self):
        """K when this CAHV is a ROS pinhole: C = 0, A = z, H' along x, V' along y (orthogonal, unskewed)."""
        (hx, hy, hz), (vx, vy, vz) = self.h, self.v
        scale = max(abs(hx), abs(vy))
        pinhole = (
            np.allclose(self._c, 0, rtol=0, atol=1e-12)
            and np.allclose(self._a, (0, 0, 1), rtol=0, atol=1e-12)
            and abs(hy) <= 1e-12 * scale and abs(vx) <= 1e-12 * scale and hx > 0 and vy > 0
        )  # fmt: skip
        return pinhole_camera_info("plumb_bob", [0.0] * 5, hx, vy, hz, vz) if pinhole else None


@dataclass(frozen=True)
class CahvorModel(CahvModel):
    """CAHV with radial distortion R = (r0, r1, r2) about the optical axis O (Gennery)."""

    o: Vec3
    r: Vec3

    def __post_init__(self):
        super().__post_init__()
        O, R = _vec3("o", self.o), _vec3("r", self.r)
        _require_unit("o", self.o, O)
        if not O @ self._a > 0:
            raise ValueError(f"o = {self.o!r}: O·A = {O @ self._a:.6g}, must be > 0 (O within 90° of A)")
        if not 1 + R[0] > 0:
            raise ValueError(f"r = {self.r!r}: 1 + r0 = {1 + R[0]:.6g} is the on-axis scale and must be > 0")
        for key, vector in (("o", O), ("r", R)):
            object.__setattr__(self, key, tuple(float(x) for x in vector))
            object.__setattr__(self, "_" + key, vector)
        object.__setattr__(self, "_radial", _Radial(R))

    @property
    def axis(self):
        return self._o

    def project(self, points):
        p = as_points(points) - self._c
        zeta = p @ self._o
        lateral = p - zeta[:, None] * self._o
        r0, r1, r2 = self._r
        with np.errstate(divide="ignore", invalid="ignore"):
            tau = np.sum(lateral * lateral, axis=1) / (zeta * zeta)
        mu = r0 + r1 * tau + r2 * tau * tau
        uv, valid = self._image_of(p + mu[:, None] * lateral)
        valid &= (zeta > 0) & (tau < self._radial.fold**2)
        uv[~valid] = np.nan
        return uv, valid

    def _undistorted(self, uv) -> tuple[np.ndarray, np.ndarray]:
        """Per pixel: the true tangent χ from O (NaN where no ray) and the unit direction away from O."""
        ray = self._rays_of(uv)
        omega = ray @ self._o
        lateral = ray - omega[:, None] * self._o
        length = np.linalg.norm(lateral, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            chi_image = np.where(omega > 0, length / omega, np.nan)
            outward = np.where(length[:, None] > 0, lateral / length[:, None], 0.0)
        return self._radial.undistort(chi_image), outward

    def unproject(self, uv):
        chi, outward = self._undistorted(uv)
        directions = unit(self._o + chi[:, None] * outward)
        return np.broadcast_to(self._c, directions.shape).copy(), directions

    def camera_info(self):
        return None


@dataclass(frozen=True)
class CahvoreModel(CahvorModel):
    """CAHVOR with entrance-pupil movement E = (e0, e1, e2) along O and Gennery's linearity L in [0, 1]."""

    e: Vec3
    linearity: float

    def __post_init__(self):
        super().__post_init__()
        E = _vec3("e", self.e)
        check_finite(linearity=self.linearity)
        if not 0 <= self.linearity <= 1:
            raise ValueError(
                f"linearity = {self.linearity!r}: must be in [0, 1]: 1 perspective, 0 equidistant fisheye, "
                "in between intermediate (Gennery 2006); the sine branch L < 0 and L > 1, which JPL's cmod "
                "also evaluates, are not supported"
            )
        object.__setattr__(self, "e", tuple(float(x) for x in E))
        object.__setattr__(self, "_e", E)

    def _chi_of_theta(self, theta):
        L = self.linearity
        return theta if L < 1e-12 else np.tan(L * theta) / L

    def _theta_of_chi(self, chi):
        L = self.linearity
        return chi if L < 1e-12 else np.arctan(L * chi) / L

    def _pupil_shift(self, theta):
        """δ(θ) = (θ/sin θ − 1)(e0 + e1 θ² + e2 θ⁴), by its series where θ/sin θ − 1 cancels."""
        e0, e1, e2 = self._e
        t2 = theta * theta
        with np.errstate(divide="ignore", invalid="ignore"):
            excess = np.where(theta < 1e-3, t2 / 6 + 7 * t2 * t2 / 360, theta / np.sin(theta) - 1)
        return excess * (e0 + t2 * (e1 + t2 * e2))

    def project(self, points):
        p = as_points(points) - self._c
        zeta = p @ self._o
        lateral = p - zeta[:, None] * self._o
        length = np.linalg.norm(lateral, axis=1)
        e0, e1, e2 = self._e

        def residual(theta):  # (ζ − δ) sin θ − |λ| cos θ, written without dividing by sin θ
            s, c, t2 = np.sin(theta), np.cos(theta), theta * theta
            pupil = e0 + t2 * (e1 + t2 * e2)
            slope = zeta * c + length * s - (1 - c) * pupil - (theta - s) * theta * (2 * e1 + 4 * e2 * t2)
            return zeta * s - length * c - (theta - s) * pupil, slope

        start = np.arctan2(length, zeta)
        theta = _bracketed_newton(residual, start, np.zeros_like(start), np.full_like(start, np.pi))
        value, _ = residual(theta)
        scale = np.linalg.norm(p, axis=1) + np.abs(self._e).sum()
        solved = np.abs(value) <= 1e-12 * scale  # no root in [0, π]: the bracket was empty

        chi = self._chi_of_theta(theta)
        in_domain = solved & (theta * self.linearity < np.pi / 2) & (theta < np.pi) & (chi < self._radial.fold)
        chi_image = self._radial.distort(chi)
        with np.errstate(divide="ignore", invalid="ignore"):
            outward = np.where(length[:, None] > 0, lateral / length[:, None], 0.0)
        uv, valid = self._image_of(self._o + chi_image[:, None] * outward)
        valid &= in_domain
        uv[~valid] = np.nan
        return uv, valid

    def unproject(self, uv):
        chi, outward = self._undistorted(uv)
        theta = self._theta_of_chi(chi)
        theta = np.where(theta < np.pi, theta, np.nan)  # fisheye: the antipode and past it name no ray
        directions = np.sin(theta)[:, None] * outward + np.cos(theta)[:, None] * self._o
        origins = self._c + self._pupil_shift(theta)[:, None] * self._o
        return origins, directions


# Paper, figure 7 caption: the CAHV, CAHVOR and CAHVORE examples, verbatim, in the paper's world
# frame (z up: the camera 35 above the origin looking straight down). The paper does not give the
# CAHVORE linearity; 1 (perspective, JPL's CAHVORE type 1) is assumed here.
_PAPER_WORLD = {
    "c": (0.0, 0.0, 35.0), "a": (0.0, 0.0, -1.0),
    "h": (734.264, 0.0, -310.0), "v": (0.0, -714.264, -320.0), "o": (0.0, 0.0, -1.0),
}  # fmt: skip
_PAPER_SENSOR = {  # the same camera in its own optical frame: world rotated 180° about x, C at 0
    "c": (0.0, 0.0, 0.0), "a": (0.0, 0.0, 1.0),
    "h": (734.264, 0.0, 310.0), "v": (0.0, 714.264, 320.0), "o": (0.0, 0.0, 1.0),
}  # fmt: skip
_PAPER_DISTORTION = {"r": (0.05, -0.21, 0.01), "e": (0.12, -0.14, 0.13), "linearity": 1.0}
PAPER_FIGURE_7_SIZE = (620, 640)  # width, height: H·A = 310 and V·A = 320 put the axis at the centre


def _paper_specs(frame: dict) -> dict[str, dict]:
    cahv = {key: frame[key] for key in "cahv"}
    cahvor = {**cahv, "o": frame["o"], "r": _PAPER_DISTORTION["r"]}
    cahvore = {**cahvor, "e": _PAPER_DISTORTION["e"], "linearity": _PAPER_DISTORTION["linearity"]}
    return {
        "cahv": {"kind": "cahv", **cahv},
        "cahvor": {"kind": "cahvor", **cahvor},
        "cahvore": {"kind": "cahvore", **cahvore},
    }


PAPER_FIGURE_7 = _paper_specs(_PAPER_SENSOR)  # specs for camera_model_from_spec, sensor frame
PAPER_FIGURE_7_WORLD = _paper_specs(_PAPER_WORLD)  # the caption's numbers as printed
