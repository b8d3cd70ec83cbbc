"""Under `jax_enable_x64` (switched on for the whole suite in conftest.py), Python-number
defaults follow the dtype of the user's arrays: float32 in, float32 out; float64 stays
float64. A default must never promote a user's float32 fields or results to float64."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gfxlab.raster import BeamPath, phosphor_frames, random_scan, raster_scan
from gfxlab.render import DirectionalLight, PointLight
from gfxlab.viewing import Camera

DTYPES = [np.float32, np.float64]


def _float_dtypes(tree):
    return {
        x.dtype for x in jax.tree.leaves(tree) if jnp.issubdtype(jnp.result_type(x), jnp.floating)
    }


def test_the_suite_runs_with_x64():
    assert jax.config.jax_enable_x64  # else these tests would pass without testing anything


@pytest.mark.parametrize("dtype", DTYPES)
def test_camera_defaults_follow_the_pose_dtype(dtype):
    eye = np.array([0.0, 1.0, 5.0], dtype)
    for camera in (
        Camera(eye),
        Camera(eye, [0, 0, 0], (0.0, 1.0, 0.0), fov_y=0.7, near=0.5, far=20.0),
        Camera.from_rotation(eye, np.array([0.1, 0.2, 0.0], dtype)),
    ):
        assert _float_dtypes(camera) == {np.dtype(dtype)}
        for matrix in (camera.view_matrix(), camera.projection_matrix()):
            assert matrix.dtype == dtype
        assert camera.project(jnp.zeros((2, 3), dtype)).dtype == dtype


def test_camera_arrays_lead_and_python_numbers_get_the_default_float():
    mixed = Camera(np.zeros(3, np.float32) + 5, near=np.float64(0.5))
    assert mixed.eye.dtype == np.float32 and mixed.near.dtype == np.float64
    assert mixed.far.dtype == np.float64  # the lens follows its one array
    plain = Camera((0.0, 0.0, 5.0))
    assert _float_dtypes(plain) == {np.dtype(np.float64)}  # JAX's default float under x64


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("light", [PointLight, DirectionalLight])
def test_light_intensity_default_follows_the_light(light, dtype):
    lamp = light(np.array([1.0, 2.0, 3.0], dtype))
    assert _float_dtypes(lamp) == {np.dtype(dtype)}
    assert lamp.intensity == 1
    wi, irradiance = lamp.incident(jnp.zeros((4, 3), dtype))
    assert wi.dtype == dtype and irradiance.dtype == dtype
    coloured = light(np.ones(3, dtype), np.array([1.0, 0.5, 0.25], np.float32))
    assert coloured.intensity.dtype == np.result_type(dtype, np.float32)


@pytest.mark.parametrize("dtype", DTYPES)
def test_beam_paths_and_phosphor_keep_the_dtype(dtype):
    beams = [
        raster_scan(np.full((3, 4), 0.5, dtype)),
        random_scan(np.ones((2, 2, 2), dtype)),
        BeamPath(np.ones((3, 2), dtype), np.ones(3, dtype), np.ones(3, bool)),
    ]
    for beam in beams:
        assert _float_dtypes(beam) == {np.dtype(dtype)}
        frames = phosphor_frames(beam, (3, 4), num_frames=2)  # default decay 0.98
        assert frames.dtype == dtype
        assert phosphor_frames(beam, (3, 4), num_frames=2, decay=0.5).dtype == dtype
    wide = phosphor_frames(beams[0], (3, 4), num_frames=2, decay=np.float64(0.5))
    assert wide.dtype == np.result_type(dtype, np.float64)  # an array decay is the user's
