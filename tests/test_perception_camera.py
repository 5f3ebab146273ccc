"""Camera, ray-cast depth against analytic depth, GL against ray casting, noise (no Open3D needed)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from manigrasp.errors import ConfigError
from manigrasp.perception.camera import Camera, Intrinsics, capture, look_at, orbit_pose, raycast_depth
from manigrasp.perception.noise import DepthNoise, apply_noise, incidence_deg

BOX_XML = """<mujoco><worldbody>
  <geom name="floor" type="plane" size="1 1 .1"/>
  <geom name="box" type="box" size=".05 .06 .04" pos="0 0 .04"/>
</worldbody></mujoco>"""


def _box_scene():
    model = mujoco.MjModel.from_xml_string(BOX_XML)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def test_intrinsics_from_fovy():
    k = Intrinsics.from_fovy(640, 480, 60.0)
    assert k.fx == pytest.approx(240 / math.tan(math.radians(30)))
    assert (k.cx, k.cy) == (320, 240)
    assert k.fovy_deg == pytest.approx(60.0)
    with pytest.raises(ConfigError, match="fovy"):
        Intrinsics.from_fovy(10, 10, 180.0)


def test_look_at_axes():
    pose = look_at([1.0, 0.0, 1.0], [0.0, 0.0, 0.0])
    z = pose[:3, 2]
    np.testing.assert_allclose(z, np.array([-1, 0, -1]) / math.sqrt(2), atol=1e-12)
    assert pose[2, 1] < 0  # image down (camera y) points down in the world
    np.testing.assert_allclose(pose[:3, :3] @ pose[:3, :3].T, np.eye(3), atol=1e-12)
    with pytest.raises(ConfigError, match="up vector"):
        look_at([0, 0, 1], [0, 0, 0])


def test_raycast_depth_of_box_top_matches_analytic_depth():
    """A camera 0.5 m above a box top (z = 0.08) looking straight down sees z-depth 0.42 on the box,
    0.50 on the floor, and the box's outline where the projection of its top face says."""
    model, data = _box_scene()
    k = Intrinsics.from_fovy(101, 81, 40.0)
    pose = look_at([0, 0, 0.5], [0, 0, 0], up=[0, 1, 0])
    image = raycast_depth(model, data, Camera(k, pose))
    box = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "box")
    on_box = image.geom == box
    np.testing.assert_allclose(image.depth[on_box], 0.42, atol=1e-9)
    np.testing.assert_allclose(image.depth[~on_box], 0.50, atol=1e-9)
    # pixel centres whose ray hits the top face |x| < 0.05, |y| < 0.06 at depth 0.42
    rays = k.pixel_rays().reshape(81, 101, 3) * 0.42
    world = rays @ pose[:3, :3].T + pose[:3, 3]
    expected = (np.abs(world[..., 0]) < 0.05) & (np.abs(world[..., 1]) < 0.06)
    assert np.array_equal(on_box, expected)
    assert image.backend == "raycast"


def test_raycast_depth_oblique_is_z_depth():
    """Depth is along the optical axis: a tilted camera's floor pixels follow the plane's z-depth formula."""
    model, data = _box_scene()
    k = Intrinsics.from_fovy(64, 48, 45.0)
    pose = orbit_pose([0.3, 0.0, 0.0], 0.6, 180.0, 50.0)  # looks at the floor beside the box
    image = raycast_depth(model, data, Camera(k, pose))
    floor = image.geom == mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    rays = k.pixel_rays() @ pose[:3, :3].T  # z-depth 1 along each ray
    t = -pose[2, 3] / rays[:, 2]  # where the ray meets z = 0
    np.testing.assert_allclose(image.depth[floor], t.reshape(48, 64)[floor], rtol=1e-9)


def test_noise_is_seeded_and_grows_with_distance():
    model, data = _box_scene()
    image = raycast_depth(model, data, Camera(Intrinsics.from_fovy(80, 60, 45.0), look_at([0.4, 0, 0.5], [0, 0, 0])))
    noise = DepthNoise()
    a = apply_noise(image, noise, np.random.default_rng(3))
    b = apply_noise(image, noise, np.random.default_rng(3))
    np.testing.assert_array_equal(a.depth, b.depth)
    assert noise.sigma(1.4) > noise.sigma(0.6) > noise.sigma(0.4)
    assert noise.dropout_probability(np.array([10.0, 77.5, 89.0])).tolist() == [0.0, 0.5, 1.0]
    kept = np.isfinite(a.depth) & np.isfinite(image.depth)
    residual = (a.depth - image.depth)[kept]
    assert np.std(residual) == pytest.approx(float(np.mean(noise.sigma(image.depth[kept]))), rel=0.2)
    assert np.all(a.geom[np.isnan(a.depth)] == -1)


def test_incidence_of_a_frontal_plane_is_zero():
    model, data = _box_scene()
    image = raycast_depth(model, data, Camera(Intrinsics.from_fovy(41, 41, 10.0), look_at([0, 0, 0.6], [0, 0, 0.08],
                                                                                          up=[0, 1, 0])))
    centre = incidence_deg(image)[15:26, 15:26]
    assert np.nanmax(centre) < 5.0  # pixel rays diverge by < 5 deg from the axis


def test_unknown_backend_lists_choices():
    model, data = _box_scene()
    cam = Camera(Intrinsics.from_fovy(8, 8, 45.0), look_at([0, 0, 1], [0, 0, 0], up=[0, 1, 0]))
    with pytest.raises(ConfigError, match="raycast, gl"):
        capture(model, data, cam, backend="vulkan")


_GL_SCRIPT = """
import json, mujoco, numpy as np
from manigrasp.perception.camera import Camera, Intrinsics, gl_available, orbit_pose, raycast_depth, render_depth
ok, why = gl_available()
if not ok:
    print(json.dumps({"ok": False, "why": why})); raise SystemExit
xml = '''<mujoco><asset><mesh name="m" vertex="0 0 0  .06 0 0  0 .06 0  .02 .02 .07"/></asset><worldbody>
<geom type="plane" size="1 1 .1"/>
<body pos=".02 .01 .05"><geom name="b" type="box" size=".03 .04 .05" euler="0 0 .3"/></body>
<geom name="s" type="mesh" mesh="m" pos="-.1 .04 0"/></worldbody></mujoco>'''
m = mujoco.MjModel.from_xml_string(xml); d = mujoco.MjData(m); mujoco.mj_forward(m, d)
cam = Camera(Intrinsics.from_fovy(160, 120, 45), orbit_pose([0, 0, .05], .5, 30, 40))
a, b = raycast_depth(m, d, cam), render_depth(m, d, cam)
objects = np.isin(a.geom, [1, 2]) & (a.geom == b.geom)
print(json.dumps({"ok": True, "why": why, "n": int(objects.sum()), "same_ids": float((a.geom == b.geom).mean()),
                  "max_mm": float(1000 * np.max(np.abs(a.depth - b.depth)[objects]))}))
"""


@pytest.mark.parametrize("backend", ["egl", "osmesa"])
def test_gl_depth_agrees_with_raycast(backend):
    """Where an OpenGL backend exists, rendered and ray-cast depth agree to 1 mm on the object pixels
    (a box and a mesh: the renderer tessellates spheres and cylinders, ray casting does not, so those
    differ by the tessellation). Run in a subprocess because MUJOCO_GL is read when mujoco is imported."""
    env = {**os.environ, "MUJOCO_GL": backend, "PYOPENGL_PLATFORM": backend}
    run = subprocess.run([sys.executable, "-c", _GL_SCRIPT], env=env, capture_output=True, text=True, timeout=120)
    lines = [ln for ln in run.stdout.splitlines() if ln.startswith("{")]
    if run.returncode != 0 or not lines:
        pytest.skip(f"MUJOCO_GL={backend} unusable here: {run.stderr.strip().splitlines()[-1:]}")
    out = json.loads(lines[-1])
    if not out["ok"]:
        pytest.skip(out["why"])
    assert out["n"] > 500
    assert out["same_ids"] > 0.99
    assert out["max_mm"] < 1.0
