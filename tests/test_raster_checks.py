"""gfxlab.raster: bad inputs (eagerly and under jit), size limits, and eager == jit."""

import logging

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gfxlab import raster

NAN_SQUARE = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, np.nan], [0.0, 4.0]])
SQUARE = np.array([[0.5, 0.5], [4.5, 1.0], [4.0, 4.5], [1.0, 4.0]])
# Under jit a value check fires at run time (equinox.error_if); the message names the
# argument either way.
RUNTIME = (ValueError, RuntimeError)


# --------------------------------------------------------------------------- None


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: raster.points_to_image(None, (4, 4)), "points"),
        (lambda: raster.points_to_image(jnp.zeros((1, 2), int), None), "shape"),
        (lambda: raster.line_dda(None, (1, 1)), "p0"),
        (lambda: raster.line_bresenham((0, 0), None), "p1"),
        (lambda: raster.line_dda_steps(None, (1, 1)), "p0"),
        (lambda: raster.midpoint_circle(None), "radius"),
        (lambda: raster.midpoint_circle(3, center=None), "center"),
        (lambda: raster.midpoint_ellipse(3, None), "ry"),
        (lambda: raster.inside_polygon(None, SQUARE), "points"),
        (lambda: raster.inside_polygon(SQUARE, None), "vertices"),
        (lambda: raster.fill_polygon(None, (4, 4)), "vertices"),
        (lambda: raster.fill_polygon_scanline(None, (4, 4)), "vertices"),
        (lambda: raster.polygon_coverage(None, (4, 4)), "vertices"),
        (lambda: raster.line_coverage(None, [1.0, 1.0], (4, 4)), "p0"),
        (lambda: raster.line_coverage([0.0, 0.0], [1.0, 1.0], (4, 4), width=None), "width"),
        (lambda: raster.supersample(None, (4, 4)), "fn"),
        (lambda: raster.raster_scan(None), "frame_buffer"),
        (lambda: raster.random_scan(None), "display_list"),
        (lambda: raster.phosphor_frames(None, (4, 4)), "beam"),
    ],
)
def test_none_is_a_type_error_naming_the_argument(call, name):
    with pytest.raises(TypeError, match=name):
        call()


# --------------------------------------------------------------------------- sizes


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: raster.line_dda((0, 0), (10**9, 3)), "p1"),
        (lambda: raster.line_bresenham((-(10**12), 0), (0, 0)), "p0"),
        (lambda: raster.line_dda_steps((0, 0), (0, 10**6)), "p1"),
        (lambda: raster.line_bresenham_steps((0, 0), (raster.MAX_LINE_COORDINATE + 1, 0)), "p1"),
        (lambda: raster.points_to_image(jnp.zeros((1, 2), int), (10**7, 10)), "shape"),
        (lambda: raster.fill_polygon(SQUARE, (4, 10**8)), "shape"),
        (lambda: raster.polygon_coverage(SQUARE, (10**6, 10**6)), "shape"),
        (lambda: raster.supersample(lambda p: p[..., 0] > 0, (4, 4), samples=10**5), "samples"),
        (lambda: raster.raster_scan(jnp.zeros((2, 2)), h_retrace=10**9), "h_retrace"),
        (lambda: raster.random_scan(jnp.zeros((1, 2, 2)), samples_per_segment=10**8), "samples"),
        (
            lambda: raster.phosphor_frames(
                raster.raster_scan(jnp.zeros((2, 2))), (2, 2), num_frames=10**7
            ),
            "num_frames",
        ),
        (
            lambda: raster.phosphor_frames(
                raster.raster_scan(jnp.zeros((2, 2))), (2, 2), num_frames=4000, refreshes=4000
            ),
            "refreshes",
        ),
    ],
)
def test_huge_sizes_are_refused_before_allocating(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_lines_at_the_documented_limit_are_exact():
    lim = raster.MAX_LINE_COORDINATE
    p0, p1 = (-lim, -lim // 3), (lim, lim // 2)
    for a, b in (
        (raster.line_dda, raster.line_dda_steps),
        (raster.line_bresenham, raster.line_bresenham_steps),
    ):
        np.testing.assert_array_equal(a(p0, p1), b(p0, p1))
    pts = np.asarray(raster.line_bresenham(p0, p1))
    assert tuple(pts[0]) == p0 and tuple(pts[-1]) == p1 and len(pts) == 2 * lim + 1


# --------------------------------------------------------------------------- NaN / range


def test_nan_vertices_are_rejected_eagerly():
    points = jnp.zeros((3, 2))
    for call in (
        lambda: raster.inside_polygon(points, NAN_SQUARE),
        lambda: raster.fill_polygon(NAN_SQUARE, (4, 4)),
        lambda: raster.fill_polygon_scanline(NAN_SQUARE, (4, 4)),
        lambda: raster.polygon_coverage(NAN_SQUARE, (4, 4)),
    ):
        with pytest.raises(ValueError, match="vertices.*finite"):
            call()


def test_nan_vertices_are_rejected_under_jit():
    points = jnp.zeros((3, 2))
    for fn in (
        jax.jit(lambda v: raster.inside_polygon(points, v)),
        jax.jit(lambda v: raster.fill_polygon(v, (4, 4))),
        jax.jit(lambda v: raster.polygon_coverage(v, (4, 4))),
    ):
        with pytest.raises(RUNTIME, match="vertices"):
            jax.block_until_ready(fn(jnp.asarray(NAN_SQUARE)))
        jax.block_until_ready(fn(jnp.asarray(SQUARE)))  # finite input still works


@pytest.mark.parametrize("width", [0.0, -1.0, np.inf, np.nan])
def test_line_coverage_width_checked_eagerly_and_under_jit(width):
    p0, p1 = jnp.array([0.5, 0.5]), jnp.array([3.0, 2.0])
    with pytest.raises(ValueError, match="width"):
        raster.line_coverage(p0, p1, (4, 4), width=width)
    fn = jax.jit(lambda w: raster.line_coverage(p0, p1, (4, 4), width=w))
    with pytest.raises(RUNTIME, match="width"):
        jax.block_until_ready(fn(jnp.asarray(width)))


def test_line_coverage_nan_endpoint_rejected():
    with pytest.raises(ValueError, match="p1"):
        raster.line_coverage(jnp.array([0.0, 0.0]), jnp.array([np.nan, 1.0]), (4, 4))


@pytest.mark.parametrize("decay", [0.0, 1.5, np.nan, np.inf])
def test_phosphor_decay_checked_eagerly_and_under_jit(decay):
    beam = raster.raster_scan(jnp.ones((2, 3)))
    with pytest.raises(ValueError, match="decay"):
        raster.phosphor_frames(beam, (2, 3), decay=decay)
    fn = jax.jit(lambda d: raster.phosphor_frames(beam, (2, 3), decay=d))
    with pytest.raises(RUNTIME, match="decay"):
        jax.block_until_ready(fn(jnp.asarray(decay)))


def test_display_inputs_reject_nan():
    with pytest.raises(ValueError, match="frame_buffer"):
        raster.raster_scan(jnp.array([[0.0, np.nan]]))
    with pytest.raises(ValueError, match="display_list"):
        raster.random_scan(jnp.full((1, 2, 2), np.inf))
    with pytest.raises(ValueError, match="intensity"):
        raster.random_scan(jnp.zeros((1, 2, 2)), intensity=jnp.array([np.nan]))


# --------------------------------------------------------------------------- eager == jit


def test_eager_equals_jit():
    frame = jnp.linspace(0.0, 1.0, 12).reshape(3, 4)
    segments = jnp.array([[[0.0, 0.0], [3.0, 2.0]], [[1.0, 2.0], [2.0, 0.0]]])
    beam = raster.raster_scan(frame)
    cases = [
        (lambda v: raster.fill_polygon(v, (6, 5)), SQUARE),
        (lambda v: raster.fill_polygon_scanline(v, (6, 5)), SQUARE),
        (lambda v: raster.polygon_coverage(v, (6, 5)), SQUARE),
        (lambda v: raster.inside_polygon(v + 0.25, SQUARE), SQUARE),
        (lambda v: raster.line_coverage(v[0], v[2], (6, 5), width=1.5), SQUARE),
        (
            lambda v: raster.supersample(lambda p: raster.inside_polygon(p, v), (6, 5), samples=3),
            SQUARE,
        ),
        (lambda f: raster.raster_scan(f, interlaced=True).intensity, frame),
        (lambda s: raster.random_scan(s, samples_per_segment=3).positions, segments),
        (lambda d: raster.phosphor_frames(beam, (3, 4), decay=d, num_frames=3), 0.9),
        (lambda c: raster.midpoint_circle(4, center=c), jnp.array([2, 3])),
        (lambda c: raster.midpoint_ellipse(4, 2, center=c), jnp.array([2, 3])),
        (lambda p: raster.points_to_image(p, (6, 5)), jnp.array([[1, 1], [4, 5], [9, 9]])),
    ]
    for fn, arg in cases:
        eager, jitted = np.asarray(fn(arg)), np.asarray(jax.jit(fn)(arg))
        assert eager.dtype == jitted.dtype and eager.shape == jitted.shape
        # Integer and boolean results are identical; XLA may reassociate float sums.
        np.testing.assert_allclose(eager, jitted, rtol=1e-13, atol=1e-15)


def test_stepwise_lines_compile_once_per_length_and_axis(caplog):
    def compiles(p0, p1):
        caplog.clear()
        with jax.log_compiles(True), caplog.at_level(logging.WARNING, logger="jax"):
            raster.line_dda_steps(p0, p1)
        return [r for r in caplog.records if r.getMessage().startswith("Compiling")]

    jax.clear_caches()  # what other tests compiled in this process must not count
    compiles((0, 0), (7, 3))
    assert not compiles((5, -2), (-2, -5))  # same length and axis, other start and signs
    assert compiles((0, 0), (3, 9))  # the other axis: a new program (the check can fail)


# ------------------------------------------------------- centres, points, beams (issue 17)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: raster.midpoint_circle(3, center=(10**12, 0)), "center"),
        (lambda: raster.midpoint_ellipse_steps(3, 2, center=(0, -(2**31))), "center"),
        (lambda: raster.inside_polygon([[np.nan, 0.0]], SQUARE), "points"),
        (lambda: raster.BeamPath([[0.0, 0.0]], [2.0], [True]), "intensity"),
        (lambda: raster.BeamPath([[0.0, np.inf]], [1.0], [True]), "positions"),
        (lambda: raster.BeamPath([[0.0, 0.0]], [1.0], [True, False]), "on"),
        (lambda: raster.BeamPath(np.zeros((0, 2)), [], []), "positions"),
    ],
)
def test_huge_centres_nan_points_and_bad_beams_are_value_errors(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_beam_path_types_and_traced_checks():
    with pytest.raises(TypeError, match="positions"):
        raster.BeamPath(None, [1.0], [True])
    with pytest.raises(TypeError, match="on"):
        raster.BeamPath([[0.0, 0.0]], [1.0], [1])
    make = jax.jit(lambda i: raster.BeamPath(jnp.zeros((2, 2)), i, jnp.array([True, False])))
    with pytest.raises(RUNTIME, match="intensity"):
        jax.block_until_ready(make(jnp.array([0.5, np.nan])))
    with pytest.raises(RUNTIME, match="points"):
        jax.block_until_ready(jax.jit(raster.inside_polygon)(jnp.full((1, 2), np.nan), SQUARE))
    beam = raster.random_scan(jnp.array([[[0.0, 0.0], [3.0, 2.0]]]))  # built under jit
    assert isinstance(beam, raster.BeamPath) and beam.positions.shape[0] == beam.on.shape[0]


def test_points_to_image_rejects_non_numbers():
    with pytest.raises(TypeError, match="points"):
        raster.points_to_image("abc", (4, 4))


def test_frame_buffer_shape_message_says_2d_in_words():
    # was "must have shape (n, n)", which reads as "square"
    with pytest.raises(ValueError, match=r"`frame_buffer` must be a 2-D array \(any sizes\), got"):
        raster.raster_scan(np.zeros(5))
