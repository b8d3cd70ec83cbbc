"""gfxlab.viewing: OpenGL conventions, canonical view volume, cameras."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

import gfxlab
from gfxlab import transforms as tf
from gfxlab import viewing as vw

# JAX reports an exception raised while a compiled program runs as JaxRuntimeError or,
# on some dispatch paths, as ValueError; either carries the check's message.
JIT_ERRORS = (jax.errors.JaxRuntimeError, ValueError)


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
    assert bool(jnp.all(vw.in_view_volume(ndc, tol=1e-9)))


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
    check_grads(jax.jit(fn), args, order=1, modes=["rev"])


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (
            lambda: vw.look_at(jnp.zeros(3), jnp.zeros(3), jnp.array([0, 1.0, 0])),
            "`target` equals `eye`",
        ),
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


# --- cameras from rotation parametrisations (issue 18) ---------------------------------

from gfxlab.fit import fit  # noqa: E402

CUBE = jnp.array(
    [[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)]
) * jnp.array([1.0, 0.7, 0.4])


@pytest.mark.parametrize("representation", ["axis_angle", "quaternion", "6d", "matrix"])
def test_camera_from_rotation_equals_look_at(representation):
    eye = jnp.array([2.0, 1.5, 4.0])
    look = vw.Camera(eye, (0.0, 0.2, 0.0), (0.0, 1.0, 0.0), fov_y=0.9, near=0.5, far=20.0)
    frame = jnp.swapaxes(look.view_matrix()[:3, :3], 0, 1)  # camera-to-world
    values = {
        "axis_angle": tf.rotation_to_axis_angle(frame),
        "quaternion": tf.rotation_to_quaternion(frame),
        "6d": tf.rotation_to_6d(frame),
        "matrix": frame,
    }[representation]
    cam = vw.Camera.from_rotation(eye, values, representation, fov_y=0.9, near=0.5, far=20.0)
    np.testing.assert_allclose(cam.view_matrix(), look.view_matrix(), atol=1e-12)
    np.testing.assert_allclose(cam.project(CUBE), look.project(CUBE), atol=1e-12)
    # target/up are derived for reference: the same viewing direction and up
    direction = (look.target - look.eye) / jnp.linalg.norm(look.target - look.eye)
    np.testing.assert_allclose(cam.target - cam.eye, direction, atol=1e-12)
    assert cam.fixed_fields() == ("target", "up") and look.fixed_fields() == ()


def test_zero_rotation_looks_down_minus_z_with_finite_gradients():
    cam = vw.Camera.from_rotation(jnp.zeros(3), jnp.zeros(3))
    np.testing.assert_allclose(cam.view_matrix(), np.eye(4), atol=1e-15)

    def depth_of_point(rotvec):
        c = vw.Camera.from_rotation(jnp.array([0.0, 0.0, 5.0]), rotvec)
        return c.project(jnp.array([[0.3, 0.2, 0.0]]))[0]

    check_grads(depth_of_point, (jnp.zeros(3),), order=1, modes=["rev", "fwd"])


def test_fit_recovers_a_camera_rotation_and_holds_derived_fields():
    eye = jnp.array([0.5, 0.5, 6.0])
    truth = vw.Camera.from_rotation(eye, jnp.array([0.1, -0.15, 0.05]))
    observed = truth.to_pixels(CUBE, (64, 64))
    start = vw.Camera.from_rotation(eye, jnp.zeros(3))
    result = fit(
        lambda cam: cam.to_pixels(CUBE, (64, 64)) - observed,
        start,
        fixed=lambda leaf: leaf.ndim == 0,  # the lens; eye and rotation are fitted
        max_steps=60,
    )
    np.testing.assert_allclose(result.params.rotation, truth.rotation, atol=1e-6)
    np.testing.assert_allclose(result.params.eye, eye, atol=1e-6)
    # target and up are derived from the rotation: fit holds them (fixed_fields)
    np.testing.assert_array_equal(result.params.target, start.target)
    np.testing.assert_array_equal(result.params.up, start.up)


# --- bad camera parameters name the right argument (issue 17) --------------------------

NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: vw.look_at([INF, 0, 0], [0, 0, 0], [0, 1, 0]), ValueError, "`eye` must be finite"),
        (
            lambda: vw.look_at([0, 0, 1], [0, NAN, 0], [0, 1, 0]),
            ValueError,
            "`target` must be finite",
        ),
        (lambda: vw.look_at([0, 0, 1], [0, 0, 0], [0, 0, 0]), ValueError, "`up` must be non-zero"),
        (lambda: vw.look_at(None, [0, 0, 0], [0, 1, 0]), TypeError, "`eye` must be an array"),
        (lambda: vw.Camera([0, 0, 5.0], near=-1.0), ValueError, "`near` must be positive"),
        (
            lambda: vw.Camera([0, 0, 5.0], near=2.0, far=1.0),
            ValueError,
            "`far` must be greater than `near`",
        ),
        (lambda: vw.Camera([0, 0, 5.0], fov_y=NAN), ValueError, "`fov_y` must be finite"),
        (
            lambda: vw.Camera([0, 0, 5.0], fov_y=4.0),
            ValueError,
            r"`fov_y` must be in \(0, 3.14159\)",
        ),
        (lambda: vw.Camera([0, 0, 5.0], aspect=0.0), ValueError, "`aspect` must be > 0"),
        (lambda: vw.Camera([0, 0, 5.0], far=INF), ValueError, "`far` must be finite"),
        (
            lambda: vw.Camera([0, 0, 5.0], up=[0, 0, 1.0]),
            ValueError,
            "`up` must be non-zero and not parallel",
        ),
        (lambda: vw.Camera([0, 0, 0.0]), ValueError, "`target` equals `eye`"),
        (lambda: vw.Camera([0, NAN, 5.0]), ValueError, "`eye` must be finite"),
        (lambda: vw.Camera(None), TypeError, "`eye` must be an array"),
        (lambda: vw.Camera([0, 0, 5.0], target=None), TypeError, "`target` must be an array"),
        (
            lambda: vw.Camera.from_rotation([0, 0, 5.0], [NAN, 0, 0]),
            ValueError,
            "`rotation` must be finite",
        ),
        (
            lambda: vw.Camera.from_rotation([0, 0, 5.0], jnp.zeros(4), "quaternion"),
            ValueError,
            "`rotation` must be a non-zero quaternion",
        ),
        (
            lambda: vw.Camera.from_rotation([0, 0, 5.0], jnp.zeros(3), "euler"),
            ValueError,
            "`representation` must be",
        ),
        (lambda: vw.perspective(1.0, 1.0, -1.0, 10.0), ValueError, "`near` must be positive"),
        (lambda: vw.frustum(-1, 1, -1, 1, -1.0, 10.0), ValueError, "`near` must be positive"),
        (lambda: vw.orthographic(0, 1, 0, 1, 0, NAN), ValueError, "`far` must be finite"),
        (
            lambda: vw.in_view_volume(jnp.zeros(3), tol=-1.0),
            ValueError,
            "`tol` must be >= 0",
        ),
        (
            lambda: vw.in_view_volume(jnp.array([NAN, 0, 0])),
            ValueError,
            "`ndc_points` must be finite",
        ),
        (
            lambda: vw.ndc_to_pixels(jnp.zeros(2), (10**9, 10**9)),
            ValueError,
            r"`shape\[0\]` must be <=",
        ),
        (lambda: vw.plane_projection(["z"]), ValueError, "`axis` must be 'x', 'y' or 'z'"),
        (lambda: vw.orthographic_view(None), ValueError, "`name` must be one of"),
    ],
)
def test_bad_camera_parameters_name_the_argument(call, error, message):
    with pytest.raises(error, match=message):
        call()


@pytest.mark.parametrize(
    ("fn", "bad", "message"),
    [
        (
            lambda e: vw.look_at(e, jnp.zeros(3), jnp.array([0, 1.0, 0])),
            jnp.array([INF, 0, 0]),
            "`eye` must be finite",
        ),
        (lambda n: vw.perspective(1.0, 1.0, n, 10.0), jnp.array(-1.0), "`near` must be positive"),
        (
            lambda n: vw.Camera(jnp.array([0, 0, 5.0]), near=n).matrix(),
            jnp.array(-1.0),
            "`near` must be positive",
        ),
        (
            lambda f: vw.Camera(jnp.array([0, 0, 5.0]), fov_y=f).matrix(),
            jnp.array(NAN),
            "`fov_y` must be finite",
        ),
    ],
)
def test_bad_camera_parameters_under_jit_same_message(fn, bad, message):
    with pytest.raises(JIT_ERRORS) as info:
        jax.jit(fn)(bad)
    assert gfxlab.check_message(info.value).startswith(message)
    with pytest.raises(ValueError, match=f"^{message}"):
        gfxlab.checked_jit(fn)(bad)
