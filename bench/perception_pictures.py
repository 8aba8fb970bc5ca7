"""Redraws the README's perception pictures (docs/images/perception-*.png) from the sensors themselves.

    camera-models     a checkerboard ice plane seen straight down by each camera model: a 90°
                      pinhole and a 200° equidistant fisheye from 2 m (0.5 m squares), and the
                      paper's figure-7 CAHV, CAHVOR and CAHVORE from 35 m (4 m squares)
    obstacle-course   assemblies/perception-obstacle-course.yaml after 2 s of driving: the stereo
                      pair's left and right images and the lidar's point cloud from above,
                      coloured by range-compensated intensity ρ cos θ (misses are not drawn)

    .venv/bin/python bench/perception_pictures.py [--out docs/images]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from snakesim.components.multibody.robot_model import RobotModel  # noqa: E402
from snakesim.components.perception import Camera, SensorScene  # noqa: E402
from snakesim.components.perception.camera_models import PAPER_FIGURE_7, PAPER_FIGURE_7_SIZE  # noqa: E402
from snakesim.components.terrain.spec import load_terrain  # noqa: E402
from snakesim.framework import Harness  # noqa: E402
from snakesim.framework.assembly import resolve  # noqa: E402
from snakesim.framework.registry import default_registry  # noqa: E402
from snakesim.framework.session import Session  # noqa: E402

USES = {"robot": RobotModel.load(design="eels-1.0")}
DOWN = (1.0, 0.0, 0.0, 0.0)            # every link rotated π about x: a camera's optical z looks down


def looking_down(height: float, square: float, spec: dict, size: tuple[int, int]) -> np.ndarray:
    plane = load_terrain({"kind": "plane", "materials": [{"name": "ice", "albedo": 0.9, "texture": "checker",
                                                          "texture_size": square, "texture_contrast": 0.85}]})
    poses = np.zeros((USES["robot"].nl, 7))
    poses[:, 2], poses[:, 3:] = height, DOWN
    scene = Harness(SensorScene, {"extent": 150.0, "robot_visible": False}, uses=USES)
    scene.inputs.terrain, scene.inputs.link_poses = plane, poses
    cam = Harness(Camera, {"link": "camera_left", "optical": False, "model": spec, "width": size[0],
                           "height": size[1], "light": {"kind": "sun", "direction": (0, 0, -1), "ambient": 0.0}},
                  rate=1.0, uses=USES)
    cam.inputs.world = scene.outputs()["world"]
    return cam.outputs()["frame"].image


def camera_models(out: Path) -> Path:
    panels = [("pinhole 90°", looking_down(2.0, 0.5, {"kind": "pinhole", "fov": 90.0}, (320, 240))),
              ("fisheye 200° (equidistant)", looking_down(2.0, 0.5, {"kind": "fisheye", "fov": 200.0}, (320, 240)))]
    panels += [(f"{k.upper()} (paper fig. 7)", looking_down(35.0, 4.0, PAPER_FIGURE_7[k], PAPER_FIGURE_7_SIZE))
               for k in ("cahv", "cahvor", "cahvore")]
    fig, axes = plt.subplots(1, len(panels), figsize=(4 * len(panels), 3.6))
    for ax, (title, img) in zip(axes, panels):
        ax.imshow(np.clip(img, 0, 1), cmap="gray", vmin=0, vmax=1)
        ax.set_title(title)
        ax.axis("off")
    fig.suptitle("A checkerboard ice plane seen straight down by each camera model (ray cast, snakesim)")
    fig.tight_layout()
    path = out / "perception-camera-models.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def obstacle_course(out: Path, at: float = 2.0) -> Path:
    from snakesim.components.perception import Lidar, StereoCamera

    reg = default_registry()
    r = resolve("perception-obstacle-course", search_path=reg.assembly_paths(), sim_overrides={"duration": at})
    seen, originals = {}, {}
    for cls, ports in ((Lidar, ("scan",)), (StereoCamera, ("left", "right"))):
        originals[cls] = original = cls.output

        def spy(self, t, x, u, y, original=original, ports=ports):
            original(self, t, x, u, y)
            seen.update({p: getattr(y, p) for p in ports})

        cls.output = spy                     # the plan binds methods at build: patch first
    try:
        Session(r, reg).run()
    finally:
        for cls, original in originals.items():
            cls.output = original
    scan, left, right = seen["scan"], seen["left"], seen["right"]
    from scipy.spatial.transform import Rotation

    ret = scan.status == 0
    world = scan.pose[:3] + scan.points[ret] @ Rotation.from_quat(scan.pose[3:]).as_matrix().T
    fig = plt.figure(figsize=(15, 4.6))
    for k, (title, frame) in enumerate((("stereo left", left), ("stereo right", right))):
        ax = fig.add_subplot(1, 3, k + 1)
        ax.imshow(np.clip(frame.image, 0, 1), cmap="gray", vmin=0, vmax=1)
        ax.set_title(f"{title}, t = {frame.t:.1f} s")
        ax.axis("off")
    ax = fig.add_subplot(1, 3, 3)
    # range-compensated (ρ cos θ): the raw (1 m / r)² fall-off would hide everything past the first rings
    reflectivity = scan.intensity[ret] * scan.range[ret] ** 2
    sc = ax.scatter(world[:, 0], world[:, 1], c=reflectivity, s=1.0, cmap="turbo", vmin=0.0, vmax=0.7)
    ax.plot(*scan.pose[:2], "k^", ms=8)
    ax.set_aspect("equal")
    ax.set_xlim(scan.pose[0] - 2, scan.pose[0] + 10)
    ax.set_ylim(-4, 4)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"lidar spinning-32, {ret.sum()} returns, from above")
    fig.colorbar(sc, ax=ax, label="intensity × r²: ρ cos θ", shrink=0.8)
    fig.tight_layout()
    path = out / "perception-obstacle-course.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="docs/images")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for path in (camera_models(out), obstacle_course(out)):
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
