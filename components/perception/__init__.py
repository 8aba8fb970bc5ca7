"""Perception: lidar and cameras by ray casting on the CPU (paper 2.2.3, figs. 7, 8, 12).

    sensor_scene   the physical scene at each instant (terrain + posed robot links)  sensor_scene.py
    lidar          ranges, points and diffuse intensities of a beam pattern          lidar.py, beam_patterns.py
    camera         depth and shaded image of a camera model                          camera.py, camera_models/
    stereo_camera  a synchronised pair with a baseline                               camera.py
    image filters  noise, vignetting, gamma, colour: components after a camera       filters.py

Shared pieces: where a sensor sits (mount.py), what it sees (surfaces.py), how rays are
cast (ray_casting.py: the RayCaster protocol sensors cast into, the back-end registry;
ray_caster.py: the embree back end, the terrain's and each link's static Embree scene;
hit_kernels.py; refine_kernels.py: exact hits on tubes and moulins), how surfaces reflect
(reflectance.py), what each beam and pixel hit (labels.py: the ground-truth label scheme), a
lidar's own motion during its sweep (motion.py).
"""

from .camera import Camera, CameraFrame, StereoCamera
from .filters import ColorAdjust, Gamma, ImageFilter, ImageNoise, Vignetting
from .labels import label_name
from .lidar import Lidar, LidarScan
from .ray_caster import EmbreeWorld, RayHits, SensorWorld
from .ray_casting import RayCaster, RayCasterBackend, ray_casters
from .sensor_scene import SensorScene

#: the components this package registers
PERCEPTION = (SensorScene, Lidar, Camera, StereoCamera, ImageNoise, Vignetting, Gamma, ColorAdjust)

__all__ = ["PERCEPTION", "Camera", "CameraFrame", "ColorAdjust", "EmbreeWorld", "Gamma", "ImageFilter", "ImageNoise",
           "Lidar", "LidarScan", "RayCaster", "RayCasterBackend", "RayHits", "SensorScene", "SensorWorld",
           "StereoCamera", "Vignetting", "label_name", "ray_casters"]
