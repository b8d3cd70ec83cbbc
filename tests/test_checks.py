"""The shared check layer, through the public functions that use it: every check gives
the same message eagerly and under jit (`jax.jit`, `gfxlab.checked_jit`,
`equinox.filter_jit`, `jax.vmap`), passes good values and keeps gradients.

Each case calls one public function whose argument check is the one named: a finite
check (`color.planck_total_radiance`), a custom value check (`planck_total_radiance`'s
positive temperature, `mesh.check_faces`' index range), the range checks in their forms
(a `Mesh`'s colours in a closed interval, NaN too, `viewing.perspective`'s open
interval and half-line, `viewing.in_view_volume`'s `tol`),
`render.soft_silhouette_dense`'s positive `sigma`, `transforms.window_to_viewport`'s
rectangle and `curves.bernstein`'s parameter range.
"""

import re

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

import gfxlab
from gfxlab import clipping, color, curves, jpeg, mesh, raster, render, transforms, viewing
from gfxlab.brdf import lambert

# JAX reports an exception raised while a compiled program runs as JaxRuntimeError or,
# on some dispatch paths, as ValueError; either carries the check's message.
JIT_ERRORS = (jax.errors.JaxRuntimeError, ValueError)

NAN = float("nan")
INF = float("inf")

TRIANGLE = jnp.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
FACES = jnp.array([[0, 1, 2]])
VIEWPORT = jnp.array([0.0, 0.0, 640.0, 480.0])
FLAT = jnp.array([[0.5, 0.5], [3.0, 0.5], [0.5, 3.0]])  # a 2D triangle, pixel units


def _planck(t):
    return color.planck_total_radiance(t)


def _mesh_colors(c):
    return mesh.Mesh(TRIANGLE, FACES, colors=c).colors


def _fov(f):
    return viewing.perspective(f, 1.5, 0.1, 10.0)


def _aspect(a):
    return viewing.perspective(1.0, a, 0.1, 10.0)


def _tol(t):
    return viewing.in_view_volume(jnp.zeros((2, 3)), tol=t)


def _sigma(s):
    return render.soft_silhouette_dense(FLAT, FACES, (4, 4), sigma=s)


def _window(w):
    return transforms.window_to_viewport(w, VIEWPORT)


def _faces(f):
    return mesh.check_faces(f, 3)


def _bezier_u(u):
    return curves.bernstein(3, u)


COLOURS = [
    [0.1, 0.2, 0.3],
    [0.5, 0.5, 0.5],
    [0.9, 0.1, 0.25],
]  # inside [0, 1]: a finite difference stays valid

# (public function of one traced array, a good input, a bad input, the expected message)
VALUE_CHECKS = [
    (_planck, [1.0, 2.0], [1.0, NAN], "`temperature` must be finite (no NaN or inf)"),
    (_planck, [1.0, 2.0], [INF, 2.0], "`temperature` must be finite (no NaN or inf)"),
    (_planck, [1.0, 2.0], [3.0, -1.0], "`temperature` must be positive (kelvin)"),
    (_faces, [[0, 1, 2]], [[0, 1, 5]], "`faces` must index the 3 vertices (0 <= index < 3)"),
    (
        _mesh_colors,
        COLOURS,
        [[0.1, 0.2, 0.3], [0.5, NAN, 0.5], [0.9, 0.1, 0.25]],
        "`colors` must be in [0, 1] (colour values)",
    ),
    (
        _mesh_colors,
        COLOURS,
        [[0.1, 0.2, 0.3], [0.5, 1.5, 0.5], [0.9, 0.1, 0.25]],
        "`colors` must be in [0, 1] (colour values)",
    ),
    (_fov, 1.0, float(np.pi), "`fov_y` must be in (0, 3.14159) (radians)"),
    (_fov, 1.0, 0.0, "`fov_y` must be in (0, 3.14159) (radians)"),
    (_aspect, 1.5, -1.0, "`aspect` must be > 0 and not NaN (width / height)"),
    (_tol, 0.5, -1.0, "`tol` must be >= 0 and not NaN"),
    (_sigma, 0.5, 0.0, "`sigma` must be finite and > 0 (in pixels^2)"),
    (_sigma, 0.5, INF, "`sigma` must be finite and > 0 (in pixels^2)"),
    (
        _window,
        [0.0, 0.0, 2.0, 1.0],
        [0.0, 0.0, -1.0, 1.0],
        "`window` must be (xmin, ymin, xmax, ymax) with xmax > xmin and ymax > ymin "
        "(a rectangle with positive width and height)",
    ),
    (
        _window,
        [0.0, 0.0, 2.0, 1.0],
        [0.0, 0.0, NAN, 1.0],
        "`window` must be finite (no NaN or inf)",
    ),
    (
        _bezier_u,
        [0.1, 0.5, 0.9],
        [0.0, 1.5, 1.0],
        "`u` must lie in [0, 1], the parameter range of a Bezier curve",
    ),
]
IDS = [f"{i}-{m[:20]}" for i, (*_, m) in enumerate(VALUE_CHECKS)]
# Each function once, with its good input (`soft_silhouette_dense` on good input, eagerly
# and under jit: test_render_soft).
GOOD = [c for c in {fn: (fn, good) for fn, good, _, _ in VALUE_CHECKS}.values() if c[0] != _sigma]
GOOD_IDS = [fn.__name__ for fn, _ in GOOD]
# One differentiable function per check helper: `check_finite` and `value_error_if`,
# `check_range`, `check_rect`, the curves' own range check. (`positive`:
# `soft_silhouette_dense`'s gradients pass check_grads in test_render_soft.)
DIFFERENTIABLE = [
    (fn, good) for fn, good in GOOD if fn in (_planck, _mesh_colors, _window, _bezier_u)
]
# The cases of an elementwise function (a batch of inputs is a batch of results).
ELEMENTWISE = [c for c in VALUE_CHECKS if c[0] in (_planck, _faces)]


def _array(value):
    return jnp.asarray(value)


@pytest.mark.parametrize(("fn", "good", "bad", "message"), VALUE_CHECKS, ids=IDS)
def test_value_checks_eager(fn, good, bad, message):
    with pytest.raises(ValueError, match=re.escape(message)) as info:
        fn(_array(bad))
    assert str(info.value) == message
    assert gfxlab.check_message(info.value) == message


@pytest.mark.parametrize(("fn", "good", "bad", "message"), VALUE_CHECKS, ids=IDS)
def test_value_checks_under_jax_jit(fn, good, bad, message):
    """JAX wraps the error in JaxRuntimeError; the message is in it, recoverable."""
    with pytest.raises(JIT_ERRORS, match=re.escape(message)) as info:
        jax.block_until_ready(jax.jit(fn)(_array(bad)))
    assert gfxlab.check_message(info.value) == message


@pytest.mark.parametrize(("fn", "good", "bad", "message"), VALUE_CHECKS, ids=IDS)
def test_value_checks_under_checked_jit_and_filter_jit(fn, good, bad, message):
    with pytest.raises(ValueError, match=re.escape(message)) as info:
        gfxlab.checked_jit(fn)(_array(bad))
    assert str(info.value) == message
    with pytest.raises(eqx.EquinoxRuntimeError, match=re.escape(message)) as info2:
        jax.block_until_ready(eqx.filter_jit(fn)(_array(bad)))
    assert gfxlab.check_message(info2.value) == message


@pytest.mark.parametrize(("fn", "good", "bad", "message"), ELEMENTWISE)
def test_value_checks_under_vmap(fn, good, bad, message):
    good, bad = _array(good), _array(bad)
    batch = jnp.stack([good, good])
    expected = fn(good)
    for row in jax.vmap(fn)(batch):
        np.testing.assert_array_equal(row, expected)
    with pytest.raises(Exception, match=re.escape(message)) as info:
        jax.block_until_ready(jax.vmap(fn)(jnp.stack([good, bad])))
    assert gfxlab.check_message(info.value) == message


@pytest.mark.parametrize(("fn", "good"), GOOD, ids=GOOD_IDS)
def test_value_checks_pass_good_values(fn, good):
    eager = fn(_array(good))
    np.testing.assert_array_equal(jax.jit(fn)(_array(good)), eager)
    np.testing.assert_array_equal(gfxlab.checked_jit(fn)(_array(good)), eager)
    assert np.all(np.isfinite(np.asarray(eager, float)))


@pytest.mark.parametrize(
    ("fn", "good"), DIFFERENTIABLE, ids=[fn.__name__ for fn, _ in DIFFERENTIABLE]
)
def test_value_checks_keep_gradients(fn, good):
    loss = jax.jit(lambda x: jnp.sum(fn(x) ** 2))
    check_grads(loss, (_array(good),), order=1, modes=["rev"])


def test_checked_jit_lets_other_errors_through_and_takes_jit_options():
    @gfxlab.checked_jit(static_argnames="n")
    def tile(x, n):
        return jnp.tile(color.planck_total_radiance(x), n)

    assert tile(jnp.ones(2), n=3).shape == (6,)
    with pytest.raises(ValueError, match="^`temperature` must be finite"):
        tile(jnp.array([NAN]), n=2)
    with pytest.raises(TypeError):
        gfxlab.checked_jit(lambda x: x + "a")(1.0)


def test_check_message_of_other_errors_is_none():
    assert gfxlab.check_message(RuntimeError("boom")) is None
    assert gfxlab.check_message(KeyError("k")) is None


# --- static arguments: sizes, shapes, flags -----------------------------------------

U = jnp.array([0.25])


@pytest.mark.parametrize(
    ("value", "error", "message"),
    [
        (None, TypeError, "`n` must be an int, got None"),
        ("3", TypeError, "`n` must be an int, got '3'"),
        (2.5, TypeError, "`n` must be an int, got 2.5"),
        (INF, TypeError, "`n` must be an int, got inf"),
        (NAN, TypeError, "`n` must be an int, got nan"),
        (True, TypeError, "`n` must be an int, got True"),
        (-1, ValueError, "`n` must be >= 0, got -1"),
        (10**30, ValueError, "`n` must be <= 1024 (a documented size limit), got 10000"),
    ],
)
def test_static_int_rejects(value, error, message):
    """`curves.bernstein`'s degree `n`: a static int in [0, 1024]."""
    with pytest.raises(error, match=re.escape(message)):
        curves.bernstein(value, U)


def test_static_int_accepts_integral_values_and_refuses_tracers():
    assert curves.bernstein(4.0, U).shape == (1, 5)
    assert curves.bernstein(np.int64(5), U).shape == (1, 6)
    assert curves.bernstein(jnp.asarray(6), U).shape == (1, 7)
    assert curves.bernstein(0, U).shape == (1, 1)  # both bounds are allowed
    assert curves.bernstein(1024, U).shape == (1, 1025)
    with pytest.raises(TypeError, match="`n` sets an array size"):
        jax.jit(lambda n: curves.bernstein(n, U))(3)


def test_static_shape_and_allocation_limit():
    """`viewing.ndc_to_pixels`' image `shape`, `jpeg.blocks`' allocation."""
    points = jnp.array([[1.0, 1.0], [-1.0, 0.0]])
    expected = viewing.ndc_to_pixels(points, (4, 5))
    np.testing.assert_array_equal(expected, [[4.5, 3.5], [-0.5, 1.5]])
    np.testing.assert_array_equal(viewing.ndc_to_pixels(points, (4, 5, 3)), expected)
    with pytest.raises(ValueError, match=re.escape("`shape[0]` must be >= 1, got 0")):
        viewing.ndc_to_pixels(points, (0, 5))
    with pytest.raises(
        ValueError,
        match=re.escape("`shape` asks for 1099511627776 array elements, more than gfxlab's limit"),
    ):
        viewing.ndc_to_pixels(points, (2**20, 2**20))
    with pytest.raises(ValueError, match=re.escape("`shape` must be an image shape (H, W)")):
        viewing.ndc_to_pixels(points, "ab")
    # an array of sizes, as `np.array(image.shape)` gives, is a shape like a list
    np.testing.assert_array_equal(viewing.ndc_to_pixels(points, np.array([4, 5])), expected)
    np.testing.assert_array_equal(viewing.ndc_to_pixels(points, jnp.array([4, 5, 3])), expected)
    with pytest.raises(ValueError, match=re.escape("`shape` must be an image shape (H, W)")):
        viewing.ndc_to_pixels(points, np.array([[16, 12]]))
    with pytest.raises(TypeError, match=re.escape("`shape[1]` must be an int, got 12.5")):
        viewing.ndc_to_pixels(points, np.array([16.0, 12.5]))
    with pytest.raises(TypeError, match=re.escape("`shape` sets an array size")):
        jax.jit(lambda s: viewing.ndc_to_pixels(points, s))(jnp.array([16, 12]))
    assert jpeg.blocks(jnp.ones((2, 9, 9)), size=8).shape == (2, 2, 2, 8, 8)
    with pytest.raises(
        ValueError,
        match=re.escape(
            "`size` asks for 209715200 array elements, more than gfxlab's limit of "
            "134217728 per array (1 GiB of float64): ask for less, or work in pieces"
        ),
    ):
        jpeg.blocks(jnp.ones((200, 1, 1)), size=1024)


def test_static_bool_flags():
    frame = jnp.full((2, 3), 0.5)
    assert raster.raster_scan(frame, interlaced=np.bool_(True)).on.shape == (
        raster.raster_scan(frame, interlaced=True).on.shape
    )
    for flag in ("no", 1, None):
        with pytest.raises(TypeError, match=re.escape("`interlaced` must be True or False, got")):
            raster.raster_scan(frame, interlaced=flag)


# --- numbers: conversions and dtypes -------------------------------------------------


@pytest.mark.parametrize(
    ("value", "error", "message"),
    [
        (None, TypeError, "`offset` must be an array of numbers, got None"),
        ("abc", TypeError, "`offset` must be an array of numbers, got str"),
        (b"ab", TypeError, "`offset` must be an array of numbers, got bytes"),
        ({"k": 1}, TypeError, "`offset` must be an array of numbers, got dict"),
        ([1 + 2j, 0], TypeError, "`offset` must be real"),
        (np.array(["x", "y"]), TypeError, "`offset` must be an array of numbers"),
        ([[1, 2], [3]], ValueError, "`offset` must be a rectangular array"),
        ([2**100, 0], ValueError, "`offset` holds a number too large"),
    ],
)
def test_as_float_rejects(value, error, message):
    """`transforms.translate`'s `offset`."""
    with pytest.raises(error, match=re.escape(message)):
        transforms.translate(value)


def test_as_float_and_common_float_dtypes():
    """Integers and booleans become the default float (float64 here: x64 is on); a float32
    array stays float32; several arguments share one dtype."""
    assert color.planck_total_radiance(3).dtype == jnp.float64
    assert color.planck_total_radiance([True, True]).dtype == jnp.float64
    assert color.planck_total_radiance(jnp.ones(2, jnp.float32)).dtype == jnp.float32
    assert transforms.translate(np.ones(2, np.float32)).dtype == jnp.float32
    window = jnp.array([0.0, 0.0, 2.0, 1.0], jnp.float32)
    assert transforms.window_to_viewport(window, window).dtype == jnp.float32
    assert transforms.window_to_viewport(window, np.asarray(VIEWPORT)).dtype == jnp.float64
    with pytest.raises(
        TypeError, match=re.escape("`aspect` must be an array of numbers, got None")
    ):
        viewing.perspective(1.0, None, 0.1, 10.0)


def test_shape_checks():
    x = jnp.ones((5, 2, 3))
    with pytest.raises(
        ValueError, match=re.escape("`segments` must have shape (..., 2, 2), got shape (5, 2, 3)")
    ):
        clipping.cohen_sutherland(x, VIEWPORT)
    with pytest.raises(
        ValueError,
        match=re.escape("`faces` must be a 2-D array of shape (any, 3), got shape (5, 2, 3)"),
    ):
        mesh.check_faces(x.astype(int), 3)
    with pytest.raises(
        ValueError, match=re.escape("`frame_buffer` must be a 2-D array (any sizes), got shape")
    ):
        raster.raster_scan(x)  # not "(n, n)": nothing says the sizes are equal
    with pytest.raises(
        ValueError,
        match=re.escape("`vertices` must have shape (..., any, 2) (at least 2 dimensions)"),
    ):
        clipping.polygon_area(jnp.ones(4))
    with pytest.raises(
        ValueError, match=re.escape("`window` must have shape (4,), got shape (3,)")
    ):  # a one-entry shape is written as a tuple
        transforms.window_to_viewport(jnp.ones(3), VIEWPORT)
    with pytest.raises(
        ValueError, match=re.escape("`offset` must have shape (..., 2 or 3) (a 2D or 3D offset)")
    ):
        transforms.translate(jnp.ones(4))
    with pytest.raises(ValueError, match=re.escape("`offset` must have shape (..., 2 or 3)")):
        transforms.translate(1.0)
    # under jit shapes are static, so the same ValueError is raised at trace time
    with pytest.raises(ValueError, match=re.escape("`offset` must have shape (..., 2 or 3)")):
        jax.jit(transforms.translate)(jnp.ones(4))
    # `what` names where an expected size comes from (so both arguments are named)
    face_index = jnp.zeros((2, 2), int)
    message = (
        "`barycentrics` must have shape (2, 2, 3) (the shape of `face_index`, then 3), "
        "got shape (2, 3, 3)"
    )
    with pytest.raises(ValueError, match=re.escape(message)):
        render.interpolate(jnp.ones((3, 2)), FACES, face_index, jnp.ones((2, 3, 3)))
    with pytest.raises(ValueError, match=re.escape(message)):
        jax.jit(lambda b: render.interpolate(jnp.ones((3, 2)), FACES, face_index, b))(
            jnp.ones((2, 3, 3))
        )


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (None, "`faces` must be an integer array of vertex indices, got None"),
        ("abc", "`faces` must be an integer array of vertex indices, got 'abc'"),
        (["a", "b"], "`faces` must be an integer array of vertex indices, got list"),
        ([[1, 2], [3]], "`faces` must be an integer array of vertex indices, got list"),
        (np.array(["a"]), "`faces` must be an integer array of vertex indices, got ndarray"),
        (object(), "`faces` must be an integer array of vertex indices, got object"),
        (np.zeros((1, 3)), "`faces` must be an integer array of vertex indices, got dtype float"),
        (
            jnp.zeros((1, 3), bool),
            "`faces` must be an integer array of vertex indices, got dtype bool",
        ),
        (1.5, "`faces` must be an integer array of vertex indices, got dtype float"),
    ],
)
def test_as_int_rejects(value, message):
    """`render.interpolate`'s `faces`."""
    with pytest.raises(TypeError, match=re.escape(message)):
        render.interpolate(jnp.ones((3, 2)), value, jnp.zeros(2, int), jnp.ones((2, 3)))


def test_as_int_keeps_integer_dtypes_eagerly_and_under_jit():
    attributes = jnp.array([[1.0, 10.0], [2.0, 20.0], [3.0, 30.0]])
    face_index = jnp.array([0, -1])
    bary = jnp.array([[0.5, 0.25, 0.25], [1.0, 0.0, 0.0]])
    expected = [[1.75, 17.5], [0.0, 0.0]]
    for faces in ([[0, 1, 2]], np.array([[0, 1, 2]], np.uint8)):  # a list, a narrow dtype
        np.testing.assert_allclose(
            render.interpolate(attributes, faces, face_index, bary), expected
        )
    index = np.array([0, -1], np.int8)
    np.testing.assert_allclose(render.interpolate(attributes, FACES, index, bary), expected)
    traced = jax.jit(lambda f: render.interpolate(attributes, f, face_index, bary))(FACES)
    np.testing.assert_allclose(traced, expected)
    with pytest.raises(
        TypeError, match=re.escape("`faces` must be an integer array of vertex indices, got dtype")
    ):
        jax.jit(lambda f: render.interpolate(attributes, f, face_index, bary))(jnp.zeros((1, 3)))


# --- safe math: finite values and gradients where a formula divides by zero ----------


def test_safe_norm_and_normalize_have_finite_gradients_at_zero():
    """`mesh.face_normals` (cross products normalized by their safe norm) of a mesh
    collapsed to a point: zero normals, finite derivatives."""
    point = jnp.zeros((3, 3))
    np.testing.assert_array_equal(mesh.face_normals(point, FACES), [[0.0, 0.0, 0.0]])
    assert jnp.all(jnp.isfinite(jax.jacobian(mesh.face_normals)(point, FACES)))
    tilted = jnp.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 3.0, 4.0]])  # cross (0, -16, 12)
    np.testing.assert_allclose(mesh.face_normals(tilted, FACES), [[0.0, -0.8, 0.6]])
    check_grads(lambda v: mesh.face_normals(v, FACES), (tilted,), order=2, modes=["rev"])


def test_safe_divide_keeps_the_perspective_divide_finite():
    """`transforms.from_homogeneous` of points at infinity (w = 0, -0, tiny)."""
    big = transforms.from_homogeneous(jnp.array([[1.0, 0.0]]))[0, 0]
    assert jnp.isfinite(big) and big > 0
    assert transforms.from_homogeneous(jnp.array([[1.0, -1e-300]]))[0, 0] < 0
    grad = jax.grad(lambda w: transforms.from_homogeneous(jnp.stack([1.0, w])[None])[0, 0])(0.0)
    assert jnp.isfinite(grad)


# --- what is traced, and checks inside gfxlab's own compiled cores --------------------


def test_host_only_functions_refuse_traced_values():
    image = np.zeros((8, 8, 3), np.uint8)
    assert jpeg.encode(image)[:2] == b"\xff\xd8"
    with pytest.raises(TypeError, match=re.escape("`image` must be a concrete array")):
        jax.jit(jpeg.encode)(image)


def _callbacks(fn) -> int:
    """Host callbacks (failing checks report through them) in `fn`'s traced program."""
    return len(re.findall(r"callback", str(jax.make_jaxpr(fn)())))


def test_trusted_core_skips_its_checks_and_keeps_its_traces_apart():
    """`render` checks its inputs, then runs its core without re-checking: shading there
    (`lambert` on every pixel) adds no host callback to the program. A trace made in
    the core is never reused by a caller's jit: `lambert`, which the core called on
    arrays of these shapes, still checks."""
    shape = (6, 5)
    cube = mesh.cube()
    camera = viewing.Camera(eye=(2.5, 2.0, 3.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0))
    light = render.PointLight(position=jnp.array([3.0, 4.0, 5.0]))

    def draw(lights=None):
        return render.render(cube, camera, shape, mode="hard", lights=lights, antialias=False).color

    unshaded = _callbacks(draw)  # render's checks of its traced inputs: some
    assert unshaded > 0 and _callbacks(lambda: draw(light)) == unshaded
    direction = jnp.broadcast_to(jnp.array([0.0, 0.0, 1.0]), (*shape, 3))
    bad = direction.at[0, 0].set(NAN)
    with pytest.raises(JIT_ERRORS, match=re.escape("`wi` must be finite")):
        jax.block_until_ready(jax.jit(lambda wi: lambert(wi, direction, direction))(bad))
