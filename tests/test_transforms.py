"""gfxlab.transforms against hand-derived matrices, the seed's worked results and
round-trip properties."""

import hypothesis.extra.numpy as hnp
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from jax.test_util import check_grads

import gfxlab
from gfxlab import transforms as tf

# JAX reports an exception raised while a compiled program runs as JaxRuntimeError or,
# on some dispatch paths, as ValueError; either carries the check's message.
JIT_ERRORS = (jax.errors.JaxRuntimeError, ValueError)


UNIT_SQUARE = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
finite = st.floats(-10, 10, allow_nan=False)


def test_translate_2d_and_3d_sizes(maybe_jit):
    m2 = maybe_jit(tf.translate)(jnp.array([2.0, -1.0]))
    m3 = maybe_jit(tf.translate)(jnp.array([1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(m2, [[1, 0, 2], [0, 1, -1], [0, 0, 1]])
    np.testing.assert_array_equal(m3[:3, 3], [1, 2, 3])
    assert m3.shape == (4, 4)


def test_translate_batches():
    offsets = jnp.arange(10.0).reshape(5, 2)
    mats = tf.translate(offsets)
    assert mats.shape == (5, 3, 3)
    np.testing.assert_array_equal(mats[:, :2, 2], offsets)


def test_rotate_quarter_turn():
    np.testing.assert_allclose(
        tf.apply(tf.rotate(jnp.pi / 2), jnp.array([[1.0, 0.0]])), [[0, 1]], atol=1e-15
    )


@pytest.mark.parametrize(
    ("fn", "point", "expected"),
    [
        (tf.rotate_x, [0, 1, 0], [0, 0, 1]),
        (tf.rotate_y, [0, 0, 1], [1, 0, 0]),
        (tf.rotate_z, [1, 0, 0], [0, 1, 0]),
    ],
)
def test_axis_rotations_are_right_handed(fn, point, expected):
    out = tf.apply(fn(jnp.pi / 2), jnp.array([point], float))
    np.testing.assert_allclose(out, [expected], atol=1e-15)


@pytest.mark.parametrize(
    ("axis", "fn"), [((1, 0, 0), tf.rotate_x), ((0, 1, 0), tf.rotate_y), ((0, 0, 1), tf.rotate_z)]
)
def test_rotate_axis_matches_axis_rotations(axis, fn):
    angle = 0.7
    np.testing.assert_allclose(
        tf.rotate_axis(jnp.array(axis, float) * 3, angle), fn(angle), atol=1e-14
    )


@given(hnp.arrays(np.float64, 3, elements=finite), st.floats(-7, 7))
def test_rotate_axis_is_orthonormal_and_fixes_axis(axis, angle):
    if np.linalg.norm(axis) < 1e-3:
        axis = np.array([0.0, 0.0, 1.0])
    m = np.asarray(tf.rotate_axis(axis, angle))[:3, :3]
    np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(m), 1.0, atol=1e-12)
    np.testing.assert_allclose(m @ axis, axis, atol=1e-9 * max(1, np.linalg.norm(axis)))


def test_scale_about_fixed_point_matches_seed_q2c():
    # Seed Q2c: T(xf, yf) S(sx, sy) T(-xf, -yf) = [[sx, 0, xf(1-sx)], [0, sy, yf(1-sy)], [0, 0, 1]]
    sx, sy, xf, yf = 2.0, 0.5, 3.0, -1.0
    expected = np.array([[sx, 0, xf * (1 - sx)], [0, sy, yf * (1 - sy)], [0, 0, 1]])
    got = tf.scale(jnp.array([sx, sy]), center=jnp.array([xf, yf]))
    np.testing.assert_allclose(got, expected)
    np.testing.assert_allclose(
        got,
        tf.compose(
            tf.translate(jnp.array([-xf, -yf])),
            tf.scale(jnp.array([sx, sy])),
            tf.translate(jnp.array([xf, yf])),
        ),
    )
    np.testing.assert_allclose(tf.apply(got, jnp.array([[xf, yf]])), [[xf, yf]])


def test_shear_2d_and_3d():
    np.testing.assert_array_equal(tf.shear(xy=2.0), [[1, 2, 0], [0, 1, 0], [0, 0, 1]])
    m = tf.shear(xy=1.0, zx=0.5)
    assert m.shape == (4, 4)
    np.testing.assert_allclose(tf.apply(m, jnp.array([[1.0, 2.0, 3.0]])), [[3.0, 2.0, 3.5]])


def test_seed_q2f_shear_of_unit_cube_row_vector_form():
    # The seed's matrix is written for row vectors, V' = V . T; in our convention it is T.T.
    t_row = np.array([[1, 1.5, 3, 0], [0.8, 0, 1, 0], [0.5, 1, 1, 0], [0, 0, 0, 1]])
    cube = np.array(
        [[x, y, z] for z in (1, 0) for (x, y) in ((0, 0), (1, 0), (1, 1), (0, 1))], float
    )
    expected = (np.c_[cube, np.ones(8)] @ t_row)[:, :3]
    np.testing.assert_allclose(tf.apply(tf.linear(t_row[:3, :3].T), cube), expected)
    np.testing.assert_allclose(tf.apply(jnp.array(t_row.T), cube), expected)
    # Vertex G = (1, 1, 0) (the key prints (1, 1, 1)): (1.8, 1.5, 4).
    np.testing.assert_allclose(
        tf.apply(jnp.array(t_row.T), jnp.array([1.0, 1.0, 0.0])), [1.8, 1.5, 4.0]
    )


def test_reflect():
    np.testing.assert_allclose(
        tf.apply(tf.reflection(jnp.array([0.0, 1.0])), jnp.array([[2.0, 3.0]])), [[2, -3]]
    )
    np.testing.assert_allclose(
        tf.apply(tf.reflection(jnp.array([1.0, -1.0])), jnp.array([[2.0, 3.0]])),
        [[3, 2]],
        atol=1e-15,
    )
    # Mirror about the plane z = 1.
    m = tf.reflection(jnp.array([0.0, 0.0, 2.0]), point=jnp.array([5.0, 5.0, 1.0]))
    np.testing.assert_allclose(tf.apply(m, jnp.array([[1.0, 2.0, 4.0]])), [[1, 2, -2]])
    np.testing.assert_allclose(m @ m, np.eye(4), atol=1e-15)


def test_compose_order_is_first_then():
    a, b, c = tf.translate(jnp.array([1.0, 0.0])), tf.rotate(0.3), tf.scale(jnp.array([2.0, 3.0]))
    np.testing.assert_allclose(tf.compose(a, b, c), c @ b @ a)
    p = jnp.array([[0.2, -0.4]])
    np.testing.assert_allclose(
        tf.apply(tf.compose(a, b, c), p), tf.apply(c, tf.apply(b, tf.apply(a, p)))
    )


def test_seed_q2b_translate_then_rotate_unit_square():
    m = tf.compose(tf.translate(jnp.array([1.0, 1.0])), tf.rotate(jnp.pi / 2))
    out = tf.apply(m, UNIT_SQUARE)
    # A'(-1/2, 1/2), B'(-1/2, 3/2) (the key misprints (-3/2, 3/2)), C'(-3/2, 3/2), D'(-3/2, 1/2)
    np.testing.assert_allclose(
        out, [[-0.5, 0.5], [-0.5, 1.5], [-1.5, 1.5], [-1.5, 0.5]], atol=1e-15
    )
    # The key's row-vector matrix T = T_T . T_R is our matrix transposed.
    np.testing.assert_allclose(m.T, [[0, 1, 0], [-1, 0, 0], [-1, 1, 1]], atol=1e-15)
    row_form = np.c_[UNIT_SQUARE, np.ones(4)] @ np.asarray(m.T)
    np.testing.assert_allclose(row_form[:, :2], out, atol=1e-15)


@given(hnp.arrays(np.float64, (6, 3), elements=finite), st.floats(-3, 3), st.floats(0.2, 3))
def test_round_trip_through_inverse(points, angle, s):
    m = tf.compose(
        tf.scale(jnp.array([s, 1.0, 2.0])),
        tf.rotate_axis(jnp.array([1.0, 2, 3]), angle),
        tf.translate(jnp.array([1.0, -2.0, 0.5])),
    )
    back = tf.apply(jnp.linalg.inv(m), tf.apply(m, points))
    np.testing.assert_allclose(back, points, atol=1e-9)


def test_apply_perspective_divide_and_single_point():
    m = jnp.eye(4).at[3, 3].set(0.0).at[3, 2].set(1.0)  # w = z
    np.testing.assert_allclose(tf.apply(m, jnp.array([2.0, 4.0, 2.0])), [1.0, 2.0, 1.0])


def test_apply_w_zero_is_finite_with_finite_gradient():
    m = jnp.eye(4).at[3, 3].set(0.0).at[3, 2].set(1.0)
    p = jnp.array([[1.0, 1.0, 0.0]])
    assert jnp.all(jnp.isfinite(tf.apply(m, p)))
    g = jax.grad(lambda q: tf.apply(m, q).sum())(p)
    assert jnp.all(jnp.isfinite(g))


def test_homogeneous_helpers():
    p = jnp.array([[1.0, 2.0]])
    np.testing.assert_array_equal(tf.to_homogeneous(p), [[1, 2, 1]])
    np.testing.assert_array_equal(tf.from_homogeneous(jnp.array([[2.0, 4.0, 2.0]])), [[1, 2]])


def test_window_to_viewport_matches_seed_q2a(maybe_jit):
    window, viewport = jnp.array([1.0, 2.0, 5.0, 4.0]), jnp.array([0.0, 0.0, 200.0, 100.0])
    m = maybe_jit(tf.window_to_viewport)(window, viewport)
    sx, sy = 200 / 4, 100 / 2
    # Seed's row-vector W = T S T^-1, transposed to our column convention.
    expected = np.array([[sx, 0, 0 - 1 * sx], [0, sy, 0 - 2 * sy], [0, 0, 1]])
    np.testing.assert_allclose(m, expected)
    np.testing.assert_allclose(
        tf.apply(m, jnp.array([[1.0, 2.0], [5.0, 4.0], [3.0, 3.0]])),
        [[0, 0], [200, 100], [100, 50]],
    )


_P3 = jnp.array([[0.3, -0.2, 0.5], [1.0, 2.0, -1.0]])
GRADIENT_CASES = {
    "translate": (lambda o: tf.apply(tf.translate(o), _P3), (jnp.array([0.1, 0.2, 0.3]),)),
    "rotate": (lambda a: tf.apply(tf.rotate(a), _P3[:, :2]), (0.4,)),
    "rotate_x": (lambda a: tf.apply(tf.rotate_x(a), _P3), (0.4,)),
    "rotate_y": (lambda a: tf.apply(tf.rotate_y(a), _P3), (0.4,)),
    "rotate_z": (lambda a: tf.apply(tf.rotate_z(a), _P3), (0.4,)),
    "rotate_axis": (tf.rotate_axis, (jnp.array([1.0, 2.0, 0.5]), 0.3)),
    "scale": (lambda s, c: tf.scale(s, center=c), (jnp.array([2.0, 3.0]), jnp.array([1.0, 1.0]))),
    "shear": (lambda k: tf.shear(xy=k, zx=k), (0.5,)),
    "linear": (tf.linear, (jnp.eye(3) * 2,)),
    "reflect": (
        lambda n, q: tf.reflection(n, point=q),
        (jnp.array([1.0, 2.0]), jnp.array([0.5, 0.0])),
    ),
    "compose": (lambda a, b: tf.compose(tf.rotate(a), tf.rotate(b)), (0.1, 0.2)),
    "apply": (lambda m: tf.apply(m, _P3), (jnp.eye(4).at[3, 2].set(0.1),)),
    "from_homogeneous": (tf.from_homogeneous, (jnp.array([[1.0, 2.0, 0.5]]),)),
    "window_to_viewport": (
        tf.window_to_viewport,
        (jnp.array([0.0, 0.0, 2.0, 3.0]), jnp.array([1.0, 1.0, 5.0, 4.0])),
    ),
}


@pytest.mark.parametrize("name", list(GRADIENT_CASES))
def test_gradients(name):
    fn, args = GRADIENT_CASES[name]
    # Jitted, so each derivative compiles once instead of dispatching op by op; reverse
    # mode against finite differences (second order is checked for the rotations below).
    check_grads(jax.jit(fn), args, order=1, modes=["rev"])


def test_degenerate_rotation_axis_gradient_is_finite():
    g = jax.grad(lambda ax: tf.rotate_axis(ax, 0.3).sum())(jnp.array([1e-30, 0.0, 0.0]))
    assert jnp.all(jnp.isfinite(g))


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: tf.translate(jnp.zeros(4)), "offset"),
        (lambda: tf.rotate_axis(jnp.zeros(2), 1.0), "axis"),
        (lambda: tf.rotate_axis(jnp.zeros(3), 1.0), "non-zero"),
        (lambda: tf.scale(jnp.ones(5)), "factors"),
        (lambda: tf.scale(jnp.ones(2), center=jnp.ones(3)), "center"),
        (lambda: tf.reflection(jnp.zeros(2)), "non-zero"),
        (lambda: tf.reflection(jnp.ones(2), point=jnp.ones(3)), "point"),
        (lambda: tf.linear(jnp.ones((2, 3))), "matrix"),
        (lambda: tf.compose(), "at least one"),
        (lambda: tf.compose(tf.rotate(1.0), tf.rotate_x(1.0)), "2D and 3D"),
        (lambda: tf.apply(jnp.eye(3), jnp.ones((4, 3))), "points"),
        (lambda: tf.apply(jnp.ones((3, 4)), jnp.ones((4, 3))), "square"),
        (
            lambda: tf.window_to_viewport(jnp.array([0, 0, 0, 1.0]), jnp.array([0, 0, 1, 1.0])),
            "window",
        ),
        (
            lambda: tf.window_to_viewport(jnp.array([0, 0, 1, 1.0]), jnp.array([0, 0, 1, 0.0])),
            "viewport",
        ),
        (
            lambda: tf.window_to_viewport(jnp.array([0, 0, 1.0]), jnp.array([0, 0, 1, 1.0])),
            "window",
        ),
        (lambda: tf.rotate(1j), "real"),
    ],
)
def test_bad_input_raises_clearly(call, message):
    with pytest.raises((ValueError, TypeError), match=message):
        call()


def test_degenerate_window_raises_under_jit():
    f = jax.jit(tf.window_to_viewport)
    with pytest.raises(Exception, match="positive width and height"):
        f(jnp.array([0.0, 0.0, 0.0, 1.0]), jnp.array([0.0, 0.0, 1.0, 1.0])).block_until_ready()


# --- rotation parametrisations (issue 18) and non-finite parameters (issue 17) ---------

from scipy.spatial.transform import Rotation  # noqa: E402

rotvecs = hnp.arrays(
    np.float64, (3,), elements=st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)
)
quats = hnp.arrays(
    np.float64, (4,), elements=st.floats(-2.0, 2.0, allow_nan=False, allow_infinity=False)
).filter(lambda q: np.linalg.norm(q) > 1e-3)


def _is_rotation(m):
    m = np.asarray(m)
    np.testing.assert_allclose(m.T @ m, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(m), 1.0, atol=1e-12)


@given(rotvecs)
def test_axis_angle_matches_scipy_and_round_trips(v):
    r = tf.rotation_from_axis_angle(v)
    _is_rotation(r)
    np.testing.assert_allclose(r, Rotation.from_rotvec(v).as_matrix(), atol=1e-12)
    back = np.asarray(tf.rotation_to_axis_angle(r))
    np.testing.assert_allclose(tf.rotation_from_axis_angle(back), r, atol=1e-12)
    if np.linalg.norm(v) < np.pi - 1e-6:
        np.testing.assert_allclose(back, v, atol=1e-9)
    np.testing.assert_allclose(back, Rotation.from_matrix(np.asarray(r)).as_rotvec(), atol=1e-9)


@given(quats)
def test_quaternion_matches_scipy_and_round_trips(q):
    r = tf.rotation_from_quaternion(q)
    _is_rotation(r)
    np.testing.assert_allclose(r, Rotation.from_quat(q[[1, 2, 3, 0]]).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(tf.rotation_from_quaternion(-q), r, atol=1e-12)
    back = np.asarray(tf.rotation_to_quaternion(r))
    unit = q / np.linalg.norm(q) * np.sign(q[0] if q[0] != 0 else 1)
    assert back[0] >= 0
    np.testing.assert_allclose(tf.rotation_from_quaternion(back), r, atol=1e-12)
    if abs(q[0]) > 1e-6:
        np.testing.assert_allclose(back, unit, atol=1e-9)


@given(rotvecs, rotvecs)
def test_6d_gram_schmidt_and_round_trip(a1, a2):
    r6 = np.concatenate([a1, a2])
    if np.linalg.norm(np.cross(a1, a2)) < 1e-3:
        return
    r = np.asarray(tf.rotation_from_6d(r6))
    _is_rotation(r)
    np.testing.assert_allclose(r[:, 0], a1 / np.linalg.norm(a1), atol=1e-12)
    assert np.dot(r[:, 1], a2) > 0  # a2 lies in the half-plane of the second column
    np.testing.assert_allclose(tf.rotation_to_6d(r), np.concatenate([r[:, 0], r[:, 1]]))
    np.testing.assert_allclose(tf.rotation_from_6d(tf.rotation_to_6d(r)), r, atol=1e-12)


def test_rotation_representations_agree_and_embed():
    v = jnp.array([0.3, -0.7, 1.1])
    r = tf.rotation_from_axis_angle(v)
    q = tf.rotation_to_quaternion(r)
    six = tf.rotation_to_6d(r)
    for values, name in [(v, "axis_angle"), (q, "quaternion"), (six, "6d"), (r, "matrix")]:
        np.testing.assert_allclose(tf.rotation_matrix(values, name), r, atol=1e-12)
        m = tf.rotation(values, representation=name)
        np.testing.assert_allclose(m[:3, :3], r, atol=1e-12)
        np.testing.assert_allclose(m[3], [0, 0, 0, 1])
    # the same rotation as rotate_axis, batched
    batch = jnp.array([[0.0, 0.0, 0.5], [0.0, 0.2, 0.0]])
    np.testing.assert_allclose(
        tf.rotation(batch), tf.rotate_axis(batch, jnp.linalg.norm(batch, axis=-1)), atol=1e-12
    )


@pytest.mark.parametrize(
    ("fn", "point"),
    [
        (tf.rotation_from_axis_angle, jnp.zeros(3)),
        (tf.rotation_from_axis_angle, jnp.array([1e-4, -2e-4, 5e-5])),
        (tf.rotation_from_axis_angle, jnp.array([0.4, -1.2, 2.0])),
        (tf.rotation_from_quaternion, jnp.array([1.0, 0.0, 0.0, 0.0])),
        (tf.rotation_from_quaternion, jnp.array([0.3, -0.5, 2.0, 0.1])),
        (tf.rotation_from_6d, jnp.array([1.0, 0.0, 0.0, 0.0, 1.0, 0.0])),
        (tf.rotation_from_6d, jnp.array([0.3, 1.0, -0.2, 2.0, 0.1, 0.5])),
        (lambda v: tf.rotation_to_axis_angle(tf.rotation_from_axis_angle(v)), jnp.zeros(3)),
        (lambda v: tf.rotation_to_axis_angle(tf.rotation_from_axis_angle(v)), jnp.ones(3)),
        (lambda v: tf.rotation_to_quaternion(tf.rotation_from_axis_angle(v)), jnp.zeros(3)),
        (lambda v: tf.rotation_to_6d(tf.rotation_from_axis_angle(v)), jnp.zeros(3)),
    ],
)
def test_rotation_gradients_are_finite_and_correct_at_the_identity(fn, point):
    # One compiled program per derivative (eagerly, each nested core compiles on its own).
    check_grads(jax.jit(fn), (point,), order=1, modes=["rev"])
    assert np.all(np.isfinite(np.asarray(jax.jit(jax.jacobian(fn))(point))))


def test_rodrigues_second_derivatives_at_the_identity():
    # The Taylor branches near angle 0 are exact to second order, not only in value.
    check_grads(jax.jit(tf.rotation_from_axis_angle), (jnp.zeros(3),), order=2, modes=["rev"])


def test_round_trip_jacobian_is_the_identity_at_zero_angle():
    jac = jax.jacobian(lambda v: tf.rotation_to_axis_angle(tf.rotation_from_axis_angle(v)))
    np.testing.assert_allclose(jac(jnp.zeros(3)), np.eye(3), atol=1e-12)


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (
            lambda: tf.rotation_from_axis_angle([jnp.nan, 0, 0]),
            ValueError,
            "`rotvec` must be finite",
        ),
        (lambda: tf.rotation_from_axis_angle(None), TypeError, "`rotvec` must be an array"),
        (lambda: tf.rotation_from_axis_angle(jnp.ones(4)), ValueError, r"`rotvec` must have shape"),
        (lambda: tf.rotation_from_quaternion(jnp.zeros(4)), ValueError, "`q` must be a non-zero"),
        (lambda: tf.rotation_from_quaternion([1, 0, jnp.inf, 0]), ValueError, "`q` must be finite"),
        (
            lambda: tf.rotation_from_6d(jnp.array([1.0, 0, 0, 2, 0, 0])),
            ValueError,
            "linearly independent",
        ),
        (lambda: tf.rotation_from_6d(jnp.zeros(6)), ValueError, "`r6` must hold two linearly"),
        (
            lambda: tf.rotation_to_quaternion(2 * jnp.eye(3)),
            ValueError,
            "`matrix` must be a rotation",
        ),
        (lambda: tf.rotation_to_axis_angle(-jnp.eye(3)), ValueError, "`matrix` must be a rotation"),
        (lambda: tf.rotation_matrix(jnp.zeros(3), "euler"), ValueError, "`representation` must be"),
        (lambda: tf.translate([jnp.nan, 0.0]), ValueError, "`offset` must be finite"),
        (lambda: tf.translate(None), TypeError, "`offset` must be an array"),
        (lambda: tf.rotate(jnp.inf), ValueError, "`angle` must be finite"),
        (lambda: tf.rotate_x(jnp.nan), ValueError, "`angle` must be finite"),
        (lambda: tf.rotate_axis([0, 0, 1], jnp.nan), ValueError, "`angle` must be finite"),
        (lambda: tf.rotate_axis([0, jnp.inf, 1], 1.0), ValueError, "`axis` must be finite"),
        (lambda: tf.scale([1.0, jnp.nan]), ValueError, "`factors` must be finite"),
        (lambda: tf.scale([1.0, 1.0], center=[0, jnp.inf]), ValueError, "`center` must be finite"),
        (lambda: tf.shear(xy=jnp.nan), ValueError, "`xy` must be finite"),
        (lambda: tf.linear(jnp.full((2, 2), jnp.inf)), ValueError, "`matrix` must be finite"),
        (lambda: tf.reflection([0.0, jnp.nan]), ValueError, "`normal` must be finite"),
        (
            lambda: tf.reflection([0.0, 1.0], point=[jnp.nan, 0]),
            ValueError,
            "`point` must be finite",
        ),
        (
            lambda: tf.compose(jnp.eye(3), jnp.full((3, 3), jnp.nan)),
            ValueError,
            r"`matrices\[1\]` must be finite",
        ),
        (
            lambda: tf.apply(jnp.eye(3), jnp.array([[jnp.nan, 0.0]])),
            ValueError,
            "`points` must be finite",
        ),
        (
            lambda: tf.from_homogeneous(jnp.array([[jnp.inf, 0.0, 1.0]])),
            ValueError,
            "`points` must be finite",
        ),
        (
            lambda: tf.window_to_viewport([0, 0, jnp.inf, 1], [0, 0, 1, 1]),
            ValueError,
            "`window` must be finite",
        ),
    ],
)
def test_bad_parameters_are_rejected_naming_the_argument(call, error, message):
    with pytest.raises(error, match=message):
        call()


@pytest.mark.parametrize(
    ("fn", "bad", "message"),
    [
        (tf.translate, jnp.array([jnp.nan, 0.0]), "`offset` must be finite"),
        (tf.rotate, jnp.array(jnp.inf), "`angle` must be finite"),
        (tf.rotation_from_axis_angle, jnp.array([0.0, jnp.nan, 0.0]), "`rotvec` must be finite"),
        (tf.rotation_from_quaternion, jnp.zeros(4), "`q` must be a non-zero quaternion"),
        (tf.rotation_from_6d, jnp.ones(6), "`r6` must hold two linearly independent"),
        (
            lambda m: tf.apply(m, jnp.ones((2, 2))),
            jnp.full((3, 3), jnp.nan),
            "`matrix` must be finite",
        ),
    ],
)
def test_bad_parameters_are_rejected_under_jit_with_the_same_message(fn, bad, message):
    with pytest.raises(JIT_ERRORS) as info:
        jax.jit(fn)(bad)
    assert gfxlab.check_message(info.value).startswith(message)
    with pytest.raises(ValueError, match=f"^{message}"):
        gfxlab.checked_jit(fn)(bad)
