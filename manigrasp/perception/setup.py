"""Where the cameras are: a frozen, validated camera setup (one or several views around the object).

The benchmark's ``camera:`` config key is a `CameraSetup`:

    camera:
      views: 2                 # cameras around the object
      azimuth_deg: 30          # the first camera's azimuth; the others follow every 360 / views degrees
      azimuths_deg: [30, 150]  # or every camera's azimuth, explicitly (then len == views)
      elevation_deg: 45
      distance: 0.55
      noise: {sigma_0: 0.0012, k: 0.0019}

Every camera looks at the point `target_height` above the object's resting
position on the table, from `distance`, at `elevation_deg` above the
table plane, with the same intrinsics and noise model.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from manigrasp.errors import ConfigError
from manigrasp.perception.camera import BACKENDS, Camera
from manigrasp.perception.noise import DepthNoise
from manigrasp.perception.pipeline import CameraConfig, PerceptionConfig

MAX_VIEWS = 12


@dataclass(frozen=True)
class CameraSetup:
    """The cameras of an observation (module docstring).

    Attributes:
        views: number of cameras (1 to 12).
        azimuth_deg: azimuth of the first camera about world z, 0 on the +x side [deg]; camera i sits at
            azimuth_deg + 360 i / views unless `azimuths_deg` is given.
        azimuths_deg: explicit azimuth of every camera [deg] (empty: evenly spaced from `azimuth_deg`).
        elevation_deg: above the table plane, in (0, 90) [deg].
        distance: from the target [m].
        target_height: the point looked at, above the object's resting position on the table [m].
        width, height: resolution [px]; fovy_deg: vertical field of view [deg].
        backend: depth backend, "raycast", "gl" or "auto" (`manigrasp.perception.camera`).
        noise: the depth noise model of every camera.
    """

    views: int = 1
    azimuth_deg: float = 30.0
    azimuths_deg: tuple[float, ...] = ()
    elevation_deg: float = 45.0
    distance: float = 0.55
    target_height: float = 0.05
    width: int = 320
    height: int = 240
    fovy_deg: float = 45.0
    backend: str = "raycast"
    noise: DepthNoise = field(default_factory=DepthNoise)

    def __post_init__(self) -> None:
        if isinstance(self.views, bool) or not isinstance(self.views, int) or not 1 <= self.views <= MAX_VIEWS:
            raise ConfigError(f"camera.views must be an integer in [1, {MAX_VIEWS}], got {self.views!r}")
        azimuths = tuple(float(a) for a in self.azimuths_deg)
        if azimuths and len(azimuths) != self.views:
            raise ConfigError(f"camera.azimuths_deg lists {len(azimuths)} azimuths for {self.views} views")
        object.__setattr__(self, "azimuths_deg", azimuths)
        if not 0.0 < self.elevation_deg < 90.0:
            raise ConfigError(f"camera.elevation_deg must be in (0, 90), got {self.elevation_deg}")
        if not self.distance > 0:
            raise ConfigError(f"camera.distance must be > 0, got {self.distance}")
        if self.backend not in BACKENDS:
            raise ConfigError(f"unknown camera.backend {self.backend!r}; available: {', '.join(BACKENDS)}")
        if not isinstance(self.noise, DepthNoise):
            raise ConfigError(f"camera.noise must be a DepthNoise mapping, got {type(self.noise).__name__}")
        self.view(0).camera(np.zeros(2))  # validates resolution and field of view

    def view_azimuths(self) -> tuple[float, ...]:
        """The azimuth of every camera [deg]."""
        if self.azimuths_deg:
            return self.azimuths_deg
        return tuple(self.azimuth_deg + 360.0 * i / self.views for i in range(self.views))

    def view(self, i: int) -> CameraConfig:
        """Camera `i` as a `pipeline.CameraConfig` (one orbiting camera)."""
        return CameraConfig(self.width, self.height, self.fovy_deg, self.distance, self.view_azimuths()[i],
                            self.elevation_deg, self.target_height, self.backend)

    def cameras(self, target_xy: np.ndarray, table_height: float = 0.0) -> tuple[Camera, ...]:
        """Every camera, looking at (`target_xy`, table_height + target_height) [m]."""
        return tuple(self.view(i).camera(target_xy, table_height) for i in range(self.views))

    def perception(self, table_height: float = 0.0) -> PerceptionConfig:
        """The `PerceptionConfig` of these cameras' views (their noise and backend) over a table at
        `table_height` [m]."""
        return PerceptionConfig(noise=self.noise, backend=self.backend, table_height=table_height)

    def record(self) -> dict[str, float | int]:
        """The fields a trial stores (`manigrasp.protocol.result.TrialResult.camera_*`): number of cameras, the
        first one's azimuth, elevation, distance and the depth noise's standard deviation at that distance
        (the full setup is in run.json)."""
        return {"camera_views": self.views, "camera_azimuth_deg": float(self.view_azimuths()[0]),
                "camera_elevation_deg": float(self.elevation_deg), "camera_distance_m": float(self.distance),
                "camera_noise_sigma_m": float(self.noise.sigma(self.distance))}
