"""Camera projection models (paper 2.2.3, issue 12): pinhole, equidistant fisheye, CAHV, CAHVOR, CAHVORE.

Every model maps sensor-frame points to pixels and pixels to rays, vectorised with
NumPy in float64::

    uv, valid = model.project(points)        # (n, 3) -> (n, 2), (n,); NaN pixels where not valid
    origins, directions = model.unproject(uv)  # (n, 2) -> (n, 3), (n, 3) unit; NaN where no ray
    origins, directions = model.pixel_rays()   # (h, w, 3) each, every pixel centre

Conventions
-----------
Frame: the sensor's optical frame as in ROS (x right, y down, z forward), lengths in
the scene's unit (metres). The CAHV family's C, A, H, V, O are expressed in that same
frame, so C = 0, A = (0, 0, 1), H = (fx, 0, cx), V = (0, fy, cy) is the pinhole
(fx, fy, cx, cy); E's entries are lengths along O, R's are dimensionless.

Pixels: (u, v) = (column, row), pixel centres at integer coordinates, (0, 0) the centre
of the top-left pixel (ROS's K; JPL's CAHV image coordinates are the same), so a centred
camera has cx = (width − 1)/2 and the image spans [−0.5, width − 0.5] horizontally.
Projected pixels are not clipped: ``in_image`` says which fall on the image.

Models and their equations
--------------------------
- Pinhole: u = fx·x/z + cx, v = fy·y/z + cy (z > 0); ROS "plumb_bob" with D = 0.
- Fisheye, equidistant: image radius f·θ with θ the angle from the axis, so the field
  of view may exceed 180°; ROS "equidistant" with D = 0.
- CAHV (Yakimovsky & Cunningham 1978, "A system for extracting three-dimensional
  measurements from a stereo pair of TV cameras", CGIP 7): x = (P−C)·H / (P−C)·A,
  y = (P−C)·V / (P−C)·A.
- CAHVOR (Gennery's radial distortion about the optical axis O): with ζ = (P−C)·O,
  λ = (P−C) − ζO, τ = |λ|²/ζ², μ = r0 + r1τ + r2τ², CAHV applied to P' = P + μλ.
- CAHVORE (Gennery 2006, "Generalized camera calibration including fish-eye lenses",
  IJCV 68(3)): the entrance pupil slides along O by δ(θ) = (θ/sin θ − 1)(e0 + e1θ² + e2θ⁴)
  with the incidence angle θ, and the linearity L bends the angle mapping from
  perspective (L = 1, χ = tan θ) to equidistant fisheye (L = 0, χ = θ) through
  χ = tan(Lθ)/L; R distorts χ as in CAHVOR. Projection solves for θ by Newton's method;
  unprojection solves R's quintic and is otherwise closed form, returning the moving
  entrance point as each ray's origin.
The equations follow Gennery's papers as implemented in JPL's cmod library (Litwin);
see cahv.py for the details, including the domains (points past a distortion's fold,
behind a perspective camera, or at θ·L ≥ 90° are not valid).

Specs: ``camera_model_from_spec(spec, width, height, where)`` builds any of them from a
mapping (see spec.py); ``PAPER_FIGURE_7`` holds the paper's figure-7 CAHV, CAHVOR and
CAHVORE examples as such specs (``PAPER_FIGURE_7_SIZE`` their image size).
"""

from .base import CameraModel
from .cahv import PAPER_FIGURE_7, PAPER_FIGURE_7_SIZE, PAPER_FIGURE_7_WORLD, CahvModel, CahvoreModel, CahvorModel
from .central import FisheyeModel, PinholeModel
from .spec import KINDS, CameraSpec, camera_model_from_spec

__all__ = [
    "KINDS",
    "PAPER_FIGURE_7",
    "PAPER_FIGURE_7_SIZE",
    "PAPER_FIGURE_7_WORLD",
    "CahvModel",
    "CahvoreModel",
    "CahvorModel",
    "CameraModel",
    "CameraSpec",
    "FisheyeModel",
    "PinholeModel",
    "camera_model_from_spec",
]
