"""gfxlab.viewing: OpenGL conventions, canonical view volume, cameras."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from gfxlab import transforms as tf
from gfxlab import viewing as vw


def test_look_at_sends_eye_to_origin_and_target_down_minus_z(maybe_jit):
    eye, target, up = (
        jnp.array([3.0, 2.0, 5.0]),
        jnp.array([-1.0, 0.5, 0.0]),
        jnp.array([0, 1.0, 0]),
    )
    view = maybe_jit(vw.look_at)(eye, target, up)
    np.testing.assert_allclose(tf.apply(view, eye), [0, 0, 0], atol=1e-12)
    t = tf.apply(view, target)
    np.testing.assert_allclose(t[:2], [0, 0], atol=1e-12)
    np.testing.assert_allclose(t[2], -np.linalg.norm(target - eye), rtol=1e-12)
    # The up vector stays in the upper half of the image plane, and the frame is rigid.
    up_cam = view[:3, :3] @ up
    assert up_cam[1] > 0 and abs(up_cam[0]) < 1e-12
    np.testing.assert_allclose(view[:3, :3] @ view[:3, :3].T, np.eye(3), atol=1e-12)


def test_look_at_matches_glu_formula():
    # gluLookAt: f = normalize(target - eye), s = f x up, u = s x f.
    eye, target, up = np.array([1.0, 2, 3]), np.array([0.0, 0, 0]), np.array([0.0, 0, 1])
    f = (target - eye) / np.linalg.norm(target - eye)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    np.testing.assert_allclose(vw.look_at(eye, target, up), m, atol=1e-12)


@pytest.mark.parametrize("kind", ["ortho", "frustum", "perspective"])
def test_near_and_far_plane_centres_go_to_minus_one_and_plus_one(kind):
    near, far = 0.5, 20.0
    if kind == "ortho":
        p = vw.orthographic(-2.0, 2.0, -1.0, 1.0, near, far)
    elif kind == "frustum":
        p = vw.frustum(-0.3, 0.3, -0.2, 0.2, near, far)
    else:
        p = vw.perspective(jnp.pi / 3, 1.5, near, far)
    ndc = vw.project(p, jnp.array([[0.0, 0.0, -near], [0.0, 0.0, -far]]))
    np.testing.assert_allclose(ndc, [[0, 0, -1], [0, 0, 1]], atol=1e-12)


def test_frustum_corners_map_to_cube_corners():
    l, r, b, t, n, f = -0.4, 0.6, -0.3, 0.5, 1.0, 10.0
    p = vw.frustum(l, r, b, t, n, f)
    corners_near = jnp.array([[l, b, -n], [r, t, -n]])
    corners_far = corners_near * f / n
    ndc = vw.project(p, jnp.concatenate([corners_near, corners_far]))
    np.testing.assert_allclose(ndc, [[-1, -1, -1], [1, 1, -1], [-1, -1, 1], [1, 1, 1]], atol=1e-12)
    assert bool(jnp.all(vw.in_view_volume(ndc, tolerance=1e-9)))


def test_orthographic_box_corners():
    p = vw.orthographic(1.0, 3.0, -1.0, 2.0, 1.0, 5.0)
    ndc = vw.project(p, jnp.array([[1.0, -1.0, -1.0], [3.0, 2.0, -5.0], [2.0, 0.5, -3.0]]))
    np.testing.assert_allclose(ndc, [[-1, -1, -1], [1, 1, 1], [0, 0, 0]], atol=1e-12)


def test_perspective_fov():
    # A point on the top edge of the field of view maps to y = 1.
    fov = 0.9
    p = vw.perspective(fov, 2.0, 0.1, 50.0)
    z = -4.0
    y = -z * np.tan(fov / 2)
    np.testing.assert_allclose(vw.project(p, jnp.array([[2 * y, y, z]]))[0, :2], [1, 1], atol=1e-12)


def test_in_view_volume():
    pts = jnp.array([[0.0, 0.0, 0.0], [1.0, -1.0, 1.0], [1.01, 0.0, 0.0], [0.0, 0.0, -1.5]])
    np.testing.assert_array_equal(vw.in_view_volume(pts), [True, True, False, False])


def test_ndc_to_pixels():
    px = vw.ndc_to_pixels(jnp.array([[-1.0, -1.0], [1.0, 1.0], [0.0, 0.0]]), (4, 8))
    np.testing.assert_allclose(px, [[-0.5, -0.5], [7.5, 3.5], [3.5, 1.5]])


def test_plane_projection_is_seed_matrix():
    np.testing.assert_array_equal(vw.plane_projection("z"), np.diag([1, 1, 0, 1]))
    np.testing.assert_array_equal(vw.plane_projection("y"), np.diag([1, 0, 1, 1]))
    np.testing.assert_array_equal(vw.plane_projection("x"), np.diag([0, 1, 1, 1]))


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("front", [1, 2, 0]),
        ("rear", [-1, 2, 0]),
        ("right", [-3, 2, 0]),
        ("left", [3, 2, 0]),
        ("top", [1, -3, 0]),
        ("bottom", [1, 3, 0]),
    ],
)
def test_orthographic_views(name, expected):
    p = jnp.array([[1.0, 2.0, 3.0]])
    np.testing.assert_allclose(tf.apply(vw.orthographic_view(name), p)[0], expected, atol=1e-12)


def test_camera_round_trip_and_pixels():
    cam = vw.Camera(jnp.array([0.0, 0.0, 5.0]), fov_y=jnp.pi / 2, aspect=1.0, near=1.0, far=10.0)
    np.testing.assert_allclose(cam.to_pixels(jnp.array([[0.0, 0.0, 0.0]]), (65, 65)), [[32, 32]])
    np.testing.assert_allclose(cam.depth(jnp.array([[0.0, 0.0, 0.0], [1.0, 1.0, 4.0]])), [5, 1])
    np.testing.assert_allclose(cam.matrix(), cam.projection_matrix() @ cam.view_matrix())
    # A point at the edge of the 90 degree field of view lands on the image border.
    np.testing.assert_allclose(cam.project(jnp.array([[5.0, 0.0, 0.0]]))[0, 0], 1.0, atol=1e-12)


def test_camera_is_a_pytree_that_jits_and_differentiates():
    cam = vw.Camera(jnp.array([0.5, 0.2, 4.0]))
    pts = jnp.array([[0.1, 0.2, 0.3], [-0.4, 0.1, 0.0]])
    leaves = jax.tree_util.tree_leaves(cam)
    assert len(leaves) == 7
    out = jax.jit(lambda c: c.to_pixels(pts, (32, 32)))(cam)
    np.testing.assert_allclose(out, cam.to_pixels(pts, (32, 32)), rtol=1e-12)
    check_grads(
        jax.jit(lambda eye: vw.Camera(eye).to_pixels(pts, (32, 32))),
        (jnp.array([0.5, 0.2, 4.0]),),
        order=1,
    )


_FRUSTUM = (-0.4, 0.6, -0.3, 0.5, 1.0, 10.0)
GRADIENT_CASES = {
    "frustum": (vw.frustum, _FRUSTUM),
    "orthographic": (vw.orthographic, _FRUSTUM),
    "perspective": (vw.perspective, (0.8, 1.3, 0.5, 9.0)),
    "look_at": (
        vw.look_at,
        (jnp.array([1.0, 2, 3]), jnp.array([0.1, 0, 0]), jnp.array([0, 1.0, 0])),
    ),
    "project": (
        lambda p: vw.project(vw.perspective(0.8, 1.3, 0.5, 9.0), p),
        (jnp.array([[0.1, 0.2, -2.0]]),),
    ),
    "ndc_to_pixels": (lambda p: vw.ndc_to_pixels(p, (8, 8)), (jnp.array([[0.1, 0.2]]),)),
}


@pytest.mark.parametrize("name", list(GRADIENT_CASES))
def test_gradients(name):
    fn, args = GRADIENT_CASES[name]
    check_grads(jax.jit(fn), args, order=2)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: vw.look_at(jnp.zeros(3), jnp.zeros(3), jnp.array([0, 1.0, 0])), "target - eye"),
        (lambda: vw.look_at(jnp.zeros(3), jnp.array([0, 1.0, 0]), jnp.array([0, 1.0, 0])), "up"),
        (lambda: vw.look_at(jnp.zeros(2), jnp.ones(2), jnp.ones(2)), "eye"),
        (lambda: vw.orthographic(1.0, 0.0, 0.0, 1.0, 0.1, 1.0), "right"),
        (lambda: vw.frustum(-1.0, 1.0, -1.0, 1.0, 0.0, 1.0), "near"),
        (lambda: vw.frustum(-1.0, 1.0, -1.0, 1.0, 2.0, 1.0), "far"),
        (lambda: vw.perspective(0.0, 1.0, 0.1, 1.0), "fov_y"),
        (lambda: vw.perspective(1.0, -1.0, 0.1, 1.0), "aspect"),
        (lambda: vw.in_view_volume(jnp.zeros((3, 2))), "ndc_points"),
        (lambda: vw.ndc_to_pixels(jnp.zeros((3, 2)), (0, 3)), "shape"),
        (lambda: vw.plane_projection("w"), "axis"),
        (lambda: vw.orthographic_view("isometric"), "name"),
        (lambda: vw.Camera(jnp.zeros(2)), "eye"),
    ],
)
def test_bad_input_raises_clearly(call, message):
    with pytest.raises((ValueError, TypeError), match=message):
        call()


def test_bad_value_raises_under_jit():
    with pytest.raises(Exception, match="near"):
        jax.jit(vw.perspective)(1.0, 1.0, -0.1, 1.0).block_until_ready()
