"""Tests for gfxlab.raster: lines, circles, ellipses, fill, coverage, displays."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import shapely
import skimage.draw
from jax.test_util import check_grads
from matplotlib.path import Path

from gfxlab import raster

# --------------------------------------------------------------------------- pixels


def test_pixel_index_roundtrip_and_centers():
    shape = (5, 7)
    rc = jnp.stack(jnp.meshgrid(jnp.arange(5), jnp.arange(7), indexing="ij"), -1)
    xy = raster.index_to_pixel(rc, shape)
    np.testing.assert_array_equal(raster.pixel_to_index(xy, shape), rc)
    np.testing.assert_array_equal(raster.pixel_centers(shape), xy)
    assert tuple(xy[0, 0]) == (0, 4)  # top-left pixel is (x, y) = (0, H - 1)
    assert raster.image_extent(shape) == (-0.5, 6.5, -0.5, 4.5)


def test_points_to_image_drops_outside(maybe_jit):
    points = jnp.array([[0, 0], [6, 4], [3, 2], [-1, 2], [7, 0], [2, 5], [2, -1]])
    image = maybe_jit(raster.points_to_image, static_argnames="shape")(points, shape=(5, 7))
    expected = np.zeros((5, 7), bool)
    expected[4, 0] = expected[0, 6] = expected[2, 3] = True
    np.testing.assert_array_equal(image, expected)


def test_pixel_bad_inputs():
    with pytest.raises(ValueError, match="xy"):
        raster.pixel_to_index(jnp.zeros((3, 3)), (4, 4))
    with pytest.raises(ValueError, match="rc"):
        raster.index_to_pixel(jnp.zeros(3), (4, 4))
    with pytest.raises(ValueError, match="shape"):
        raster.image_extent((4,))
    with pytest.raises(ValueError, match="shape"):
        raster.pixel_centers((0, 3))
    with pytest.raises(TypeError, match="integer"):
        raster.points_to_image(jnp.zeros((3, 2)), (4, 4))
    with pytest.raises(ValueError, match="points"):
        raster.points_to_image(jnp.zeros((3, 3), int), (4, 4))


# --------------------------------------------------------------------------- lines

# Two lines per octant (steep and shallow, every sign), ties, and degenerate cases.
LINES = [
    ((0, 0), (9, 4)),
    ((0, 0), (4, 9)),
    ((0, 0), (-9, 4)),
    ((0, 0), (-4, 9)),
    ((0, 0), (-9, -4)),
    ((0, 0), (-4, -9)),
    ((0, 0), (9, -4)),
    ((0, 0), (4, -9)),
    ((3, -2), (15, 1)),
    ((-5, 7), (-2, -6)),
    ((2, 2), (8, 5)),
    ((8, 5), (2, 2)),
    ((0, 0), (6, 1)),
    ((0, 0), (1, 6)),
    ((0, 0), (6, 6)),
    ((0, 0), (-6, 6)),
    ((1, 1), (1, 1)),
    ((0, 3), (0, -4)),
    ((-2, 0), (5, 0)),
    ((0, 0), (17, 11)),
]


@pytest.mark.parametrize("p0, p1", LINES)
def test_lines_match_skimage_and_steps(p0, p1):
    rr, cc = skimage.draw.line(p0[1], p0[0], p1[1], p1[0])  # rows = y, cols = x
    expected = np.stack([cc, rr], -1)
    for fn in (
        raster.line_bresenham,
        raster.line_bresenham_steps,
        raster.line_dda,
        raster.line_dda_steps,
    ):
        np.testing.assert_array_equal(fn(p0, p1), expected, err_msg=fn.__name__)


@pytest.mark.parametrize("p0, p1", LINES)
@pytest.mark.parametrize("fn", [raster.line_bresenham, raster.line_dda])
def test_lines_within_half_pixel_along_major_axis(p0, p1, fn):
    pts = np.asarray(fn(p0, p1))
    (x0, y0), (x1, y1) = p0, p1
    assert tuple(pts[0]) == p0 and tuple(pts[-1]) == p1
    assert len(pts) == max(abs(x1 - x0), abs(y1 - y0)) + 1
    assert np.all(np.abs(np.diff(pts, axis=0)) <= 1)  # 8-connected, no gaps
    if abs(x1 - x0) >= abs(y1 - y0) and x1 != x0:
        ideal = y0 + (pts[:, 0] - x0) * (y1 - y0) / (x1 - x0)
        assert np.all(np.abs(pts[:, 1] - ideal) <= 0.5 + 1e-12)
    elif y1 != y0:
        ideal = x0 + (pts[:, 1] - y0) * (x1 - x0) / (y1 - y0)
        assert np.all(np.abs(pts[:, 0] - ideal) <= 0.5 + 1e-12)


def test_lines_under_jit(maybe_jit):
    fn = maybe_jit(raster.line_bresenham, static_argnames=("p0", "p1"))
    np.testing.assert_array_equal(fn(p0=(0, 0), p1=(5, -3)), raster.line_dda((0, 0), (5, -3)))


@pytest.mark.parametrize(
    "fn",
    [raster.line_dda, raster.line_bresenham, raster.line_dda_steps, raster.line_bresenham_steps],
)
def test_lines_bad_inputs(fn):
    with pytest.raises(TypeError, match="p0"):
        fn((0.5, 0), (3, 3))
    with pytest.raises(ValueError, match="p1"):
        fn((0, 0), (1, 2, 3))
    with pytest.raises(TypeError, match="static"):
        jax.jit(fn)(jnp.array([0, 0]), jnp.array([3, 3]))


# --------------------------------------------------------------------------- circles


def test_circle_trace_matches_textbook_table():
    # The seed's derivation worked through for r = 10 (Hearn & Baker's example 3-...).
    table = np.asarray(raster.midpoint_circle_trace(10))
    np.testing.assert_array_equal(table[:, 0], np.arange(7))
    np.testing.assert_array_equal(table[:, 1], [-9, -6, -1, 6, -3, 8, 5])
    np.testing.assert_array_equal(
        table[:, 2:], [(1, 10), (2, 10), (3, 10), (4, 9), (5, 9), (6, 8), (7, 7)]
    )
    assert raster.midpoint_circle_trace(0).shape == (0, 4)


def _skimage_circle(radius, cx, cy):
    rr, cc = skimage.draw.circle_perimeter(cy, cx, radius)
    return set(zip(cc.tolist(), rr.tolist(), strict=True))


def test_midpoint_circle_equals_skimage_every_radius_0_to_300():
    rng = np.random.default_rng(0)
    for radius in range(301):
        cx, cy = (int(v) for v in rng.integers(-50, 50, 2))
        points = np.asarray(raster.midpoint_circle(radius, center=(cx, cy)))
        got = set(map(tuple, points.tolist()))
        assert len(got) == len(points), radius  # unique pixels
        assert got == _skimage_circle(radius, cx, cy), radius


# Every radius to 40 and a few large ones: the closed form compiles once per radius (its
# size is static), so the full 0..300 sweep would cost ~20 s of compiling in each run.
CIRCLE_RADII = [*range(41), 64, 99, 128, 255, 300]


def test_circle_steps_equal_vectorized_for_all_radii():
    # The stepwise recurrence (`midpoint_circle_trace`, `midpoint_circle_steps`) against
    # the closed form (`midpoint_circle`).
    for r in CIRCLE_RADII:
        trace = np.asarray(raster.midpoint_circle_trace(r))
        np.testing.assert_array_equal(trace[:, 0], np.arange(len(trace)))
        x_next, y_next = trace[:, 2], trace[:, 3]
        np.testing.assert_array_equal(x_next, np.arange(1, len(trace) + 1))
        # The loop runs while x < y: only the last step may cross the diagonal, onto the
        # mirror image of the pixel before it.
        assert (x_next[:-1] <= y_next[:-1]).all()
        if len(trace) and x_next[-1] > y_next[-1]:
            previous = (x_next[-2], y_next[-2]) if len(trace) > 1 else (0, r)
            assert (x_next[-1], y_next[-1]) == previous[::-1]
        np.testing.assert_array_equal(
            raster.midpoint_circle_steps(r, center=(2, 3)),
            raster.midpoint_circle(r, center=(2, 3)),
            err_msg=str(r),
        )


def test_midpoint_circle_jit_traced_center(maybe_jit):
    fn = maybe_jit(raster.midpoint_circle, static_argnames="radius")
    got = fn(radius=12, center=jnp.array([4, -1]))
    np.testing.assert_array_equal(got, raster.midpoint_circle(12) + jnp.array([4, -1]))
    # Clockwise closed loop: consecutive pixels are 8-neighbours.
    loop = np.asarray(got)
    steps = np.abs(np.diff(np.concatenate([loop, loop[:1]]), axis=0))
    assert steps.max() == 1


def test_circle_bad_inputs():
    for fn in (raster.midpoint_circle, raster.midpoint_circle_steps, raster.midpoint_circle_trace):
        with pytest.raises(ValueError, match="radius"):
            fn(-1)
        with pytest.raises(TypeError, match="radius"):
            fn(2.5)
        with pytest.raises(ValueError, match="radius"):
            fn(raster.MAX_CIRCLE_RADIUS + 1)
    with pytest.raises(TypeError, match="static"):
        jax.jit(raster.midpoint_circle)(jnp.asarray(3))
    with pytest.raises(TypeError, match="center"):
        raster.midpoint_circle(3, center=(0.5, 0.0))
    with pytest.raises(ValueError, match="center"):
        raster.midpoint_circle(3, center=(1, 2, 3))


# --------------------------------------------------------------------------- ellipses


def test_ellipse_trace_matches_textbook_example():
    # Hearn & Baker's worked example rx = 8, ry = 6.
    table = np.asarray(raster.midpoint_ellipse_trace(8, 6))
    np.testing.assert_array_equal(table[:, 0], [1] * 7 + [2] * 3)
    np.testing.assert_array_equal(table[:, 1], [0, 1, 2, 3, 4, 5, 6, 0, 1, 2])
    np.testing.assert_array_equal(
        table[:, 2], [-332, -224, -44, 208, -108, 288, 244, -23, 361, 297]
    )
    np.testing.assert_array_equal(
        table[:, 3:],
        [(1, 6), (2, 6), (3, 6), (4, 5), (5, 5), (6, 4), (7, 3), (8, 2), (8, 1), (8, 0)],
    )
    # Odd radii make the initial parameters quarter-integers; they stay exact.
    odd = np.asarray(raster.midpoint_ellipse_trace(5, 3))
    assert odd[0, 2] == 9 - 25 * 3 + 25 / 4


def test_ellipse_closed_form_equals_steps_on_a_grid():
    # The stepwise two-region loop (`midpoint_ellipse_steps`) against the closed form
    # (`midpoint_ellipse`), for every pair of semi-axes up to 48.
    for rx in range(1, 49):
        for ry in range(1, 49):
            np.testing.assert_array_equal(
                raster.midpoint_ellipse_steps(rx, ry),
                raster.midpoint_ellipse(rx, ry),
                err_msg=f"{rx}, {ry}",
            )


@pytest.mark.parametrize("rx, ry", [(1, 1), (8, 6), (3, 17), (25, 4), (40, 40), (128, 90)])
def test_midpoint_ellipse_pixels(rx, ry):
    got = np.asarray(raster.midpoint_ellipse(rx, ry, center=(5, -3)))
    np.testing.assert_array_equal(got, raster.midpoint_ellipse_steps(rx, ry, center=(5, -3)))
    assert len(set(map(tuple, got.tolist()))) == len(got)
    loop = np.concatenate([got, got[:1]])
    assert np.abs(np.diff(loop, axis=0)).max() == 1  # a closed 8-connected loop
    # The true ellipse passes within one pixel (Chebyshev distance) of every pixel: its
    # implicit function changes sign over the 3 x 3 block around the pixel.
    offsets = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1]), -1).reshape(-1, 2)
    block = (got - [5, -3])[:, None, :] + offsets
    implicit = (block[..., 0] / rx) ** 2 + (block[..., 1] / ry) ** 2 - 1
    assert np.all((implicit.min(1) <= 0) & (implicit.max(1) >= 0))
    symmetric = set(map(tuple, (got - [5, -3]).tolist()))
    assert symmetric == {(-a, b) for a, b in symmetric} == {(a, -b) for a, b in symmetric}


def test_ellipse_with_equal_radii_is_the_midpoint_circle():
    for radius in (1, 2, 5, 10, 23, 60):
        ellipse = set(map(tuple, np.asarray(raster.midpoint_ellipse(radius, radius)).tolist()))
        circle = set(map(tuple, np.asarray(raster.midpoint_circle(radius)).tolist()))
        assert ellipse == circle, radius


def test_ellipse_bad_inputs():
    for fn in (
        raster.midpoint_ellipse,
        raster.midpoint_ellipse_steps,
        raster.midpoint_ellipse_trace,
    ):
        with pytest.raises(ValueError, match="rx"):
            fn(0, 3)
        with pytest.raises(TypeError, match="ry"):
            fn(3, 1.5)
        with pytest.raises(ValueError, match="ry"):
            fn(3, raster.MAX_ELLIPSE_RADIUS + 1)


# --------------------------------------------------------------------------- fill

SHAPE = (24, 32)


def _random_polygon(rng, count, scale=(30.0, 22.0)):
    return rng.uniform(0.3, 1.0, (count, 2)) * np.array(scale)


def test_fill_polygon_matches_matplotlib(maybe_jit):
    rng = np.random.default_rng(3)
    centres = np.asarray(raster.pixel_centers(SHAPE)).reshape(-1, 2)
    fill = maybe_jit(raster.fill_polygon, static_argnames="shape")
    for count in (5, 5, 13, 13):  # random, mostly self-intersecting: even-odd rule
        vertices = _random_polygon(rng, count)
        expected = Path(vertices).contains_points(centres).reshape(SHAPE)
        np.testing.assert_array_equal(fill(vertices, shape=SHAPE), expected)
        np.testing.assert_array_equal(raster.fill_polygon_scanline(vertices, SHAPE), expected)


def test_fill_polygon_bad_inputs():
    with pytest.raises(ValueError, match="vertices"):
        raster.fill_polygon(jnp.zeros((2, 2)), SHAPE)
    with pytest.raises(ValueError, match="vertices"):
        raster.fill_polygon(jnp.zeros((4, 3)), SHAPE)
    with pytest.raises(ValueError, match="shape"):
        raster.fill_polygon_scanline(jnp.zeros((4, 2)), (0, 4))
    with pytest.raises(ValueError, match="points"):
        raster.inside_polygon(jnp.zeros((4, 3)), jnp.zeros((4, 2)))


# --------------------------------------------------------------------------- anti-aliasing


def _shapely_coverage(vertices, shape):
    height, width = shape
    centres = np.asarray(raster.pixel_centers(shape)).reshape(-1, 2)
    boxes = shapely.box(
        centres[:, 0] - 0.5, centres[:, 1] - 0.5, centres[:, 0] + 0.5, centres[:, 1] + 0.5
    )
    polygon = shapely.Polygon(vertices)
    return shapely.area(shapely.intersection(polygon, boxes)).reshape(height, width)


def test_polygon_coverage_is_exact_area(maybe_jit):
    rng = np.random.default_rng(4)
    angles = np.sort(rng.uniform(0, 2 * np.pi, 9))
    radii = rng.uniform(4, 10, 9)
    star = np.stack([15 + radii * np.cos(angles), 11 + radii * np.sin(angles)], -1)
    coverage = maybe_jit(raster.polygon_coverage, static_argnames="shape")
    for vertices in (star, star[::-1], np.array([[2.3, 1.7], [29.2, 4.4], [5.5, 21.9]])):
        np.testing.assert_allclose(
            coverage(vertices, shape=SHAPE), _shapely_coverage(vertices, SHAPE), atol=1e-9
        )


def test_line_coverage_is_exact_area():
    p0, p1 = jnp.array([3.2, 4.1]), jnp.array([27.5, 18.3])
    got = raster.line_coverage(p0, p1, SHAPE, width=1.5)
    d = (p1 - p0) / jnp.linalg.norm(p1 - p0)
    n = jnp.array([-d[1], d[0]]) * 0.75
    rect = np.asarray(jnp.stack([p0 - n, p1 - n, p1 + n, p0 + n]))
    np.testing.assert_allclose(got, _shapely_coverage(rect, SHAPE), atol=1e-9)
    np.testing.assert_allclose(got.sum(), 1.5 * jnp.linalg.norm(p1 - p0), rtol=1e-12)


def test_supersample_converges_to_coverage():
    vertices = jnp.array([[2.3, 1.7], [29.2, 4.4], [5.5, 21.9]])
    exact = raster.polygon_coverage(vertices, SHAPE)
    images = [
        raster.supersample(lambda p: raster.inside_polygon(p, vertices), SHAPE, samples=k)
        for k in (1, 4, 16)
    ]
    errors = [float(jnp.abs(image - exact).mean()) for image in images]
    assert errors[0] > errors[1] > errors[2] and errors[2] < 2e-3
    np.testing.assert_array_equal(images[0], raster.fill_polygon(vertices, SHAPE))
    # a half-plane edge on the sub-sample grid is reproduced exactly
    half = raster.supersample(lambda p: p[..., 0] < 3.25, (2, 6), samples=4)
    np.testing.assert_allclose(half[0], [1, 1, 1, 0.75, 0, 0])


def test_coverage_gradients():
    vertices = jnp.array([[1.3, 1.2], [6.6, 2.1], [4.2, 6.4], [1.9, 4.8]])
    polygon = jax.jit(lambda v: raster.polygon_coverage(v, (8, 8)))
    check_grads(polygon, (vertices,), order=1, modes=["rev"], atol=1e-5, rtol=1e-5)
    line = jax.jit(lambda a, b, w: raster.line_coverage(a, b, (8, 8), width=w))
    args = (jnp.array([1.3, 2.2]), jnp.array([6.1, 5.4]), jnp.asarray(1.3))
    check_grads(line, args, order=1, modes=["rev"], atol=1e-5, rtol=1e-5)
    # a polygon inside one pixel, and a zero-length line: finite gradients
    ones = jnp.ones((8, 8))
    _, pullback = jax.vjp(polygon, vertices / 8 + 1)
    assert jnp.all(jnp.isfinite(pullback(ones)[0]))
    _, pullback = jax.vjp(line, args[0], args[0], args[2])
    assert all(jnp.all(jnp.isfinite(g)) for g in pullback(ones))


def test_antialiasing_bad_inputs():
    with pytest.raises(TypeError, match="fn"):
        raster.supersample(3, SHAPE)
    with pytest.raises(ValueError, match="samples"):
        raster.supersample(lambda p: p[..., 0] > 0, SHAPE, samples=0)
    with pytest.raises(ValueError, match="fn"):
        raster.supersample(lambda p: p, SHAPE)
    with pytest.raises(ValueError, match="vertices"):
        raster.polygon_coverage(jnp.zeros((2, 2)), SHAPE)
    with pytest.raises(ValueError, match="width"):
        raster.line_coverage(jnp.zeros(2), jnp.ones(2), SHAPE, width=0.0)
    with pytest.raises(ValueError, match="p1"):
        raster.line_coverage(jnp.zeros(2), jnp.ones(3), SHAPE)


# --------------------------------------------------------------------------- displays


@pytest.mark.parametrize("interlaced", [False, True])
def test_raster_scan_refreshes_the_frame_buffer(interlaced):
    rng = np.random.default_rng(5)
    frame = jnp.asarray(rng.uniform(0.1, 1.0, (7, 6)))
    beam = raster.raster_scan(frame, interlaced=interlaced, h_retrace=3, v_retrace=5)
    fields = 2 if interlaced else 1
    assert beam.positions.shape == (7 * 6 + (7 - fields) * 3 + fields * 5, 2)
    on = np.asarray(beam.on)
    assert on.sum() == 42 and np.all(np.asarray(beam.intensity)[~on] == 0)
    order = list(range(0, 7, 2)) + list(range(1, 7, 2)) if interlaced else list(range(7))
    np.testing.assert_array_equal(np.asarray(beam.intensity)[on], np.asarray(frame)[order].ravel())
    centres = np.asarray(raster.pixel_centers((7, 6)))[order].reshape(-1, 2)
    np.testing.assert_array_equal(np.asarray(beam.positions)[on], centres)
    # With no decay, one refresh paints exactly the frame buffer onto the screen.
    screen = raster.phosphor_frames(beam, (7, 6), num_frames=3, decay=1.0)
    np.testing.assert_allclose(screen[-1], frame)
    # Halfway through an interlaced refresh only the first field has been drawn.
    if interlaced:
        half = raster.phosphor_frames(beam, (7, 6), num_frames=2, decay=1.0)[0]
        assert np.all(np.asarray(half)[1::2] == 0) and np.all(np.asarray(half)[0:6:2] > 0)


def test_random_scan_draws_the_display_list():
    segments = jnp.array([[[1.0, 1.0], [8.0, 5.0]], [[0.0, 7.0], [9.0, 7.0]]])
    beam = raster.random_scan(
        segments, intensity=jnp.array([1.0, 0.5]), samples_per_segment=10, move_samples=3
    )
    assert beam.positions.shape == (26, 2)
    on = np.asarray(beam.on)
    assert on.sum() == 20
    lit = np.asarray(beam.positions)[on].reshape(2, 10, 2)
    np.testing.assert_allclose(lit[:, 0], segments[:, 0])
    np.testing.assert_allclose(lit[:, -1], segments[:, 1])
    # the drawn samples lie on their segments (cross product zero)
    d = np.asarray(segments[:, 1] - segments[:, 0])
    rel = lit - np.asarray(segments[:, :1])
    np.testing.assert_allclose(
        rel[..., 0] * d[:, None, 1] - rel[..., 1] * d[:, None, 0], 0, atol=1e-12
    )
    screen = raster.phosphor_frames(beam, (9, 10), num_frames=1, decay=1.0, refreshes=2)
    assert float(screen[0][1, 5]) == 1.0  # y = 7 line (row 1) fully lit after two refreshes
    assert float(screen[0].max()) <= 1.0


def test_display_bad_inputs():
    with pytest.raises(ValueError, match="frame_buffer"):
        raster.raster_scan(jnp.zeros((2, 3, 3)))
    with pytest.raises(ValueError, match="h_retrace"):
        raster.raster_scan(jnp.zeros((2, 3)), h_retrace=0)
    with pytest.raises(ValueError, match="display_list"):
        raster.random_scan(jnp.zeros((3, 2)))
    with pytest.raises(ValueError, match="samples_per_segment"):
        raster.random_scan(jnp.zeros((1, 2, 2)), samples_per_segment=1)
    beam = raster.random_scan(jnp.zeros((1, 2, 2)))
    with pytest.raises(ValueError, match="decay"):
        raster.phosphor_frames(beam, (4, 4), decay=1.5)
    with pytest.raises(TypeError, match="beam"):
        raster.phosphor_frames((1, 2), (4, 4))
