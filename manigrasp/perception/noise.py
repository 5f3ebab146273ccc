"""A depth-sensor noise model: axial noise growing with distance, dropout at grazing angles (seeded).

The axial noise follows the structured-light model of Nguyen, Izadi and
Lovell (2012) for a Kinect: sigma(z) = sigma_0 + k (z - z_0)^2. A pixel whose
surface is seen at an incidence angle theta (between the viewing ray and the
surface normal) is dropped with probability rising linearly from 0 at
`dropout_start_deg` to 1 at `dropout_full_deg`. Normals come from the depth
image itself (finite differences of the back-projected points), so the model
treats both depth backends alike. The `numpy.random.Generator` is passed in.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.perception.camera import DepthImage


@dataclass(frozen=True)
class DepthNoise:
    """Noise parameters.

    Attributes:
        sigma_0: axial standard deviation at `z_0` [m].
        k: growth of the standard deviation with distance [m / m^2].
        z_0: distance of the smallest noise [m].
        dropout_start_deg: incidence angle where dropout begins [deg].
        dropout_full_deg: incidence angle beyond which every pixel is dropped [deg].
    """

    sigma_0: float = 0.0012
    k: float = 0.0019
    z_0: float = 0.4
    dropout_start_deg: float = 70.0
    dropout_full_deg: float = 85.0

    def __post_init__(self) -> None:
        if self.sigma_0 < 0 or self.k < 0:
            raise ConfigError("depth noise sigma_0 and k must be >= 0")
        if not 0 <= self.dropout_start_deg < self.dropout_full_deg <= 90:
            raise ConfigError("need 0 <= dropout_start_deg < dropout_full_deg <= 90")

    def sigma(self, depth: np.ndarray) -> np.ndarray:
        """Axial standard deviation [m] at z-depth `depth` [m] (any shape)."""
        return self.sigma_0 + self.k * (np.asarray(depth, float) - self.z_0) ** 2

    def dropout_probability(self, incidence_deg: np.ndarray) -> np.ndarray:
        """Probability of losing a pixel seen at `incidence_deg` [deg] (NaN: unknown angle -> 0)."""
        span = self.dropout_full_deg - self.dropout_start_deg
        p = (np.asarray(incidence_deg, float) - self.dropout_start_deg) / span
        return np.clip(np.nan_to_num(p, nan=0.0), 0.0, 1.0)


NOISELESS = DepthNoise(sigma_0=0.0, k=0.0, dropout_start_deg=89.9, dropout_full_deg=90.0)


def camera_points(image: DepthImage) -> np.ndarray:
    """(height, width, 3) points in the camera frame [m] (NaN where there is no depth)."""
    rays = image.camera.intrinsics.pixel_rays().reshape(*image.depth.shape, 3)
    return rays * image.depth[..., None]


def incidence_deg(image: DepthImage) -> np.ndarray:
    """(height, width) angle [deg] between each pixel's viewing ray and the surface normal, from
    central differences of the back-projected points; NaN where a neighbour has no depth."""
    pts = camera_points(image)
    du = np.gradient(pts, axis=1)
    dv = np.gradient(pts, axis=0)
    normal = np.cross(du, dv)
    ray = pts
    cos = np.abs(np.einsum("ijk,ijk->ij", normal, ray))
    denom = np.linalg.norm(normal, axis=2) * np.linalg.norm(ray, axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.degrees(np.arccos(np.clip(cos / denom, 0.0, 1.0)))


def apply_noise(image: DepthImage, noise: DepthNoise, rng: np.random.Generator) -> DepthImage:
    """A copy of `image` with axial noise added and grazing pixels dropped (depth NaN, geom -1)."""
    depth = image.depth
    drop = rng.random(depth.shape) < noise.dropout_probability(incidence_deg(image))
    noisy = depth + rng.standard_normal(depth.shape) * noise.sigma(np.nan_to_num(depth))
    noisy = np.where(drop, np.nan, noisy)
    geom = np.where(np.isnan(noisy), -1, image.geom)
    return replace(image, depth=noisy, geom=geom)
