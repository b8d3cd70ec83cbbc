"""Hidden-surface removal: z-buffer, painter's, Warnock and scan-line agree."""

import jax.numpy as jnp
import numpy as np
import pytest
from matplotlib.path import Path

from gfxlab import render as R
from gfxlab.mesh import cube
from gfxlab.viewing import Camera

METHODS = [R.zbuffer, R.painter, R.warnock, R.scanline, R.raycast]


def layered_scene(seed, count, shape, spread=9.0):
    """Random tilted triangles in distinct depth layers: no cycles, no interpenetration."""
    rng = np.random.default_rng(seed)
    h, w = shape
    centre = rng.uniform([0, 0], [w, h], (count, 1, 2))
    xy = centre + rng.normal(0, spread, (count, 3, 2))
    z = rng.permutation(count)[:, None, None] + rng.uniform(-0.3, 0.3, (count, 3, 1))
    colors = rng.uniform(0, 1, (count, 3))
    return jnp.asarray(np.concatenate([xy, z], -1)), jnp.asarray(colors)


def reference_owner(triangles, shape):
    """Brute force with matplotlib's point-in-polygon: nearest triangle at each centre."""
    h, w = shape
    rows, cols = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    points = np.stack([cols, h - 1 - rows], -1).reshape(-1, 2).astype(float)
    tri = np.asarray(triangles)
    best = np.full(len(points), np.inf)
    owner = np.full(len(points), -1)
    for index, t in enumerate(tri):  # a test reference: clarity over speed
        inside = Path(t[:, :2]).contains_points(points)
        a = np.column_stack([t[:, :2], np.ones(3)])
        plane = np.linalg.solve(a, t[:, 2])
        depth = points @ plane[:2] + plane[2]
        nearer = inside & (depth < best)
        best[nearer], owner[nearer] = depth[nearer], index
    return owner.reshape(h, w), best.reshape(h, w)


@pytest.mark.parametrize("seed", [0, 1])
def test_four_methods_agree_with_a_brute_force_reference(seed):
    shape = (37, 45)
    triangles, colors = layered_scene(seed, 16, shape)
    owner, depth = reference_owner(triangles, shape)
    background = jnp.array([0.1, 0.2, 0.3])
    expected = np.where((owner >= 0)[..., None], np.asarray(colors)[owner], background)
    assert 0.2 < (owner >= 0).mean() < 0.95
    for method in METHODS:
        result = method(triangles, colors, shape, background=background)
        match = np.all(np.asarray(result.image) == expected, -1).mean()
        assert match >= 0.998, method.__name__  # pixel centres on edges may differ
        assert result.counters["memory_bytes"] > 0
    cast = R.raycast(triangles, colors, shape)
    assert int(cast.counters["polygon_tests"]) == shape[0] * shape[1] * len(triangles)
    z = R.zbuffer(triangles, colors, shape, background=background)
    hit = owner >= 0
    np.testing.assert_allclose(np.asarray(z.depth)[hit], depth[hit], atol=1e-9)
    assert np.all(np.isinf(np.asarray(z.depth)[~hit]))
    assert int(z.counters["memory_bytes"]) == 37 * 45 * (3 + 1) * 8
    covered = sum(
        Path(t[:, :2])
        .contains_points(np.argwhere(np.ones(shape))[:, ::-1] * [1, -1] + [0, shape[0] - 1])
        .sum()
        for t in np.asarray(triangles)
    )
    assert abs(int(z.counters["depth_tests"]) - covered) <= 3


def cyclic_scene():
    """Three bars, each over the next and under the previous (the classic cycle)."""
    bars = []
    for k in range(3):
        angle = 2 * np.pi * k / 3
        d, n = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])
        start, end = 20 - 17 * d + 4 * n, 20 + 17 * d + 4 * n
        width = 3.5 * n
        quad = np.array([start - width, end - width, end + width, start + width])
        z = np.array([0.0, 2.0, 2.0, 0.0])  # each bar tilts from near to far along its length
        tris = [quad[[0, 1, 2]], quad[[0, 2, 3]]]
        zs = [z[[0, 1, 2]], z[[0, 2, 3]]]
        bars += [np.column_stack([t, zz]) for t, zz in zip(tris, zs, strict=True)]
    colors = np.repeat(np.eye(3), 2, axis=0)
    return jnp.asarray(np.array(bars)), jnp.asarray(colors)


def test_painter_fails_on_cyclic_overlap_the_others_do_not():
    shape = (40, 40)
    triangles, colors = cyclic_scene()
    owner, _ = reference_owner(triangles, shape)
    expected = np.where((owner >= 0)[..., None], np.asarray(colors)[owner], 0.0)
    painted = R.painter(triangles, colors, shape)
    assert int(painted.counters["cycle"]) == 1
    assert np.mean(np.all(np.asarray(painted.image) == expected, -1)) < 0.99
    for method in (R.zbuffer, R.warnock, R.scanline, R.raycast):
        image = np.asarray(method(triangles, colors, shape).image)
        assert np.mean(np.all(image == expected, -1)) >= 0.998
    # without the cycle (one bar removed) the painter's order is right again
    two = R.painter(triangles[:4], colors[:4], shape)
    assert int(two.counters["cycle"]) == 0
    np.testing.assert_array_equal(two.image, R.zbuffer(triangles[:4], colors[:4], shape).image)


def test_exact_ties_and_centres_on_edges_agree_across_methods():
    """Pixel centres exactly on a sloped edge are covered by every method (scan-line
    spans are rounded crossings), and two faces at one constant depth tie exactly
    (the lower index wins; the painter paints in index order, so the later one shows)."""
    shape = (32, 32)
    red, green = np.eye(3)[:2]
    x, y = np.meshgrid(np.arange(32.0), 31.0 - np.arange(32.0))  # centres, y up
    for n in (5, 14, 16, 22, 28):  # integer corners put centres on the hypotenuse
        tri = jnp.array([[[1.0, 1.0, 0.5], [n, 1.0, 0.5], [1.0, n, 0.5]]])
        inside = (x >= 1) & (y >= 1) & (x + y <= n + 1)  # exact: closed triangle
        for method in METHODS:
            image = np.asarray(method(tri, jnp.array([red]), shape).image)
            np.testing.assert_array_equal(np.any(image > 0, -1), inside, method.__name__)
    first = [[2.0, 3.0, 1.0], [30.0, 5.0, 1.0], [10.0, 28.0, 1.0]]
    second = [[25.0, 2.0, 1.0], [28.0, 30.0, 1.0], [1.0, 20.0, 1.0]]
    for scene in ([first, second], [first, first]):  # overlapping; the same face twice
        triangles, colors = jnp.array(scene), jnp.array([red, green])
        drawn = np.asarray(R.zbuffer(triangles, colors, shape).image)
        alone = [
            np.asarray(R.zbuffer(triangles[i : i + 1], colors[:1], shape).image) for i in (0, 1)
        ]
        overlap = alone[0].any(-1) & alone[1].any(-1)
        assert overlap.any() and np.all(drawn[overlap] == red)  # the lower index wins a tie
        for method in (R.scanline, R.raycast, R.warnock):
            np.testing.assert_array_equal(method(triangles, colors, shape).image, drawn)
    same = np.asarray(R.painter(jnp.array([first, first]), jnp.array([red, green]), shape).image)
    covered = np.any(same > 0, -1)
    assert covered.any() and np.all(same[covered] == green)


def test_warnock_quadtree():
    shape = (16, 16)
    big = jnp.array([[[-40.0, -40.0, 1.0], [80.0, -40.0, 1.0], [-40.0, 80.0, 1.0]]])
    one = R.warnock(big, jnp.array([[1.0, 0.0, 0.0]]), shape)
    assert int(one.quadtree[0][0, 0]) == 3  # a single surrounding polygon: done at the root
    assert all(int(jnp.sum(level > 0)) == 0 for level in one.quadtree[1:])
    empty = R.warnock(big[:0], jnp.zeros((0, 3)), shape)
    assert int(empty.quadtree[0][0, 0]) == 1
    # a small triangle in front of a surrounding one: subdivision around it, test 4 elsewhere
    small = jnp.array([[[3.2, 3.3, 0.0], [9.7, 4.1, 0.0], [5.1, 11.6, 0.0]]])
    scene = jnp.concatenate([big, small])
    result = R.warnock(scene, jnp.eye(3)[:2], shape)
    codes = np.concatenate([np.asarray(level).ravel() for level in result.quadtree])
    assert int(result.quadtree[0][0, 0]) == 5 and (codes == 3).any() and (codes == 4).any()
    np.testing.assert_array_equal(result.image, R.zbuffer(scene, jnp.eye(3)[:2], shape).image)
    cells = R.quadtree_cells(result.quadtree, shape)
    assert cells.shape[1] == 6
    leaves = cells[cells[:, 5] != 5]
    area = np.sum((leaves[:, 2] - leaves[:, 0]) * (leaves[:, 3] - leaves[:, 1]))
    assert area == pytest.approx(16 * 16)  # the decided cells tile the image


def test_screen_scene_of_a_cube():
    camera = Camera(jnp.array([2.0, 1.5, 3.0]), near=0.5, far=10.0)
    mesh = cube().with_colors(jnp.array([0.2, 0.6, 0.9]))
    triangles, colors = R.screen_scene(mesh, camera, (40, 40))
    np.testing.assert_allclose(
        triangles[..., :2], camera.to_pixels(mesh.vertices, (40, 40))[mesh.faces]
    )
    images = [np.asarray(m(triangles, colors, (40, 40)).image) for m in METHODS]
    for image in images[1:]:
        assert np.mean(np.all(image == images[0], -1)) >= 0.995
    # a face crossing the near plane is skipped (a zero-area triangle), not drawn wrongly
    close = Camera(jnp.array([0.0, 0.0, 0.55]), near=0.5, far=10.0)
    triangles, _ = R.screen_scene(mesh, close, (40, 40))
    u, v = (
        np.asarray(triangles[:, 1] - triangles[:, 0]),
        np.asarray(triangles[:, 2] - triangles[:, 0]),
    )
    area = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    assert np.any(area == 0) and np.any(area != 0) and bool(jnp.all(jnp.isfinite(triangles)))


def test_bad_inputs():
    triangles, colors = layered_scene(0, 3, (8, 8))
    for method in METHODS:
        with pytest.raises(ValueError, match="triangles"):
            method(triangles[..., :2], colors, (8, 8))
        with pytest.raises(ValueError, match="colors"):
            method(triangles, colors[:2], (8, 8))
        with pytest.raises(ValueError, match="shape"):
            method(triangles, colors, (8,))
    with pytest.raises(TypeError, match="quadtree"):
        R.quadtree_cells("x", (8, 8))
    with pytest.raises(ValueError, match="quadtree"):
        R.quadtree_cells((np.zeros((1, 1), int), np.zeros((3, 3), int)), (2, 2))
    # a quadtree drawn over an image of another size: its cells would be misplaced (two
    # faces at 16 x 16: the program test_warnock_quadtree compiles)
    small = R.warnock(triangles[:2], colors[:2], (16, 16)).quadtree
    with pytest.raises(ValueError, match="`shape` \\(64, 64\\) is not the shape"):
        R.quadtree_cells(small, (64, 64))
    assert len(R.quadtree_cells(small, (9, 16))) > 0  # also padded to 16 x 16: fine


def test_nan_scenes_are_errors_eagerly_and_under_jit():
    import jax

    triangles, colors = layered_scene(0, 3, (8, 8))
    nan_triangles = triangles.at[1, 2, 0].set(jnp.nan)
    for method in METHODS:
        for kwargs, name in (
            (dict(triangles=nan_triangles), "triangles"),
            (dict(colors=colors.at[0, 1].set(jnp.inf)), "colors"),
            (dict(colors=jnp.zeros((3, 7))), "colors"),  # 7 channels: not a colour
            (dict(background=jnp.array([0.0, jnp.nan, 0.0])), "background"),
        ):
            call = dict(triangles=triangles, colors=colors, background=0.0) | kwargs
            with pytest.raises(ValueError, match=name):
                method(call["triangles"], call["colors"], (8, 8), background=call["background"])
    with pytest.raises(ValueError, match="triangles"):  # counts differ: both are named
        R.zbuffer(triangles[:0], colors, (8, 8))
    assert R.zbuffer(triangles[:0], colors[:0], (8, 8)).image.shape == (8, 8, 3)
    jitted = jax.jit(lambda t: R.zbuffer(t, colors, (8, 8)).image)
    with pytest.raises((ValueError, RuntimeError), match="triangles"):
        jax.block_until_ready(jitted(nan_triangles))
    np.testing.assert_array_equal(jitted(triangles), R.zbuffer(triangles, colors, (8, 8)).image)
    with pytest.raises(ValueError, match="ambient"):
        R.screen_scene(cube(), Camera(jnp.array([2.0, 1.5, 3.0])), (8, 8), ambient=jnp.nan)
    with pytest.raises(ValueError, match="light"):
        R.screen_scene(cube(), Camera(jnp.array([2.0, 1.5, 3.0])), (8, 8), light=jnp.zeros(3))


def test_visibility_result_validates():
    image = jnp.zeros((2, 3, 3))
    with pytest.raises(TypeError, match="counters"):
        R.VisibilityResult(image, None, None)
    with pytest.raises(ValueError, match="image"):
        R.VisibilityResult(image.at[0, 0, 0].set(jnp.nan), None, {})
    with pytest.raises(ValueError, match="depth"):
        R.VisibilityResult(image, jnp.zeros((3, 2)), {})
    with pytest.raises(ValueError, match="depth"):
        R.VisibilityResult(image, jnp.full((2, 3), jnp.nan), {})
    assert R.VisibilityResult(image, jnp.full((2, 3), jnp.inf), {}).depth.shape == (2, 3)


def test_shading_bad_inputs():
    import jax

    light = R.PointLight([0.0, 0.0, 5.0])
    albedo, normal, position, eye = (
        jnp.ones((4, 3)),
        jnp.zeros((4, 3)),
        jnp.zeros((4, 3)),
        [
            0.0,
            0.0,
            3.0,
        ],
    )
    np.testing.assert_allclose(  # no lights: the ambient term alone
        R.shade(albedo, normal, position, eye, lights=(), ambient=0.25), 0.25 * albedo
    )
    for kwargs, error, name in (
        (dict(lights=None), TypeError, "lights"),
        (dict(albedo=albedo.at[0, 0].set(jnp.nan)), ValueError, "albedo"),
        (dict(albedo=jnp.ones((4, 7))), ValueError, "albedo"),
        (dict(normal=normal.at[1, 1].set(jnp.inf)), ValueError, "normal"),
        (dict(eye=[0.0, jnp.nan, 1.0]), ValueError, "eye"),
        (dict(ambient=jnp.nan), ValueError, "ambient"),
    ):
        call = dict(albedo=albedo, normal=normal, position=position, eye=eye, lights=light) | kwargs
        with pytest.raises(error, match=name):
            R.shade(**call)
    texture = jnp.linspace(0.0, 1.0, 2 * 3 * 3).reshape(2, 3, 3)
    uv = jnp.array([[0.25, 0.5]])
    with pytest.raises(ValueError, match="texture"):
        R.sample_texture(texture.at[0, 0, 0].set(jnp.nan), uv)
    with pytest.raises(ValueError, match="texture"):
        R.sample_texture(jnp.zeros((2, 3, 7)), uv)
    with pytest.raises(ValueError, match="uv"):
        R.sample_texture(texture, uv.at[0, 0].set(jnp.nan))
    with pytest.raises((ValueError, RuntimeError), match="uv"):
        jax.block_until_ready(jax.jit(R.sample_texture)(texture, uv.at[0, 1].set(jnp.inf)))
