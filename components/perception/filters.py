"""Image filters: ordinary components wired after a camera, in any order, each turning a
CameraFrame into a new one (IRIS-DARTS's filter pipeline, paper 2.2.3).

    camera.frame -> noise.frame_in;  noise.frame -> gamma.frame_in;  gamma.frame -> ...

A filter recomputes only when its input frame changes (a camera at 5 Hz feeding a filter
evaluated every base step costs one identity test per step). Write your own by
subclassing :class:`ImageFilter` and implementing ``apply(frame) -> image``; register it
as a component plugin like any other.

    image_noise    photon shot noise and read noise, seeded: I + sqrt(I·shot²)·N(0,1) +
                   read·N(0,1) (shot² the variance per unit signal; the noise keyed by the
                   seed and the frame's seq, so a run is reproducible)
    vignetting     I·cos⁴φ (natural vignetting, φ the pixel ray's angle off the optical
                   axis, from the camera model) times an optional radial falloff
                   1 + k1·ρ² + k2·ρ⁴ (ρ the distance from the image centre over the half
                   diagonal; lens/aperture vignetting)
    gamma          I^(1/γ) for I ≥ 0 (display encoding; negative noise values stay negative)
    color_adjust   gain per channel, offset, saturation s (RGB: grey + s·(I − grey))
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from snakesim.components.port_roles import CAMERA_FRAME
from snakesim.framework import Component, Input, Output, Params

from .camera import CameraFrame


class ImageFilter(Component):
    """Base of the filters: ``frame_in`` -> ``apply`` -> ``frame`` (same frame, new image)."""

    frame_in = Input(type=CameraFrame, role=CAMERA_FRAME)
    frame = Output(type=CameraFrame, feedthrough=True, role=CAMERA_FRAME)

    def make_cache(self, x, u, y):
        return _LastFrame()

    def output(self, t, x, u, y):
        memo = u.cache
        src = u.frame_in
        if src is None:
            y.frame = None
            return
        if src is not memo.source:
            memo.source = src
            image = np.asarray(self.apply(src, memo), dtype=np.float32)
            if image.shape != src.image.shape:
                raise ValueError(f"{self.name}: apply() returned an image of shape {image.shape} for a frame of "
                                 f"shape {src.image.shape}")
            memo.result = src.with_image(image)
        y.frame = memo.result

    def apply(self, frame: CameraFrame, memo: "_LastFrame") -> np.ndarray:
        """The filtered image of ``frame`` (same shape). ``memo.derived`` is a dict for this run's
        precomputed values (e.g. per camera model)."""
        raise NotImplementedError


class _LastFrame:
    """This run's memo: the last input frame, its filtered result, derived values."""

    def __init__(self):
        self.source = None
        self.result = None
        self.derived = {}


class ImageNoiseParams(Params):
    shot: float = Field(0.0, ge=0, description="shot-noise variance per unit signal (photon noise)")
    read: float = Field(0.0, ge=0, description="read-noise standard deviation (image units)")
    seed: int = Field(0, ge=0)


class ImageNoise(ImageFilter, Component[ImageNoiseParams]):
    type_name = "image_noise"

    def apply(self, frame, memo):
        p = self.p
        gen = np.random.Generator(np.random.Philox(key=int(p.seed), counter=[int(frame.seq), 0, 0, 0]))
        img = frame.image.astype(np.float64)
        std = np.sqrt(np.maximum(img, 0.0) * p.shot + p.read ** 2)
        return img + std * gen.standard_normal(img.shape)


class VignettingParams(Params):
    cos4: bool = Field(True, description="natural cos⁴ falloff with the ray's angle off the axis")
    k1: float = Field(0.0, description="radial falloff coefficient of ρ²")
    k2: float = Field(0.0, description="radial falloff coefficient of ρ⁴")


class Vignetting(ImageFilter, Component[VignettingParams]):
    type_name = "vignetting"

    def gain(self, model) -> np.ndarray:
        p = self.p
        _, d = model.pixel_rays()
        g = np.ones(d.shape[:2])
        if p.cos4:
            g *= np.clip(d[..., 2], 0.0, 1.0) ** 4      # rays behind the axis (fisheye > 180°) get none
        if p.k1 or p.k2:
            h, w = d.shape[:2]
            v, u = np.mgrid[0:h, 0:w]
            rho2 = ((u - (w - 1) / 2) ** 2 + (v - (h - 1) / 2) ** 2) / (((w - 1) / 2) ** 2 + ((h - 1) / 2) ** 2)
            g *= 1.0 + p.k1 * rho2 + p.k2 * rho2 ** 2
        return g

    def apply(self, frame, memo):
        g = memo.derived.get(id(frame.model))
        if g is None:
            g = memo.derived[id(frame.model)] = self.gain(frame.model)
        return frame.image * (g[..., None] if frame.image.ndim == 3 else g)


class GammaParams(Params):
    gamma: float = Field(2.2, gt=0, description="display gamma γ: out = in^(1/γ)")


class Gamma(ImageFilter, Component[GammaParams]):
    type_name = "gamma"

    def apply(self, frame, memo):
        img = frame.image
        return np.sign(img) * np.abs(img) ** (1.0 / self.p.gamma)


class ColorAdjustParams(Params):
    gain: tuple[float, float, float] = Field((1.0, 1.0, 1.0), description="per channel (R, G, B; grey: the first)")
    offset: float = Field(0.0, description="added after the gain")
    saturation: float = Field(1.0, ge=0, description="RGB: 0 grey, 1 unchanged")


class ColorAdjust(ImageFilter, Component[ColorAdjustParams]):
    type_name = "color_adjust"

    def apply(self, frame, memo):
        p = self.p
        img = frame.image
        if img.ndim == 2:
            return img * p.gain[0] + p.offset
        out = img * np.asarray(p.gain, dtype=np.float32) + p.offset
        if p.saturation != 1.0:
            grey = out.mean(axis=2, keepdims=True)
            out = grey + p.saturation * (out - grey)
        return out
