"""Camera setups, free space from depth images, and several views of a known box fused into one cloud.

The box (5 x 3 x 12 cm) stands upright on a table; the cameras are ray-cast
(no OpenGL needed) at 0.55 m, 45 degrees elevation.
"""

from __future__ import annotations

import numpy as np
import pytest

from manigrasp.errors import ConfigError
from manigrasp.perception.noise import NOISELESS
from manigrasp.perception.setup import CameraSetup
from manigrasp.planners.free_space import FREE, OCCUPIED, UNKNOWN, FreeSpace
from tests.helpers import TALL_BOX as BOX
from tests.helpers import fused

pytest.importorskip("open3d")


def test_camera_setup_spreads_views_and_validates():
    assert CameraSetup(views=3, azimuth_deg=30.0).view_azimuths() == (30.0, 150.0, 270.0)
    assert CameraSetup(views=2, azimuths_deg=[0, 90]).view_azimuths() == (0.0, 90.0)
    cameras = CameraSetup(views=2, distance=0.5).cameras(np.array([0.1, 0.0]))
    assert [np.linalg.norm(c.position - [0.1, 0.0, 0.05]) for c in cameras] == pytest.approx([0.5, 0.5])
    record = CameraSetup(views=2).record()
    assert record["camera_views"] == 2 and record["camera_azimuth_deg"] == 30.0
    assert record["camera_noise_sigma_m"] == pytest.approx(0.0012 + 0.0019 * 0.15**2)
    for bad, match in (({"views": 0}, "views"), ({"views": 2, "azimuths_deg": [0]}, "azimuths"),
                       ({"elevation_deg": 90}, "elevation"), ({"distance": 0}, "distance"),
                       ({"backend": "lidar"}, "backend"), ({"fovy_deg": 200}, "fovy")):
        with pytest.raises(ConfigError, match=match):
            CameraSetup(**bad)


def test_a_second_view_leaves_the_first_frame_unchanged(box_table):
    one, two = fused(box_table, CameraSetup()), fused(box_table, CameraSetup(views=2))
    np.testing.assert_array_equal(one.images[0].depth, two.images[0].depth)
    assert len(two.cloud) == len(two.clouds[0]) + len(two.clouds[1]) > len(one.cloud)


def face_positions(cloud, axis: int) -> tuple[float, float]:
    """Median coordinate along `axis` of the points whose normals face -axis and +axis (the two faces)."""
    return tuple(float(np.median(cloud.points[sign * cloud.normals[:, axis] > 0.9, axis])) for sign in (-1, 1))


@pytest.mark.parametrize("noise", ["noiseless", "default"])
def test_two_opposite_views_fuse_to_the_box_extent(box_table, noise):
    """One view sees two side faces and the top; two opposite views see all four sides, and the fused
    cloud spans the box, face to face (x, y) and to the top (the table removal cuts the bottom 4 mm)."""
    setup = CameraSetup(views=2, noise=NOISELESS) if noise == "noiseless" else CameraSetup(views=2)
    cloud = fused(box_table, setup).cloud
    for axis in range(2):  # every side face is seen, from one camera or the other
        for sign in (-1, 1):
            assert np.sum(sign * cloud.normals[:, axis] > 0.9) > 50, (axis, sign)
        low, high = face_positions(cloud, axis)
        assert abs(high - low - BOX[axis]) < 0.003 and abs(high + low) < 0.003, (axis, low, high)
    top = np.median(cloud.points[cloud.normals[:, 2] > 0.9, 2])
    assert abs(top - BOX[2]) < 0.003
    if noise == "noiseless":
        np.testing.assert_allclose(cloud.points.max(axis=0)[:2] - cloud.points.min(axis=0)[:2], BOX[:2],
                                   atol=0.003)
    single = fused(box_table, CameraSetup(noise=setup.noise)).cloud
    assert np.sum(single.normals[:, 0] < -0.9) < 5 and np.sum(single.normals[:, 1] < -0.9) < 5


def test_free_space_textbook_cases(box_table):
    """In front of a seen face: free; on it: occupied; inside the box or in its shadow: unknown, until a
    second camera sees the shadow."""
    one = fused(box_table, CameraSetup(noise=NOISELESS))
    camera = one.images[0].camera.position
    face = np.array([BOX[0] / 2, 0.0, 0.06])  # the +x face, seen from azimuth 30 deg
    ray = (camera - face) / np.linalg.norm(camera - face)
    shadow = np.array([-BOX[0] / 2 - 0.02, -0.01, 0.03])  # behind the box, low
    points = np.array([face + 0.02 * ray, face, [0.0, 0.0, 0.06], shadow])
    space = FreeSpace(one.depth_views())
    np.testing.assert_array_equal(space.classify(points), [FREE, OCCUPIED, UNKNOWN, UNKNOWN])
    both = FreeSpace(fused(box_table, CameraSetup(views=2, noise=NOISELESS)).depth_views())
    np.testing.assert_array_equal(both.classify(points), [FREE, OCCUPIED, UNKNOWN, FREE])
    grid = space.voxels(np.array([-0.05, -0.05, 0.01]), np.array([0.05, 0.05, 0.11]), 0.01)
    assert grid.shape == (10, 10, 10) and grid[5, 5, 5] == UNKNOWN and (grid == FREE).mean() > 0.3
