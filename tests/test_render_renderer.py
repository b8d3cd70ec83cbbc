"""`render`: barycentrics and attributes vs NumPy, shading vs gfxlab.brdf, sharp limits,
gradients, textures, batches, sharding and bad inputs."""

import functools
import os
import re
import subprocess
import sys
import textwrap
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads
from render_scenes import tiny_scene
from scipy.ndimage import map_coordinates
from user_flags import run_with_user_xla_flags

from gfxlab import brdf as B
from gfxlab import render as R
from gfxlab.mesh import Mesh, icosphere
from gfxlab.viewing import Camera

SHAPE = (14, 16)


def cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def triangle_soup(seed=4, count=5):
    """Tilted triangles at distinct depths, per-face colours (vertices not shared)."""
    rng = np.random.default_rng(seed)
    centres = np.concatenate(
        [rng.uniform(-0.5, 0.5, (count, 1, 2)), np.linspace(-1, 1, count)[:, None, None]], -1
    )
    vertices = centres + rng.normal(0, 1.0, (count, 3, 3)) * np.array([1, 1, 0.1])
    colors = np.repeat(rng.uniform(0.1, 1, (count, 3)), 3, axis=0)
    faces = np.arange(3 * count).reshape(count, 3)
    return Mesh(jnp.asarray(vertices.reshape(-1, 3)), jnp.asarray(faces), jnp.asarray(colors))


CAMERA = Camera(jnp.array([0.2, 0.3, 4.0]), near=1.0, far=8.0)


def numpy_reference(mesh, camera, shape, attributes):
    """Per pixel: nearest covering face by eye depth, perspective-correct barycentrics."""
    h, w = shape
    v = np.asarray(mesh.vertices)
    m = np.asarray(camera.matrix())
    clip = np.c_[v, np.ones(len(v))] @ m.T
    ndc = clip[:, :3] / clip[:, 3:]
    px = np.stack([(ndc[:, 0] + 1) / 2 * w - 0.5, (ndc[:, 1] + 1) / 2 * h - 0.5], -1)
    eye_depth = clip[:, 3]  # for a perspective matrix w_clip = -z_eye
    face = np.full(shape, -1)
    bary = np.zeros(shape + (3,))
    best = np.full(shape, np.inf)
    for f, (i, j, k) in enumerate(np.asarray(mesh.faces)):  # a test reference: clarity first
        a, b, c = px[i], px[j], px[k]
        area = cross(b - a, c - a)
        for row in range(h):
            for col in range(w):
                p = np.array([col, h - 1 - row], float)
                l0 = cross(c - b, p - b) / area
                l1 = cross(a - c, p - c) / area
                l2 = 1 - l0 - l1
                if min(l0, l1, l2) < 0:
                    continue
                q = np.array([l0, l1, l2]) / eye_depth[[i, j, k]]
                depth = 1 / q.sum()
                if depth < best[row, col]:
                    best[row, col], face[row, col], bary[row, col] = depth, f, q * depth
    attrs = np.einsum("hwv,hwva->hwa", bary, attributes[np.asarray(mesh.faces)[face]])
    attrs[face < 0] = 0
    return face, bary, attrs, best


@functools.lru_cache
def hard_soup():
    mesh = triangle_soup()
    attributes = np.random.default_rng(1).normal(size=(mesh.num_vertices, 2))
    rendering = R.render(
        mesh,
        CAMERA,
        SHAPE,
        mode="hard",
        attributes=jnp.asarray(attributes),
        antialias=False,
        background=jnp.zeros(3),
    )
    return mesh, attributes, rendering


def test_barycentrics_and_attributes_equal_a_numpy_reference():
    mesh, attributes, r = hard_soup()
    face, bary, attrs, depth = numpy_reference(mesh, CAMERA, SHAPE, attributes)
    assert 0.2 < np.mean(face >= 0) < 0.95 and len(np.unique(face)) >= 4  # a real scene
    np.testing.assert_array_equal(r.face_index, face)
    covered = face >= 0
    np.testing.assert_allclose(np.asarray(r.barycentrics)[covered], bary[covered], atol=1e-9)
    np.testing.assert_allclose(r.attributes, attrs, atol=1e-9)
    np.testing.assert_allclose(np.asarray(r.depth)[covered], depth[covered], rtol=1e-9)
    # the standalone interpolation agrees, and the colours are the faces' colours
    again = R.interpolate(jnp.asarray(attributes), mesh.faces, r.face_index, r.barycentrics)
    np.testing.assert_allclose(again, attrs, atol=1e-9)
    # perspective-correct, not screen-space: the two differ on this tilted scene
    assert np.max(np.abs(np.asarray(r.barycentrics)[covered].sum(-1) - 1)) < 1e-9


def test_hard_and_soft_equal_the_zbuffer_in_the_sharp_limit():
    mesh, _, hard = hard_soup()
    triangles, colors = R.screen_scene(mesh, CAMERA, SHAPE)
    z = R.zbuffer(triangles, colors, SHAPE)
    np.testing.assert_allclose(hard.color, z.image, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(hard.alpha) > 0, np.isfinite(z.depth))
    soft = R.render(
        mesh, CAMERA, SHAPE, mode="soft", sigma=1e-6, gamma=1e-4, background=jnp.zeros(3)
    )
    agree = np.all(np.abs(np.asarray(soft.color) - np.asarray(z.image)) < 1e-3, -1)
    assert agree.mean() >= 0.97
    blurry = R.render(
        mesh, CAMERA, SHAPE, mode="soft", sigma=1.0, gamma=0.1, background=jnp.zeros(3)
    )
    assert np.all(np.abs(np.asarray(blurry.color) - np.asarray(z.image)) < 1e-3, -1).mean() < (
        agree.mean()
    )


def test_shading_equals_gfxlab_brdf_per_pixel():
    sphere = icosphere(1, radius=0.9)
    colors = 0.4 + 0.5 * np.abs(np.asarray(sphere.vertices))
    mesh = Mesh(sphere.vertices, sphere.faces, colors)
    camera = Camera(jnp.array([0.5, 0.8, 3.0]), near=0.5, far=10.0)
    lights = [R.PointLight([2.0, 2.0, 2.0], 6.0), R.DirectionalLight([-1.0, 0.5, 1.0], 0.7)]
    model = B.CookTorrance(roughness=0.4, f0=0.04, kd=0.8)
    r = R.render(
        mesh,
        camera,
        SHAPE,
        mode="hard",
        lights=lights,
        brdf=model,
        ambient=0.05,
        antialias=False,
        background=jnp.zeros(3),
    )
    covered = np.asarray(r.face_index) >= 0
    assert covered.mean() > 0.3
    albedo = np.asarray(R.interpolate(mesh.colors, mesh.faces, r.face_index, r.barycentrics))
    n, p = np.asarray(r.normal)[covered], np.asarray(r.position)[covered]
    wo = np.asarray(camera.eye) - p
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    n = np.where((np.sum(n * wo, -1) < 0)[:, None], -n, n)
    expected = 0.05 * albedo[covered]
    for light in lights:
        if isinstance(light, R.PointLight):
            to = np.asarray(light.position) - p
            irradiance = float(light.intensity) / np.sum(to * to, -1)
        else:
            to = np.broadcast_to(np.asarray(light.direction), p.shape)
            irradiance = float(light.intensity)
        wi = to / np.linalg.norm(to, axis=-1, keepdims=True)
        f = np.asarray(
            B.cook_torrance(
                jnp.asarray(wi), jnp.asarray(wo), jnp.asarray(n), roughness=0.4, f0=0.04, kd=0.8
            )
        )
        cos = np.maximum(np.sum(n * wi, -1), 0)
        expected = expected + (np.pi * f * cos * irradiance)[:, None] * albedo[covered]
    np.testing.assert_allclose(np.asarray(r.color)[covered], expected, rtol=1e-9, atol=1e-12)
    # the interpolated normals are unit and point outwards on a sphere
    np.testing.assert_allclose(np.linalg.norm(np.asarray(r.normal)[covered], axis=-1), 1.0)
    assert np.all(np.sum(np.asarray(r.normal)[covered] * np.asarray(r.position)[covered], -1) > 0)


def test_texture_sampling_is_bilinear_and_rendered_through_uvs():
    rng = np.random.default_rng(4)
    texture = rng.uniform(0, 1, (5, 7, 3))
    uv = rng.uniform(-0.1, 1.1, (40, 2))
    ours = R.sample_texture(jnp.asarray(texture), jnp.asarray(uv))
    rows = (1 - uv[:, 1]) * 5 - 0.5  # row 0 at the top
    cols = uv[:, 0] * 7 - 0.5
    ref = np.stack(
        [map_coordinates(texture[..., c], [rows, cols], order=1, mode="nearest") for c in range(3)],
        -1,
    )
    np.testing.assert_allclose(ours, ref, atol=1e-12)
    # a textured square facing the camera shows the texture where its uv lands
    square = Mesh(
        jnp.array([[-1.0, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]),
        jnp.array([[0, 1, 2], [0, 2, 3]]),
        uvs=jnp.array([[0.0, 0], [1, 0], [1, 1], [0, 1]]),
        uv_faces=jnp.array([[0, 1, 2], [0, 2, 3]]),
        texture=jnp.asarray(texture),
    )
    camera = Camera(jnp.array([0.0, 0.0, 3.0]), near=0.5, far=10.0)
    r = R.render(
        square,
        camera,
        SHAPE,
        mode="hard",
        antialias=False,
        attributes=jnp.array([[0.0, 0], [1, 0], [1, 1], [0, 1]]),
    )
    covered = np.asarray(r.face_index) >= 0
    expected = R.sample_texture(jnp.asarray(texture), r.attributes)
    np.testing.assert_allclose(
        np.asarray(r.color)[covered], np.asarray(expected)[covered], atol=1e-12
    )
    # differentiable in the texture
    g = jax.grad(lambda t: jnp.sum(R.sample_texture(t, jnp.asarray(uv))))(jnp.asarray(texture))
    assert np.all(np.isfinite(g)) and np.sum(g) == pytest.approx(len(uv) * 3)


@pytest.mark.parametrize("mode", ["soft", "hard"])
def test_check_grads(mode):
    vertices, faces, colors = tiny_scene()
    light = R.DirectionalLight([0.3, 0.4, 1.0])

    @jax.jit
    def image(vertices, colors):
        camera = Camera(jnp.array([0.2, 0.1, 2.5]), near=0.5, far=5.0)
        r = R.render(
            Mesh(vertices, faces, colors),
            camera,
            (7, 7),
            mode=mode,
            sigma=3.0,
            gamma=0.2,
            eps=1e-12,
            lights=light,
            ambient=0.2,
            tile_size=4,
        )
        return r.color, r.alpha

    colors = 0.9 * colors  # inside [0, 1] (`Mesh` refuses colours out of it): the finite
    # differences of check_grads step by eps either way
    check_grads(image, (vertices, colors), order=1, modes=("rev",), eps=1e-6, rtol=1e-4, atol=1e-6)
    if mode == "hard":  # the antialiased silhouette moves with the vertices
        # d sum(alpha) / d vertices, through the VJP check_grads compiled
        (color, alpha), pullback = jax.vjp(image, vertices, colors)
        g = pullback((jnp.asarray(np.zeros(color.shape)), jnp.asarray(np.ones(alpha.shape))))[0]
        assert np.abs(np.asarray(g)).sum() > 0


@pytest.mark.parametrize("mode", ["soft", "hard"])
def test_gradients_equal_plain_autodiff(mode):
    """The tiles' custom VJP equals plain autodiff of every pixel against every face, on
    a sphere spread over many tiles (two kernel widths: busy and quiet steps)."""
    sphere = icosphere(1, radius=0.8)
    colors = 0.5 + 0.5 * sphere.vertices
    camera = Camera(jnp.array([0.3, 0.6, 3.0]), near=0.5, far=10.0)
    light = R.DirectionalLight([0.3, 0.4, 1.0])
    weights = jnp.asarray(np.random.default_rng(2).uniform(0, 1, (16, 16, 3)))

    def loss(vertices, colors, fn):
        r = fn(
            Mesh(vertices, sphere.faces, colors),
            camera,
            (16, 16),
            mode=mode,
            sigma=1.0,
            gamma=0.05,
            lights=light,
            ambient=0.2,
            tile_size=4,
            capacity=64,
        )
        return jnp.sum(weights * r.color) + jnp.sum(r.alpha) + 0.1 * jnp.sum(r.depth)

    args = (sphere.vertices, colors)
    ours = jax.jit(jax.grad(lambda *a: loss(*a, R.render), argnums=(0, 1)))(*args)
    ref = jax.jit(jax.grad(lambda *a: loss(*a, R.render_dense), argnums=(0, 1)))(*args)
    for g, r in zip(ours, ref, strict=True):
        assert np.abs(np.asarray(r)).max() > 1e-3
        np.testing.assert_allclose(g, r, rtol=1e-8, atol=1e-10)


# Four views: the sharded test below splits them over two devices (two views each) and
# compares with this batch, rendered once.
EYES = np.array([[0.2, 0.1, 2.5], [-0.4, 0.3, 2.2], [0.5, -0.3, 2.8], [-0.1, -0.5, 2.4]])


@functools.lru_cache
def batched_views():
    vertices, faces, colors = tiny_scene()
    mesh = Mesh(vertices, faces, colors)
    return mesh, R.render(mesh, Camera(jnp.asarray(EYES), near=0.5, far=5.0), (9, 9), sigma=0.5)


def test_batched_views_and_vertices_equal_single_renders():
    mesh, batch = batched_views()
    vertices, faces, colors = tiny_scene()
    cameras = [Camera(jnp.asarray(eye), near=0.5, far=5.0) for eye in EYES]
    for b, camera in enumerate(cameras):
        one = R.render(mesh, camera, (9, 9), sigma=0.5)
        np.testing.assert_allclose(batch.color[b], one.color, atol=1e-12)
    # as many vertex sets as views: the eager projection reuses the batched ops above
    moved = jnp.asarray(np.asarray(vertices) + np.array([0.0, 0.1, -0.1, 0.05])[:, None, None])
    batch = R.render(mesh, cameras[0], (9, 9), vertices=moved, sigma=0.5)
    one = R.render(Mesh(vertices + 0.1, faces, colors), cameras[0], (9, 9), sigma=0.5)
    np.testing.assert_allclose(batch.alpha[1], one.alpha, atol=1e-12)


def test_an_explicit_capacity_that_overflows_is_grown_eagerly_with_a_warning():
    """An eager render with too small a `capacity` (e.g. from `tile_capacity` before a
    fit moved the mesh) warns, recompiles with room for the busiest tile and returns
    what a sufficient capacity gives, for single and batched views alike."""
    mesh, batch = batched_views()
    cameras = Camera(jnp.asarray(EYES), near=0.5, far=5.0)
    enough = R.tile_capacity(mesh, cameras, (9, 9), sigma=0.5)
    assert enough > 1
    with pytest.warns(RuntimeWarning, match=r"more than `capacity` = 1; recompiling"):
        grown = R.render(mesh, cameras, (9, 9), sigma=0.5, capacity=1)
    np.testing.assert_array_equal(grown.color, batch.color)
    one = Camera(jnp.asarray(EYES[0]), near=0.5, far=5.0)
    with pytest.warns(RuntimeWarning, match="recompiling"):
        grown = R.render(mesh, one, (9, 9), mode="hard", capacity=1)
    np.testing.assert_array_equal(grown.color, R.render(mesh, one, (9, 9), mode="hard").color)


def test_batched_views_equal_single_views_with_lights_and_antialiasing():
    """A symmetric sphere puts pixel pairs on faces that meet at one vertex, with equal
    depths: float noise between a batched and a single render must not decide whether
    the pair is blended. Only silhouette edges (boundaries, folds) are, by topology."""
    ball = icosphere(2).with_colors(jnp.array([0.8, 0.5, 0.2]))
    light = R.PointLight(jnp.array([2.0, 2.0, 2.0]), 10.0)
    eyes = jnp.array([[0.0, 0.0, 4.0], [4.0, 0.0, 0.0]])
    batched = R.render(ball, Camera(eyes), (32, 32), mode="hard", lights=light)
    for k in range(2):
        single = R.render(ball, Camera(eyes[k]), (32, 32), mode="hard", lights=light)
        np.testing.assert_allclose(batched.color[k], single.color, atol=2e-5)
        flat = R.render(ball, Camera(eyes[k]), (32, 32), mode="hard", lights=light, antialias=False)
        blended = np.abs(np.asarray(single.color - flat.color)).max(-1) > 1e-6
        inside = np.asarray(flat.alpha) > 0
        interior = inside & np.roll(inside, 1, 0) & np.roll(inside, -1, 0)
        interior &= np.roll(inside, 1, 1) & np.roll(inside, -1, 1)
        assert blended.any() and not (blended & interior).any()  # silhouette pixels only


def grid_plane(n, dtype=np.float64):
    """An `n x n`-vertex square in z = 0, two triangles per cell (shared edges)."""
    u = np.linspace(-1.0, 1.0, n)
    x, y = np.meshgrid(u, u)
    vertices = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], -1).astype(dtype)
    i = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None]).ravel()
    faces = np.concatenate(
        [np.stack([i, i + 1, i + n + 1], -1), np.stack([i, i + n + 1, i + n], -1)]
    )
    return Mesh(jnp.asarray(vertices), jnp.asarray(faces), jnp.ones((n * n, 3), dtype))


HOLES_SCRIPT = """
import json, sys
import jax, jax.numpy as jnp, numpy as np
jax.config.update("jax_enable_x64", True)
sys.path.insert(0, sys.argv[1])
from test_render_renderer import grid_plane, triangle_along
from gfxlab import render as R
from gfxlab.mesh import Mesh, cube
from gfxlab.viewing import Camera
# Capacities are given (every face fits in every tile), so that each case compiles its
# render alone, not also the tile measure: this child compiles at full optimisation.
found = []
for renderer, n, dtype in [(R.render, 5, np.float32), (R.render_dense, 2, np.float32)]:
    plane = grid_plane(n, dtype)
    eyes = np.zeros((16, 3), dtype)
    eyes[:, 2] = np.linspace(3.2, 6.0, 16)
    options = dict(mode="hard", capacity=plane.num_faces)
    batched = renderer(plane, Camera(eyes), (16, 16), **options)
    for k, face_index in enumerate(np.asarray(batched.face_index)):
        rows, cols = np.nonzero(face_index >= 0)
        box = face_index[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1]
        found.append([renderer.__name__, n, str(dtype), float(eyes[k, 2]), int((box < 0).sum())])
    single = renderer(plane, Camera(eyes[3]), (16, 16), **options)
    found.append(["batched vs single", n, str(dtype), 0.0,
                  int((np.asarray(batched.face_index[3]) != np.asarray(single.face_index)).sum())])
box32 = Mesh(cube(1.0).vertices.astype(jnp.float32), cube(1.0).faces)
for size in (40, 44):  # the front square's diagonal runs through pixel centres
    r = R.render(box32, Camera(np.array([0.0, 0.0, 4.0], np.float32)), (size, size),
                 mode="hard", cull_backfaces=True, capacity=box32.num_faces)
    covered = np.asarray(r.face_index) >= 0
    rows, cols = np.nonzero(covered)
    box = covered[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1]
    found.append(["culled cube", size, "float32", 4.0, int((~box).sum())])
camera = Camera(np.array([0.0, 0.0, 5.0], np.float32))
for direction in [(0.54, 0.84), (-0.59, 0.81)]:  # an edge 1e-6 px outside a centre
    mesh = triangle_along(camera, (32, 32), (16.0, 16.0), direction, 1e-6)
    mesh = Mesh(mesh.vertices.astype(jnp.float32), mesh.faces)
    alpha = float(R.render(mesh, camera, (32, 32), mode="hard", capacity=1).alpha[15, 16])
    found.append(["edge 1e-6 px away", 0, "float32", 5.0, int(abs(alpha - 0.5) > 0.05)])
print(json.dumps(found))
"""


def test_shared_edges_through_pixel_centres_leave_no_holes():
    """Seen along its axis, a grid's (or a cube's) inner edges run through pixel centres;
    a centre on an edge is inside at least one of its faces: the square is solid at
    every distance, and a batch of views equals single views. A pixel whose centre is
    a hair outside an edge is antialiased to about 1/2 (it was once 1).
    Run with the user's XLA flags: the suite's fast-compile flags skip the fused
    multiply-adds whose rounding made holes (tests/conftest.py)."""
    rows = run_with_user_xla_flags(HOLES_SCRIPT, os.path.dirname(__file__))
    assert len(rows) == 2 * 17 + 2 + 2
    assert [row for row in rows if row[-1]] == []  # (renderer, n, dtype, eye z, holes)


def triangle_along(camera, shape, centre, direction, distance):
    """One large triangle in z = 0 whose edge runs along `direction` (pixels) at signed
    `distance` (pixels, > 0: outside) from the pixel centre `centre`."""
    px = np.asarray(camera.to_pixels(jnp.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), shape))
    origin, scale = px[0, :2], px[1, 0] - px[0, 0]  # pixels of the world origin, per unit
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    normal = np.array([d[1], -d[0]])
    on_edge = np.asarray(centre, float) + normal * distance
    corners = np.array([on_edge - 20 * d, on_edge + 20 * normal, on_edge + 20 * d])
    world = np.c_[(corners - origin) / scale, np.zeros(3)]
    return Mesh(jnp.asarray(world), jnp.array([[0, 1, 2]]))


@pytest.mark.parametrize("direction", [(1.0, 1.0), (1.0, 3.0), (1.0, 0.2), (0.0, 1.0)])
def test_antialiased_coverage_is_continuous_as_an_edge_crosses_a_pixel_centre(direction):
    """A pixel's antialiased alpha follows the edge: about 1/2 with its centre on the
    edge, on either side of it, at any slope. Each edge is blended by the pixel pairs
    it is closer to perpendicular to (nvdiffrast); blended by both, a pixel just
    outside a slanted edge got about 1 and dropped to 0 once covered."""
    camera, shape, centre = Camera(jnp.array([0.0, 0.0, 4.0])), (16, 16), (7.0, 8.0)
    row, col = shape[0] - 1 - int(centre[1]), int(centre[0])  # y up
    alphas = []
    for distance in (0.2, 0.01, -0.01, -0.2):
        mesh = triangle_along(camera, shape, centre, direction, distance)
        alphas.append(float(R.render(mesh, camera, shape, mode="hard").alpha[row, col]))
    assert alphas[0] < alphas[1] < alphas[2] < alphas[3]  # it grows as the edge covers it
    assert abs(alphas[1] - 0.5) < 0.05 and abs(alphas[2] - 0.5) < 0.05
    assert alphas[2] - alphas[1] < 0.05  # no jump as the centre crosses the edge


def test_a_fit_whose_mesh_outgrows_its_capacity_grows_it_and_reruns():
    """A fit that shrinks the mesh crowds the tiles past the capacity measured at the
    start: `fit` grows the capacity (a warning says so), reruns the steps, and ends
    where a fit with room from the start ends; it never aborts."""
    from gfxlab.fit import fit

    ball, camera, shape = icosphere(1), Camera(jnp.array([0.0, 0.0, 4.0])), (16, 16)
    target = R.render(ball.with_vertices(0.4 * ball.vertices), camera, shape).alpha
    measured = R.tile_capacity(ball, camera, shape, sigma=1.0)

    def loss(scale, capacity):
        mesh = ball.with_vertices(scale * ball.vertices)
        return jnp.sum((R.render(mesh, camera, shape, capacity=capacity).alpha - target) ** 2)

    options = {"method": "adam", "learning_rate": 0.05, "max_steps": 25}
    crowded = functools.partial(loss, capacity=measured)
    with pytest.warns(
        RuntimeWarning,
        match=rf"tile capacity {measured} was exceeded; "
        r"recompiled with (\d+); steps 1-25 were rerun",
    ) as caught:
        grown = fit(crowded, jnp.asarray(1.0), **options)
    needed = int(re.search(r"recompiled with (\d+)", str(caught[-1].message)).group(1))
    assert measured < needed <= ball.num_faces
    # The same fit again has room from the start (the capacity stays grown): it runs the
    # grown program without a warning, and its steps are the rerun's, step for step.
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        roomy = fit(crowded, jnp.asarray(1.0), **options)
    assert float(grown.params) < 0.6
    np.testing.assert_allclose(grown.loss_history, roomy.loss_history, rtol=1e-5, atol=1e-6)
    # and the grown capacity renders what room for every face renders
    every_face = loss(grown.params, capacity=ball.num_faces)
    np.testing.assert_allclose(every_face, grown.loss, rtol=1e-6, atol=1e-9)


def test_tile_capacity_for_the_hard_path_is_sigma_none():
    """`tile_capacity(..., sigma=None)` measures hard mode's bins (no soft margin):
    enough for a hard render, which then runs without growing, and no more than a soft
    sigma's count; its options are still checked."""
    mesh, _ = batched_views()
    one = Camera(jnp.asarray(EYES[0]), near=0.5, far=5.0)
    hard = R.tile_capacity(mesh, one, (9, 9), sigma=None)
    assert 1 <= hard <= R.tile_capacity(mesh, one, (9, 9), sigma=4.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a capacity that overflows would warn
        fitted = R.render(mesh, one, (9, 9), mode="hard", capacity=hard)
    np.testing.assert_array_equal(fitted.color, R.render(mesh, one, (9, 9), mode="hard").color)
    with pytest.raises(ValueError, match="tile_size"):
        R.tile_capacity(mesh, one, (9, 9), sigma=None, tile_size=0)


def test_sharded_views_equal_unsharded(tmp_path):
    """A child process with two CPU devices renders the four views sharded (two per
    device); they equal this process's unsharded batch (`batched_views`). Under a
    `jax.set_mesh` mesh with Explicit axes, sharding is a named error (JAX's own names
    no argument), unsharded views still render; under an Auto-axes mesh, sharded ones."""
    mesh, plain = batched_views()
    arrays = dict(vertices=mesh.vertices, faces=mesh.faces, colors=mesh.colors, eyes=EYES)
    np.savez(tmp_path / "scene.npz", **arrays)
    script = textwrap.dedent("""
        import sys
        import jax, jax.numpy as jnp, numpy as np
        jax.config.update("jax_enable_x64", True)
        from gfxlab import render as R
        from gfxlab.mesh import Mesh
        from gfxlab.viewing import Camera
        assert len(jax.devices()) == 2
        scene = np.load(sys.argv[1] + "/scene.npz")
        mesh = Mesh(*(jnp.asarray(scene[k]) for k in ("vertices", "faces", "colors")))
        cameras = Camera(jnp.asarray(scene["eyes"]), near=0.5, far=5.0)
        sharded = R.shard_cameras(cameras)
        assert len(sharded.eye.sharding.device_set) == 2
        split = R.render(mesh, sharded, (9, 9), sigma=0.5)
        assert len(split.color.sharding.device_set) == 2
        np.save(sys.argv[1] + "/split.npy", np.asarray(split.color))
        # `jax.make_mesh` axes are Explicit by default: sharding there is a named error;
        # unsharded views render there, and sharded ones under an Auto-axes mesh.
        explicit = jax.make_mesh((2,), ("views",))
        auto = jax.make_mesh((2,), ("views",), axis_types=(jax.sharding.AxisType.Auto,))
        errors = []
        with jax.set_mesh(explicit):
            for call in (lambda: R.shard_cameras(cameras),
                         lambda: R.render(mesh, sharded, (9, 9), sigma=0.5)):
                try:
                    call()
                    errors.append(None)
                except ValueError as error:
                    errors.append(str(error))
            plain_here = R.render(mesh, cameras, (9, 9), sigma=0.5)
        assert errors[0].startswith("`shard_cameras` cannot run here: the mesh set by "
                                    "`jax.set_mesh` has Explicit axes ('views',)"), errors
        assert errors[1].startswith("`camera` is sharded over 2 devices, but the mesh"), errors
        assert "axis_types=(jax.sharding.AxisType.Auto, ...)" in errors[1], errors
        with jax.set_mesh(auto):
            in_auto = R.render(mesh, R.shard_cameras(cameras), (9, 9), sigma=0.5)
        assert len(in_auto.color.sharding.device_set) == 2
        np.save(sys.argv[1] + "/explicit.npy", np.asarray(plain_here.color))
        np.save(sys.argv[1] + "/auto.npy", np.asarray(in_auto.color))
        print("ok")
    """)
    # Two CPU devices, on top of the suite's compile flags (tests/conftest.py).
    flags = f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count=2"
    env = dict(os.environ, XLA_FLAGS=flags, JAX_PLATFORMS="cpu")
    out = subprocess.run(
        [sys.executable, "-c", script, str(tmp_path)],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().endswith("ok")
    for name in ("split", "explicit", "auto"):
        np.testing.assert_allclose(np.load(tmp_path / f"{name}.npy"), plain.color, atol=1e-12)


def test_bad_inputs():
    vertices, faces, colors = tiny_scene()
    mesh = Mesh(vertices, faces, colors)
    camera = Camera(jnp.array([0.2, 0.1, 2.5]), near=0.5, far=5.0)
    with pytest.raises(ValueError, match="mode"):
        R.render(mesh, camera, (8, 8), mode="wire")
    with pytest.raises(TypeError, match="mesh"):
        R.render(vertices, camera, (8, 8))
    with pytest.raises(TypeError, match="camera"):
        R.render(mesh, None, (8, 8))
    with pytest.raises(ValueError, match="vertices"):
        R.render(mesh, camera, (8, 8), vertices=jnp.asarray(np.zeros((5, 3))))
    nan_vertices = np.array(vertices)
    nan_vertices[0, 0] = np.nan
    with pytest.raises(ValueError, match="vertices"):
        R.render(mesh, camera, (8, 8), vertices=jnp.asarray(nan_vertices))
    with pytest.raises(ValueError, match="sigma"):
        R.render(mesh, camera, (8, 8), sigma=0.0)
    with pytest.raises(ValueError, match="gamma"):
        R.render(mesh, camera, (8, 8), gamma=-1.0)
    with pytest.raises(ValueError, match="background"):
        R.render(mesh, camera, (8, 8), background=jnp.asarray(np.zeros(2)))
    # scalar options of the wrong shape are named (not a broadcasting error deep inside)
    for name, value in (
        ("sigma", np.ones(2)),
        ("gamma", [0.1, 0.2]),
        ("eps_background", [0.1] * 3),
    ):
        with pytest.raises(ValueError, match=f"`{name}` must have shape"):
            R.render(mesh, camera, (8, 8), **{name: value})
    with pytest.raises(ValueError, match="`ambient` must be a scalar or a colour"):
        R.render(mesh, camera, (8, 8), ambient=np.ones(2))
    # a capacity beyond the number of faces is clamped to it, not allocated
    np.testing.assert_array_equal(
        R.render(mesh, camera, (8, 8), capacity=10**9).color, R.render(mesh, camera, (8, 8)).color
    )
    with pytest.raises(ValueError, match="attributes"):
        R.render(mesh, camera, (8, 8), attributes=jnp.asarray(np.zeros((4, 2))))
    with pytest.raises(TypeError, match="lights"):
        R.render(mesh, camera, (8, 8), lights=[jnp.asarray(np.ones(3))])
    with pytest.raises(ValueError, match="batch"):
        R.render(
            mesh,
            Camera(jnp.asarray(np.full((2, 3), 3.0))),
            (8, 8),
            vertices=jnp.asarray(np.stack([vertices] * 3)),
        )
    with pytest.raises(ValueError, match="intensity"):
        R.PointLight([0.0, 0.0, 1.0], -1.0)
    with pytest.raises(ValueError, match="direction"):
        R.DirectionalLight([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="uv"):
        R.sample_texture(jnp.asarray(np.ones((2, 2, 3))), jnp.asarray(np.ones((4, 3))))
    with pytest.raises(ValueError, match="barycentrics"):
        R.interpolate(
            colors, faces, jnp.asarray(np.zeros((2, 2), int)), jnp.asarray(np.zeros((2, 2, 2)))
        )
    with pytest.raises(ValueError, match="devices"):
        R.shard_cameras(camera)


def _scene_and(**options):
    vertices, faces, colors = tiny_scene()
    mesh = Mesh(vertices, faces, colors)
    camera = options.pop("camera", Camera(jnp.array([0.2, 0.1, 2.5]), near=0.5, far=5.0))
    return R.render(options.pop("mesh", mesh), camera, (8, 8), **options).color


LIGHT = R.PointLight(jnp.array([2.0, 2.0, 2.0]), 1.0)


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"attributes": jnp.full((6, 2), jnp.nan)}, ValueError, "`attributes` must be finite"),
        ({"cull_backfaces": 1}, TypeError, "`cull_backfaces` must be True or False"),
        ({"antialias": "yes", "mode": "hard"}, TypeError, "`antialias` must be True or False"),
        ({"eps_background": -1.0}, ValueError, "`eps_background` must be finite and > 0"),
        ({"lights": LIGHT, "brdf": "ggx"}, TypeError, r"`brdf` must be a gfxlab.brdf model.*GGX"),
        ({"lights": "sun"}, TypeError, "`lights` must be a PointLight"),
        (
            {"lights": R.PointLight(jnp.array([2.0, 2.0, 2.0]), jnp.ones(4))},
            ValueError,
            r"`lights\[0\].intensity` has 4 colour channels; the surface has 3",
        ),
        (
            {"mesh": Mesh(jnp.zeros((3, 3)), jnp.zeros((0, 3), jnp.int32))},
            ValueError,
            "`mesh` has no faces",
        ),
    ],
)
def test_bad_options_are_named(options, error, message):
    with pytest.raises(error, match=message):
        _scene_and(**options)


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        (
            {"target": [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]], "near": [0.5, 0.6, 0.7]},
            r"fields must batch one number of views, got `camera.target` 2, `camera.near` 3",
        ),
        ({"eye": [[[0.0, 0.0, 4.0]], [[0.0, 0.0, 5.0]]]}, r"`camera.eye` must have shape"),
        (
            {"eye": [[0.0, 0.0, 4.0], [0.0, 0.0, 5.0]], "fov_y": [0.5, 0.6, 0.7]},
            r"`camera.fov_y` 3",
        ),
    ],
)
def test_camera_batches_that_do_not_agree_are_named(fields, match):
    """`Camera` broadcasts its fields (its matrices accept any batch shape); `render`
    takes one batch axis of one size, and names the field that breaks that."""
    fields = {"eye": [0.0, 0.0, 4.0]} | fields
    camera = Camera(**{k: jnp.asarray(v) for k, v in fields.items()})
    with pytest.raises(ValueError, match=match):
        R.render(icosphere(0), camera, (8, 8))
    targets = jnp.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]])  # one eye, two targets: 2 views
    views = R.render(icosphere(0), Camera(jnp.array([0.0, 0.0, 4.0]), targets), (8, 8))
    for k in range(2):
        single = R.render(icosphere(0), Camera(jnp.array([0.0, 0.0, 4.0]), targets[k]), (8, 8))
        np.testing.assert_allclose(views.color[k], single.color, atol=1e-12)
    eyes = Camera(jnp.array([[0.0, 0.0, 4.0], [0.0, 0.0, 5.0]]))
    with pytest.raises(ValueError, match=r"`vertices` batches 3 meshes but `camera` 2 views"):
        R.render(icosphere(0), eyes, (8, 8), vertices=jnp.stack([icosphere(0).vertices] * 3))


def test_a_capacity_outgrown_inside_your_own_jit_is_a_named_error():
    """Under `jax.jit` the overflow is raised in a host callback, which JAX wraps in its
    runtime error: `check_message` finds the message there, and `checked_jit` raises it
    as the `TileCapacityError` it is."""
    from gfxlab import check_message, checked_jit

    ball, camera = icosphere(2), Camera(jnp.array([0.0, 0.0, 4.0]))

    def coverage(v):
        return R.render(ball, camera, (32, 32), mode="hard", vertices=v, capacity=8).alpha.sum()

    with pytest.raises(jax.errors.JaxRuntimeError) as raised:
        jax.jit(coverage)(0.3 * ball.vertices)
    message = check_message(raised.value)
    assert message.startswith("a 8x8 tile overlaps") and "`capacity` = 8" in message
    with pytest.raises(R.TileCapacityError, match=r"more than `capacity` = 8: pass"):
        checked_jit(coverage)(0.3 * ball.vertices)
    assert issubclass(R.TileCapacityError, ValueError)


@pytest.mark.parametrize(
    ("model", "value", "match"),
    [
        (lambda r: B.CookTorrance(r), 0.0, r"`roughness` must be >= 0.02"),
        (lambda s: B.Phong(1.0, s), -3.0, r"`shininess` must be >= 0"),
        (lambda a: B.Lambert(a), float("nan"), r"`albedo` must be finite"),
    ],
)
def test_traced_brdf_parameters_are_checked_inside_render(model, value, match):
    """Under `jit` a model's construction cannot check its traced parameters, and the
    render's core drops the checks inside the model: `render` ties them on first."""
    from gfxlab import checked_jit

    ball, camera = icosphere(1), Camera(jnp.array([0.0, 0.0, 4.0]))
    light = [R.PointLight(jnp.array([0.0, 0.0, 4.0]))]

    def image(p):
        return R.render(ball, camera, (8, 8), mode="hard", lights=light, brdf=model(p)).color

    with pytest.raises(ValueError, match=match):
        checked_jit(image)(jnp.asarray(value))
    with pytest.raises(ValueError, match=r"`brdf\.\w+` must be a scalar in `render`"):
        image(jnp.full((3,), 0.5))
    good = {0.0: 0.5, -3.0: 3.0}.get(value, 0.5)
    assert np.isfinite(np.asarray(checked_jit(image)(jnp.asarray(good)))).all()


def test_faces_that_do_not_index_the_vertices_are_refused_traced_or_not():
    """A `Mesh` checks concrete faces at construction; faces changed by `eqx.tree_at`
    or traced under `jit` are checked by `render` (and `tile_capacity`)."""
    import equinox as eqx

    from gfxlab import checked_jit

    ball, camera = icosphere(1), Camera(jnp.array([0.0, 0.0, 4.0]))
    bad = ball.faces.at[0, 0].set(10_000)
    message = r"`mesh.faces` must index the 42 vertices \(0 <= index < 42\)"
    with pytest.raises(ValueError, match=message):
        checked_jit(lambda f: R.render(Mesh(ball.vertices, f), camera, (8, 8)).alpha)(bad)
    edited = eqx.tree_at(lambda m: m.faces, ball, bad.at[0, 0].set(-5))
    with pytest.raises(ValueError, match=message):
        R.render(edited, camera, (8, 8))
    with pytest.raises(ValueError, match=message):
        R.tile_capacity(edited, camera, (8, 8), sigma=1.0)


def test_shade_and_mesh_name_mismatched_channels_and_shapes():
    with pytest.raises(ValueError, match=r"`albedo`, `normal` and `position` must have one batch"):
        R.shade(
            jnp.ones((4, 4, 3)),
            jnp.ones((4, 5, 3)),
            jnp.ones((4, 4, 3)),
            jnp.zeros(3),
            lights=LIGHT,
        )
    with pytest.raises(ValueError, match=r"`lights\[0\].intensity` has 2 colour channels"):
        R.shade(
            jnp.ones((2, 3)),
            jnp.ones((2, 3)),
            jnp.ones((2, 3)),
            jnp.zeros(3),
            lights=R.DirectionalLight(jnp.ones(3), jnp.ones(2)),
        )
    with pytest.raises(ValueError, match="`ambient` must be finite and >= 0"):
        R.shade(
            jnp.ones((2, 3)),
            jnp.ones((2, 3)),
            jnp.ones((2, 3)),
            jnp.zeros(3),
            lights=LIGHT,
            ambient=-0.1,
        )
    with pytest.raises(ValueError, match=r"`eye`, `target`, `up` must be \(3,\) vectors or "):
        Camera(jnp.array([[0.0, 0.0, 4.0], [0.0, 0.0, 5.0]]), jnp.zeros((3, 3)))
    vertices, faces, _ = tiny_scene()
    with pytest.raises(ValueError, match="`texture` has 4 colour channels and `colors` 3"):
        Mesh(
            vertices,
            faces,
            colors=jnp.full((6, 3), 0.5),
            uvs=jnp.zeros((6, 2)),
            uv_faces=faces,
            texture=jnp.ones((2, 2, 4)),
        )


def test_ambient_is_finite_non_negative_and_for_lit_renders_only():
    """A NaN or negative `ambient` is an error, eagerly and under jit (the check must not
    be dead code); an unlit render (`lights=None`) ignores no ambient term silently: any
    ambient but a concrete 0 is refused, naming `lights=`."""
    vertices, faces, colors = tiny_scene()
    mesh = Mesh(vertices, faces, colors)
    camera = Camera(jnp.array([0.2, 0.1, 2.5]), near=0.5, far=5.0)
    light = R.DirectionalLight([0.0, 0.0, 1.0])
    for bad in (jnp.nan, -0.5):
        with pytest.raises(ValueError, match="`ambient` must be finite and >= 0"):
            R.render(mesh, camera, (8, 8), lights=light, ambient=bad)
        run = jax.jit(lambda a: R.render(mesh, camera, (8, 8), lights=light, ambient=a))
        with pytest.raises(Exception, match="`ambient` must be finite and >= 0"):
            jax.block_until_ready(run(jnp.asarray(bad)).color)
    for ambient in (0.3, jnp.array([0.1, 0.0, 0.0])):
        with pytest.raises(ValueError, match="`ambient` shades lit renders only.*`lights=`"):
            R.render(mesh, camera, (8, 8), ambient=ambient)
    with pytest.raises(ValueError, match="`ambient` shades lit renders only"):
        jax.jit(lambda a: R.render(mesh, camera, (8, 8), ambient=a).color)(0.0)
    with pytest.raises(ValueError, match="`brdf` shades lit renders only"):
        R.render(mesh, camera, (8, 8), brdf=B.Lambert())
    unlit = R.render(mesh, camera, (8, 8), ambient=jnp.zeros(3)).color
    np.testing.assert_array_equal(unlit, R.render(mesh, camera, (8, 8)).color)
    lit = R.render(mesh, camera, (8, 8), lights=light, ambient=0.5).color
    dark = R.render(mesh, camera, (8, 8), lights=light).color
    np.testing.assert_allclose(lit - dark, 0.5 * R.render(mesh, camera, (8, 8)).color, atol=1e-5)


def test_undefined_camera_frame_is_an_error_under_jit_and_grad():
    """A traced camera cannot check its frame when it is made, and the compiled core
    skips the camera's checks: `render` must, or the image is blank with zero gradients.
    Both undefined frames run through one set of compiled programs (one `loss`)."""
    vertices, faces, colors = tiny_scene()
    mesh = Mesh(vertices, faces, colors)

    def loss(e):
        rendering = R.render(mesh, Camera(e, near=0.5, far=5.0), (8, 8), capacity=faces.shape[0])
        return rendering.alpha.sum()

    good = jnp.array([0.2, 0.1, 2.5])
    assert float(jax.jit(loss)(good)) > 0
    runs = (jax.jit(loss), jax.jit(jax.grad(loss)))
    batched_run = jax.jit(jax.vmap(loss))
    for eye, message in [
        ([0.0, 0.0, 0.0], "`camera.target` equals `camera.eye`"),
        ([0.0, 3.0, 0.0], "`camera.up` must be non-zero and not parallel"),
    ]:
        bad = jnp.array(eye)
        for run in runs:
            with pytest.raises(Exception, match=message):
                jax.block_until_ready(run(bad))
        with pytest.raises(Exception, match=message):
            jax.block_until_ready(batched_run(jnp.stack([good, bad])))
        with pytest.raises(ValueError, match=message.replace("camera.", "")):  # eagerly
            Camera(bad, near=0.5, far=5.0)


def test_render_dense_bad_inputs():
    vertices, faces, colors = tiny_scene()
    mesh = Mesh(vertices, faces, colors)
    camera = Camera(jnp.array([0.2, 0.1, 2.5]), near=0.5, far=5.0)
    with pytest.raises(TypeError, match="mesh"):
        R.render_dense(vertices, camera, (8, 8))
    with pytest.raises(TypeError, match="camera"):
        R.render_dense(mesh, None, (8, 8))
    with pytest.raises(ValueError, match="mode"):
        R.render_dense(mesh, camera, (8, 8), mode="wire")
    with pytest.raises(ValueError, match="sigma"):
        R.render_dense(mesh, camera, (8, 8), sigma=0.0)
    with pytest.raises(ValueError, match="tile_size"):
        R.render_dense(mesh, camera, (8, 8), tile_size=0)


@pytest.mark.parametrize("name", ["sigma", "gamma"])
def test_nan_or_inf_sigma_and_gamma_say_finite_and_positive_eagerly_and_under_jit(name):
    """NaN, inf and 0 are refused with one accurate message, eagerly and under jit."""
    vertices, faces, colors = tiny_scene()
    mesh = Mesh(vertices, faces, colors)
    camera = Camera(jnp.array([0.2, 0.1, 2.5]), near=0.5, far=5.0)
    message = f"`{name}` must be finite and > 0"
    for bad in (jnp.nan, jnp.inf, 0.0, -1.0):
        with pytest.raises(ValueError, match=message):
            R.render(mesh, camera, (8, 8), **{name: bad})
    run = jax.jit(lambda v: R.render(mesh, camera, (8, 8), capacity=4, **{name: v}).color)
    assert np.isfinite(np.asarray(run(jnp.asarray(0.5)))).all()
    with pytest.raises(Exception, match=message):
        jax.block_until_ready(run(jnp.asarray(jnp.nan)))
