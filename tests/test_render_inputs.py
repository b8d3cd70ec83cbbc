"""The argument checks of `render`'s entries other than `render` (gfxlab/render/_inputs.py):
`Rendering`, `interpolate`, `antialias` and `soft_silhouette(_dense)` name the argument at
fault, eagerly and under `jax.jit` alike (these checks are static: shapes and dtypes, so
they fire at trace time with the eager message)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gfxlab import render as R

H, W = 4, 5
FACES = jnp.array([[0, 1, 2], [1, 2, 3]])
FACE_INDEX = jnp.array([[0, -1, 1, 1, 0]] * H)
BARY = jnp.full((H, W, 3), 1 / 3)
ATTRS = jnp.arange(8.0).reshape(4, 2)
IMAGE = jnp.linspace(0.0, 1.0, H * W * 3).reshape(H, W, 3)
DEPTH = jnp.ones((H, W))
TRI2D = jnp.array([[[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]], [[3.0, 0.0], [0.0, 3.0], [3.0, 3.0]]])
VERTS2D = jnp.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0], [3.0, 3.0]])


def _rendering(**bad):
    fields = dict(
        color=IMAGE,
        alpha=DEPTH,
        depth=DEPTH,
        normal=BARY,
        position=BARY,
        face_index=FACE_INDEX,
        barycentrics=BARY,
        attributes=jnp.ones((H, W, 2)),
    )
    return R.Rendering(**(fields | bad))


def _interpolate(**bad):
    args = dict(attributes=ATTRS, faces=FACES, face_index=FACE_INDEX, barycentrics=BARY)
    return R.interpolate(**(args | bad))


def _antialias(**bad):
    args = dict(image=IMAGE, face_index=FACE_INDEX, depth=DEPTH, triangles_2d=TRI2D, faces=FACES)
    return R.antialias(**(args | bad))


def _silhouette(dense=False, **bad):
    fn = R.soft_silhouette_dense if dense else R.soft_silhouette
    args = dict(vertices_2d=VERTS2D, faces=FACES, shape=(H, W), sigma=1.0) | bad
    return fn(args.pop("vertices_2d"), args.pop("faces"), args.pop("shape"), **args)


# (call taking the bad value, the bad value, error, a regex the message must match)
CASES = [
    (
        lambda v: _rendering(color=v),
        jnp.zeros((0, W, 3)),
        ValueError,
        r"`alpha` must have shape \(0, 5\) \(the pixel shape \(0, 5\) of `color`\)",
    ),
    (lambda v: _rendering(attributes=v), "abc", TypeError, "`attributes` must be an array"),
    (lambda v: _rendering(alpha=v), None, TypeError, "`alpha` must be an array"),
    (
        lambda v: _interpolate(attributes=v),
        jnp.zeros((0, 2)),
        ValueError,
        r"`faces` index vertices, but `attributes` has none \(shape \(0, 2\)\)",
    ),
    (
        lambda v: _interpolate(face_index=v),
        "abc",
        TypeError,
        "`face_index` must be an integer array of face indices",
    ),
    (
        lambda v: _interpolate(face_index=v),
        np.zeros((H, W)),
        TypeError,
        "`face_index` must be an integer array of face indices, got dtype float",
    ),
    (
        lambda v: _antialias(image=v),
        jnp.zeros((0, W, 3)),
        ValueError,
        r"`face_index` must have shape \(0, 5\) \(the pixel shape \(H, W\) of `image`\)",
    ),
    (
        lambda v: _antialias(face_index=v),
        "abc",
        TypeError,
        "`face_index` must be an integer array",
    ),
    (
        lambda v: _antialias(triangles_2d=v),
        jnp.zeros((0, 3, 2)),
        ValueError,
        r"`faces` must have shape \(0, 3\) \(one row per triangle of `triangles_2d`\)",
    ),
    (
        lambda v: _antialias(faces=v),
        ["a", "b", "c"],
        TypeError,
        "`faces` must be an integer array of vertex indices",
    ),
    (
        lambda v: _silhouette(vertices_2d=v),
        jnp.zeros((0, 2)),
        ValueError,
        r"`faces` index vertices, but `vertices_2d` has none",
    ),
    (
        lambda v: _silhouette(dense=True, vertices_2d=v),
        jnp.zeros((0, 2)),
        ValueError,
        r"`faces` index vertices, but `vertices_2d` has none",
    ),
]
IDS = [f"{i}-{m[:24]}" for i, (_, _, _, m) in enumerate(CASES)]


@pytest.mark.parametrize(("call", "bad", "error", "message"), CASES, ids=IDS)
def test_bad_input_names_the_argument_eagerly(call, bad, error, message):
    with pytest.raises(error, match=message):
        call(bad)


@pytest.mark.parametrize(("call", "bad", "error", "message"), CASES, ids=IDS)
def test_bad_input_names_the_argument_under_jit(call, bad, error, message):
    if isinstance(bad, jax.Array):  # the bad array itself traced
        with pytest.raises(error, match=message):
            jax.jit(call)(bad)
    else:  # a non-array bad value, with the valid arrays traced around it
        with pytest.raises(error, match=message):
            jax.jit(lambda image: (call(bad), image)[1])(IMAGE)


def test_valid_calls_agree_eagerly_and_under_jit():
    """The checks let valid input through unchanged: same values eagerly and under jit,
    and the interpolation equals a NumPy reference."""
    eager = _interpolate()
    corners = np.asarray(ATTRS)[np.asarray(FACES)[np.maximum(np.asarray(FACE_INDEX), 0)]]
    expected = np.einsum("hwv,hwva->hwa", np.asarray(BARY), corners)
    expected[np.asarray(FACE_INDEX) < 0] = 0.0
    np.testing.assert_allclose(eager, expected, rtol=1e-6)
    np.testing.assert_allclose(jax.jit(lambda a: _interpolate(attributes=a))(ATTRS), eager)
    out = _antialias()
    np.testing.assert_allclose(jax.jit(lambda i: _antialias(image=i))(IMAGE), out, rtol=1e-6)
    sil = _silhouette()
    assert sil.shape == (H, W) and float(sil.max()) > 0.5
    np.testing.assert_allclose(_silhouette(dense=True), sil, rtol=1e-5, atol=1e-6)
    rendering = _rendering()
    assert jax.jit(lambda c: _rendering(color=c).color)(IMAGE).shape == rendering.color.shape
    assert _rendering(attributes=None).attributes is None


@pytest.mark.parametrize("name", ["soft_silhouette", "soft_silhouette_dense"])
def test_silhouette_of_no_faces_is_a_clear_error(name):
    fn = getattr(R, name)
    with pytest.raises(ValueError, match=r"`faces` must hold at least one triangle"):
        fn(jnp.zeros((3, 2)), jnp.zeros((0, 3), jnp.int32), (4, 5), sigma=1.0)


def test_face_index_out_of_range_is_refused_by_interpolate_and_antialias(maybe_jit):
    attributes = jnp.array([[1.0, 0.0], [0.0, 1.0], [2.0, 2.0]])
    faces = jnp.array([[0, 1, 2]])
    bary = jnp.array([[0.2, 0.3, 0.5], [1.0, 0.0, 0.0]])
    good = maybe_jit(R.interpolate)(attributes, faces, jnp.array([0, -1]), bary)
    np.testing.assert_allclose(
        good[0], 0.2 * attributes[0] + 0.3 * attributes[1] + 0.5 * attributes[2]
    )
    for bad in ([3, -1], [-2, 0]):
        with pytest.raises(Exception, match="`face_index` must be -1 \\(background\\) or a face"):
            maybe_jit(R.interpolate)(attributes, faces, jnp.array(bad), bary)
    image = jnp.zeros((4, 4, 3))
    index = jnp.full((4, 4), -1).at[1, 1].set(5)
    tri = jnp.array([[[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]]])
    with pytest.raises(Exception, match="`face_index` must be -1 \\(background\\) or a face"):
        maybe_jit(R.antialias)(image, index, jnp.ones((4, 4)), tri, faces)
    with pytest.raises(Exception, match="`faces` must be vertex indices >= 0"):
        maybe_jit(R.antialias)(image, index.at[1, 1].set(0), jnp.ones((4, 4)), tri, faces - 4)
