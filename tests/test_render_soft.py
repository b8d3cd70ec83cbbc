"""The soft rasterizer: coverage, tiles vs dense reference, gradients, errors."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads
from matplotlib.path import Path
from render_scenes import tiny_scene

from gfxlab import render as R
from gfxlab.mesh import Mesh, icosphere
from gfxlab.viewing import Camera


def pixel_centres(shape):
    h, w = shape
    rows, cols = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    return np.stack([cols, h - 1 - rows], -1).reshape(-1, 2).astype(float)


def star(center, radii, points):
    angle = np.pi / 2 + np.pi * np.arange(2 * points) / points
    radius = np.where(np.arange(2 * points) % 2 == 0, radii[0], radii[1])
    return np.asarray(center) + radius[:, None] * np.stack([np.cos(angle), np.sin(angle)], -1)


def test_silhouette_at_small_sigma_is_pixel_centre_coverage():
    shape = (64, 80)
    outline = star((41.3, 30.7), (27.0, 11.0), 5)
    vertices = np.concatenate([[[41.3, 30.7]], outline])  # a fan from the centre
    n = len(outline)
    faces = np.stack([np.zeros(n, int), 1 + np.arange(n), 1 + (np.arange(n) + 1) % n], -1)
    soft = R.soft_silhouette(jnp.asarray(vertices), jnp.asarray(faces), shape, sigma=1e-3)
    inside = Path(outline).contains_points(pixel_centres(shape)).reshape(shape)
    agree = np.mean((np.asarray(soft) > 0.5) == inside)
    assert agree >= 0.995
    assert 0.1 < inside.mean() < 0.6  # the star is really there


def random_scene(rng, faces, shape, spread=6.0):
    h, w = shape
    centre = rng.uniform([0, 0], [w, h], (faces, 1, 2))
    return jnp.asarray((centre + rng.normal(0, spread, (faces, 3, 2))).reshape(-1, 2))


def test_tiled_silhouette_equals_dense(maybe_jit):
    rng = np.random.default_rng(1)
    shape = (29, 37)
    vertices = random_scene(rng, 15, shape)
    faces = jnp.asarray(np.arange(45).reshape(15, 3))
    run = maybe_jit(R.soft_silhouette, static_argnames=("shape", "tile_size", "capacity"))
    tiled = run(vertices, faces, shape, sigma=2.0, tile_size=8, capacity=16)
    dense = R.soft_silhouette_dense(vertices, faces, shape, sigma=2.0)
    np.testing.assert_allclose(tiled, dense, atol=1e-6)
    assert np.max(dense) > 0.9


def test_silhouette_gradients_equal_plain_autodiff():
    """The tiles' custom VJP (recomputed per step, one segment_sum) equals plain autodiff
    of the dense formula, for the vertices and sigma, and passes check_grads."""
    rng = np.random.default_rng(5)
    shape = (21, 27)
    vertices = random_scene(rng, 12, shape, spread=4.0)
    faces = jnp.asarray(np.arange(36).reshape(12, 3))
    weights = jnp.asarray(rng.uniform(0, 1, shape))

    @jax.jit
    def tiled(v, sigma):
        image = R.soft_silhouette(v, faces, shape, sigma=sigma, tile_size=4, capacity=12)
        return jnp.sum(weights * image)

    def dense(v, sigma):
        return jnp.sum(weights * R.soft_silhouette_dense(v, faces, shape, sigma=sigma))

    # Not weakly typed: check_grads' shifted inputs (strong float64) then reuse the
    # compiled `tiled` (this test runs in a child with XLA's slower default emitters).
    sigma = jnp.asarray(1.5, dtype=jnp.float64)
    ours = jax.grad(tiled, argnums=(0, 1))(vertices, sigma)
    ref = jax.jit(jax.grad(dense, argnums=(0, 1)))(vertices, sigma)
    assert np.abs(np.asarray(ref[0])).max() > 1e-3 and abs(float(ref[1])) > 1e-3
    for g, r in zip(ours, ref, strict=True):
        np.testing.assert_allclose(g, r, rtol=1e-8, atol=1e-10)
    check_grads(tiled, (vertices, sigma), order=1, modes=("rev",), eps=1e-6, rtol=1e-5)


def test_rasterizer_gradients_equal_plain_autodiff():
    mesh, camera = sphere_scene()
    shape = (18, 22)
    rng = np.random.default_rng(6)
    weights = jnp.asarray(rng.uniform(0, 1, shape + (4,)))
    kw = dict(sigma=1.5, gamma=0.05, background=jnp.array([0.2, 0.3, 0.4]))

    def loss(vertices, colors, eye, tiled=True):
        m, c = Mesh(vertices, mesh.faces, colors), Camera(eye, near=0.5, far=10.0)
        if tiled:
            rgba, depth = R.soft_rasterize(m, c, shape, tile_size=4, capacity=64, **kw)
        else:
            rgba, depth = R.soft_rasterize_dense(m, c, shape, **kw)
        return jnp.sum(weights * rgba) + 0.1 * jnp.sum(depth)

    args = (mesh.vertices, mesh.colors, camera.eye)
    ours = jax.jit(jax.grad(loss, argnums=(0, 1, 2)))(*args)
    ref = jax.jit(jax.grad(lambda *a: loss(*a, tiled=False), argnums=(0, 1, 2)))(*args)
    for g, r in zip(ours, ref, strict=True):
        assert np.abs(np.asarray(r)).max() > 1e-3
        np.testing.assert_allclose(g, r, rtol=1e-8, atol=1e-10)


def sphere_scene():
    sphere = icosphere(1, radius=0.8)
    colors = 0.5 + 0.5 * sphere.vertices
    mesh = Mesh(sphere.vertices + jnp.array([0.1, 0.0, 0.0]), sphere.faces, colors)
    camera = Camera(jnp.array([0.3, 0.6, 3.0]), near=0.5, far=10.0)
    return mesh, camera


def test_tiled_rasterizer_equals_dense():
    mesh, camera = sphere_scene()
    shape = (27, 34)
    kw = dict(
        sigma=1.5,
        gamma=0.05,
        background=jnp.array([0.2, 0.3, 0.4]),
        light=jnp.array([1.0, 2.0, 3.0]),
    )
    # one compiled program for both (the eager path is tested below, with `capacity`)
    (rgba, depth), (rgba_ref, depth_ref) = jax.jit(
        lambda m, c: (
            R.soft_rasterize(m, c, shape, tile_size=8, capacity=80, **kw),
            R.soft_rasterize_dense(m, c, shape, **kw),
        )
    )(mesh, camera)
    np.testing.assert_allclose(rgba, rgba_ref, atol=1e-6)
    np.testing.assert_allclose(depth, depth_ref, atol=1e-6)
    assert rgba.shape == shape + (4,) and depth.shape == shape
    assert 0.1 < np.mean(np.asarray(rgba)[..., 3]) < 0.9


def test_a_gradient_through_the_tile_loop_traces_each_kernel_once_per_pass():
    """`jax.grad` of a jitted tiled image traces the pixel kernel once per kernel width
    and once for the empty-tile value in the forward pass, and as often again in the
    backward pass: the custom VJP's primal and fwd rule share one trace (they were
    traced apart, a third more tracing for every render's gradient)."""
    from gfxlab.render import _tiles

    calls = []

    def coverage(points, tri, slot_mask, ids, sigma):
        calls.append(points.shape)
        d2, inside, _ = _tiles.pixel_face_terms(points, tri)
        soft = jnp.where(inside, 1.0, jnp.exp(-d2 / sigma))
        return jnp.sum(jnp.where(slot_mask[None], soft, 0.0), -1, keepdims=True)

    tri = jnp.array(
        [[[2.0, 2.0], [13.0, 3.0], [6.0, 12.0]], [[9.0, 9.0], [14.0, 14.0], [5.0, 15.0]]]
    )
    capacity = 24  # two kernel widths
    assert len(_tiles.step_widths(capacity)) == 2

    @jax.jit
    def image(tri, sigma):
        out, _ = _tiles.tiled(
            coverage,
            tri,
            jnp.ones(2, bool),
            tri,
            sigma,
            (16, 16),
            margin=3.0,
            tile_size=8,
            capacity=capacity,
            tiles_per_step=2,
        )
        return out

    grads = jax.grad(lambda t, s: jnp.sum(image(t, s) ** 2), (0, 1))(tri, jnp.asarray(2.0))
    assert len(calls) == 2 * (2 + 1)
    assert all(np.isfinite(g).all() for g in grads) and float(jnp.abs(grads[0]).sum()) > 0


def test_soft_converges_to_zbuffer():
    rng = np.random.default_rng(3)
    shape = (32, 32)
    count = 10
    camera = Camera(jnp.array([0.0, 0.0, 4.0]), near=1.0, far=8.0)
    # slightly tilted triangles at distinct depths (no interpenetration)
    centres = np.concatenate(
        [rng.uniform(-1, 1, (count, 1, 2)), np.linspace(-1, 1, count)[:, None, None]], -1
    )
    vertices = centres + rng.normal(0, 0.6, (count, 3, 3)) * np.array([1, 1, 0.02])
    face_colors = rng.uniform(0, 1, (count, 3))
    mesh = Mesh(
        jnp.asarray(vertices.reshape(-1, 3)),
        jnp.asarray(np.arange(3 * count).reshape(count, 3)),
        jnp.asarray(np.repeat(face_colors, 3, axis=0)),
    )
    triangles, colors = R.screen_scene(mesh, camera, shape)
    hard = R.zbuffer(triangles, colors, shape)
    covered = np.isfinite(np.asarray(hard.depth))
    assert 0.15 < covered.mean() < 0.9
    agreement = []
    for sigma, gamma in [(1.0, 0.1), (1e-5, 1e-3)]:
        rgba, _ = R.soft_rasterize(mesh, camera, shape, sigma=sigma, gamma=gamma, capacity=16)
        rgba = np.asarray(rgba)
        composite = rgba[..., :3] * rgba[..., 3:]  # over a black background
        agreement.append(np.mean(np.all(np.abs(composite - np.asarray(hard.image)) < 1e-3, -1)))
    assert agreement[1] >= 0.99 and agreement[1] > agreement[0]
    assert np.mean((rgba[..., 3] > 0.5) == covered) >= 0.99


def test_check_grads_of_the_soft_rasterizer():
    vertices, faces, colors = tiny_scene()
    eye = jnp.array([0.2, 0.1, 2.5])

    @jax.jit
    def render(vertices, colors, eye):
        camera = Camera(eye, near=0.5, far=5.0)
        rgba, depth = R.soft_rasterize(
            Mesh(vertices, faces, colors),
            camera,
            (8, 8),
            sigma=3.0,
            gamma=0.2,
            eps=1e-12,
            tile_size=4,
            capacity=2,
        )
        return rgba, depth

    colors = 0.9 * colors  # inside [0, 1] (`Mesh` refuses colours out of it): the finite
    # differences of check_grads step by eps either way
    check_grads(
        render, (vertices, colors, eye), order=1, modes=("rev",), eps=1e-6, rtol=1e-4, atol=1e-6
    )


def test_gradients_stay_finite_in_degenerate_cases():
    vertices = jnp.array(
        [
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],  # a triangle shrunk to a point
            [-0.5, 0.1, 0.0],
            [0.0, 0.1, 0.0],
            [0.5, 0.1, 0.0],  # collinear corners
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [0.0, 1.0, 0.0],  # edges through pixel centres
            [0.0, 0.0, 0.5],
            [0.3, 0.0, 5.0],
            [0.0, 0.3, 0.5],  # a corner behind the camera
        ]
    )
    faces = jnp.asarray(np.arange(12).reshape(4, 3))
    camera = Camera(jnp.array([0.0, 0.0, 2.0]), near=0.5, far=10.0)

    def loss(vertices, eye):
        cam = Camera(eye, near=0.5, far=10.0)
        rgba, depth = R.soft_rasterize(
            Mesh(vertices, faces), cam, (9, 9), sigma=0.5, gamma=0.1, capacity=4
        )
        return jnp.sum(rgba) + 0.01 * jnp.sum(depth)

    grads = jax.jit(jax.grad(loss, argnums=(0, 1)))(vertices, camera.eye)
    assert all(np.all(np.isfinite(np.asarray(g))) for g in grads)
    assert np.abs(np.asarray(grads[0])[6:9]).sum() > 0  # the proper triangle moves the image
    # the 2D silhouette too, with vertices exactly on pixel centres
    pts = jnp.array([[2.0, 2.0], [6.0, 2.0], [2.0, 6.0], [4.0, 4.0], [4.0, 4.0], [5.0, 5.0]])
    g = jax.jit(
        jax.grad(
            lambda p: jnp.sum(
                R.soft_silhouette(p, jnp.array([[0, 1, 2], [3, 4, 5]]), (9, 9), sigma=0.5)
            )
        )
    )(pts)
    assert np.all(np.isfinite(np.asarray(g)))


def test_tile_capacity_is_found_grown_or_a_clear_error():
    vertices = jnp.array([[2.0, 2.0], [12.0, 3.0], [5.0, 11.0]] * 5)
    faces = jnp.asarray(np.arange(15).reshape(5, 3))
    expected = R.soft_silhouette(vertices, faces, (16, 16), sigma=1.0, capacity=5)
    # eager: too small a capacity is grown (and recompiled) with a warning, never an abort
    with pytest.warns(RuntimeWarning, match="capacity"):
        grown = R.soft_silhouette(vertices, faces, (16, 16), sigma=1.0, capacity=4)
    np.testing.assert_allclose(grown, expected)
    # capacity=None (the default) measures it
    np.testing.assert_allclose(R.soft_silhouette(vertices, faces, (16, 16), sigma=1.0), expected)
    # under jit an explicit capacity that overflows is an error naming `capacity`
    # (the message says how many faces the tile saw and the capacity to pass)
    jitted = jax.jit(lambda v: R.soft_silhouette(v, faces, (16, 16), sigma=1.0, capacity=4))
    with pytest.raises(Exception, match=r"overlaps 5 faces.*`capacity=5`"):
        jax.block_until_ready(jitted(vertices))
    grad = jax.jit(jax.grad(lambda v: jnp.sum(jitted(v))))
    with pytest.raises(Exception, match=r"`capacity=5`"):
        jax.block_until_ready(grad(vertices))
    # ... and with many faces, capacity=None under jit is a trace-time error naming it
    many = jnp.asarray(np.tile(np.asarray(vertices[:3]), (300, 1)))
    many_faces = jnp.asarray(np.arange(900).reshape(300, 3))
    with pytest.raises(ValueError, match="tile_capacity"):
        jax.jit(lambda v: R.soft_silhouette(v, many_faces, (16, 16), sigma=1.0))(many)


def with_value(vertices, value):
    """`vertices` with `value` at [1, 0] (built in NumPy: no eager program to compile)."""
    out = np.array(vertices)
    out[1, 0] = value
    return jnp.asarray(out)


def test_bad_inputs():
    vertices = jnp.array([[1.0, 1.0], [5.0, 1.0], [1.0, 5.0]])
    faces = jnp.array([[0, 1, 2]])
    with pytest.raises(ValueError, match="faces"):
        R.soft_silhouette(vertices, jnp.array([[0, 1, 3]]), (8, 8), sigma=1.0)
    with pytest.raises(ValueError, match="faces"):
        R.soft_silhouette(vertices, jnp.array([0, 1, 2]), (8, 8), sigma=1.0)
    with pytest.raises(ValueError, match="vertices_2d"):
        R.soft_silhouette(jnp.asarray(np.zeros((3, 3))), faces, (8, 8), sigma=1.0)
    # a NaN vertex is an error, not a silently dropped triangle (eagerly and under jit)
    with pytest.raises(ValueError, match="vertices_2d"):
        R.soft_silhouette(with_value(vertices, np.nan), faces, (8, 8), sigma=1.0)
    with pytest.raises(Exception, match="vertices_2d"):
        jitted = jax.jit(lambda v: R.soft_silhouette(v, faces, (8, 8), sigma=1.0))
        jax.block_until_ready(jitted(with_value(vertices, np.inf)))
    with pytest.raises(ValueError, match="faces"):
        R.soft_silhouette(vertices, jnp.array([[0, 1, -1]]), (8, 8), sigma=1.0)
    with pytest.raises(ValueError, match="sigma"):
        R.soft_silhouette(vertices, faces, (8, 8), sigma=0.0)
    with pytest.raises(ValueError, match="shape"):
        R.soft_silhouette(vertices, faces, (8,), sigma=1.0)
    with pytest.raises(ValueError, match="tile_size"):
        R.soft_silhouette(vertices, faces, (8, 8), sigma=1.0, tile_size=0)
    mesh, camera = sphere_scene()
    with pytest.raises(ValueError, match="gamma"):
        R.soft_rasterize(mesh, camera, (8, 8), sigma=1.0, gamma=-1.0)
    with pytest.raises(ValueError, match="sigma"):
        R.soft_rasterize(mesh, camera, (8, 8), sigma=-1.0, gamma=1.0)
    with pytest.raises(TypeError, match="mesh"):
        R.soft_rasterize(vertices, camera, (8, 8), sigma=1.0, gamma=1.0)
    with pytest.raises(TypeError, match="camera"):
        R.soft_rasterize(mesh, None, (8, 8), sigma=1.0, gamma=1.0)
    with pytest.raises(ValueError, match="background"):
        R.soft_rasterize(mesh, camera, (8, 8), sigma=1.0, gamma=1.0, background=np.zeros(2))


def test_dense_references_bad_inputs():
    vertices = jnp.array([[1.0, 1.0], [5.0, 1.0], [1.0, 5.0]])
    faces = jnp.array([[0, 1, 2]])
    with pytest.raises(ValueError, match="vertices_2d"):
        R.soft_silhouette_dense(with_value(vertices, np.nan), faces, (8, 8), sigma=1.0)
    with pytest.raises(ValueError, match="faces"):
        R.soft_silhouette_dense(vertices, jnp.array([[0, 1, 3]]), (8, 8), sigma=1.0)
    with pytest.raises(ValueError, match="sigma"):
        R.soft_silhouette_dense(vertices, faces, (8, 8), sigma=0.0)
    with pytest.raises(TypeError, match="sigma"):
        R.soft_silhouette_dense(vertices, faces, (8, 8), sigma=None)
    mesh, camera = sphere_scene()
    with pytest.raises(TypeError, match="mesh"):
        R.soft_rasterize_dense(vertices, camera, (8, 8), sigma=1.0, gamma=1.0)
    with pytest.raises(ValueError, match="gamma"):
        R.soft_rasterize_dense(mesh, camera, (8, 8), sigma=1.0, gamma=0.0)
    with pytest.raises(ValueError, match="background"):
        R.soft_rasterize_dense(mesh, camera, (8, 8), sigma=1.0, gamma=1.0, background=np.zeros(2))
