"""Sensor mounts: the per-sample pose quaternion (written out for speed) equals scipy's for any
rotation, including the branches near 180° turns; the optical frame looks along the link's x."""

import numpy as np
from scipy.spatial.transform import Rotation

from snakesim.components.perception.mount import BODY_TO_OPTICAL, quaternion_xyzw


def test_quaternion_equals_scipys_on_every_branch():
    rng = np.random.default_rng(5)
    rotations = list(Rotation.random(500, random_state=rng).as_matrix())
    # half turns about each axis and near them: the w ≈ 0 branches
    rotations += [Rotation.from_rotvec(a * (np.pi - e)).as_matrix() for a in np.eye(3) for e in (0.0, 1e-9, 1e-3)]
    for R in rotations:
        q = Rotation.from_matrix(R).as_quat()
        np.testing.assert_allclose(quaternion_xyzw(R), q if q[3] >= 0 else -q, atol=1e-12)


def test_the_optical_frame_looks_along_the_links_x_with_image_right_to_its_minus_y():
    np.testing.assert_array_equal(BODY_TO_OPTICAL @ [0, 0, 1], [1, 0, 0])     # optical z: forward
    np.testing.assert_array_equal(BODY_TO_OPTICAL @ [1, 0, 0], [0, -1, 0])    # optical x: right
    np.testing.assert_array_equal(BODY_TO_OPTICAL @ [0, 1, 0], [0, 0, -1])    # optical y: down
