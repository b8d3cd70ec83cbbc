"""Tests for gfxlab.clipping: outcodes, Cohen-Sutherland, Liang-Barsky, Sutherland-Hodgman."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st
from jax.test_util import check_grads

import gfxlab
from gfxlab import clipping

# JAX reports an exception raised while a compiled program runs as JaxRuntimeError or,
# on some dispatch paths, as ValueError; either carries the check's message.
JIT_ERRORS = (jax.errors.JaxRuntimeError, ValueError)


WINDOW = (2.0, 2.0, 10.0, 8.0)


def test_outcodes_nine_regions_as_in_the_exam_table(maybe_jit):
    xs, ys = (0.0, 6.0, 12.0), (10.0, 5.0, 0.0)  # left/inside/right, top/inside/bottom
    grid = jnp.array([[(x, y) for x in xs] for y in ys])
    codes = maybe_jit(clipping.outcode)(grid, jnp.asarray(WINDOW))
    exam_table = [[0b1001, 0b0001, 0b0101], [0b1000, 0b0000, 0b0100], [0b1010, 0b0010, 0b0110]]
    np.testing.assert_array_equal(codes, exam_table)
    # Points on the boundary are inside.
    edges = jnp.array([[2.0, 2.0], [10.0, 8.0], [2.0, 5.0], [6.0, 8.0]])
    np.testing.assert_array_equal(clipping.outcode(edges, WINDOW), 0)
    assert (clipping.LEFT, clipping.RIGHT, clipping.BOTTOM, clipping.TOP) == (8, 4, 2, 1)


def _segments(rng, count):
    """Random segments plus the degenerate cases: points, vertical, horizontal, on an
    edge, along an edge beyond the corners, through a corner, touching at a corner."""
    random = rng.uniform(-6.0, 18.0, (count, 2, 2))
    special = np.array(
        [
            [[4, 4], [4, 4]],
            [[0, 0], [0, 0]],
            [[2, 5], [2, 5]],
            [[10, 8], [10, 8]],
            [[5, -3], [5, 12]],
            [[-4, 6], [15, 6]],
            [[12, 1], [12, 9]],
            [[0, 9], [12, 9]],
            [[2, 0], [2, 12]],
            [[-1, 8], [13, 8]],
            [[4, 2], [7, 2]],
            [[10, 3], [10, 7]],
            [[1, 9], [3, 7]],
            [[1, 7], [3, 9]],
            [[9, 9], [11, 7]],
            [[0, 4], [4, 0]],
            [[-2, -2], [14, 14]],
            [[3, 3], [9, 7]],
            [[12, 5], [-3, 5]],
            [[6, 9], [6, 1]],
        ],
        float,
    )
    # random vertical and horizontal segments
    vertical = random[:200].copy()
    vertical[:, 1, 0] = vertical[:, 0, 0]
    horizontal = random[200:400].copy()
    horizontal[:, 1, 1] = horizontal[:, 0, 1]
    # random segments with one end exactly on a window edge
    on_edge = random[400:600].copy()
    on_edge[:100, 0, 0] = WINDOW[0]
    on_edge[100:, 0, 1] = WINDOW[3]
    return np.concatenate([random[600:], vertical, horizontal, on_edge, special])


def _shapely_reference(segments):
    box = shapely.box(*WINDOW)
    pieces = shapely.intersection(shapely.linestrings(segments), box)
    points = shapely.points(segments[:, 0])
    # shapely treats a zero-length linestring as a point: use `covers` for it
    zero = np.all(segments[:, 0] == segments[:, 1], axis=-1)
    visible = np.where(zero, shapely.covers(box, points), ~shapely.is_empty(pieces))
    return pieces, visible


def _assert_matches_shapely(segments, clipped, visible):
    pieces, expected_visible = _shapely_reference(segments)
    np.testing.assert_array_equal(visible, expected_visible)
    clipped = np.asarray(clipped)
    assert np.all(np.isnan(clipped[~expected_visible]))
    for i in np.flatnonzero(expected_visible):
        coords = shapely.get_coordinates(pieces[i]) if not pieces[i].is_empty else segments[i]
        # the clipped segment's ends are the extreme points of shapely's piece
        ref = np.array([coords[0], coords[-1]])
        ours = clipped[i]
        same = np.allclose(ours, ref, atol=1e-9, rtol=0)
        flipped = np.allclose(ours, ref[::-1], atol=1e-9, rtol=0)
        assert same or flipped, (i, segments[i], ours, ref)


def test_cohen_sutherland_matches_shapely(maybe_jit):
    segments = _segments(np.random.default_rng(0), 3000)
    clipped, visible = maybe_jit(clipping.cohen_sutherland)(segments, jnp.asarray(WINDOW))
    _assert_matches_shapely(segments, clipped, visible)
    # the clipped piece keeps the input's direction
    d_in = segments[:, 1] - segments[:, 0]
    d_out = np.asarray(clipped[:, 1] - clipped[:, 0])
    assert np.all(np.nan_to_num(np.sum(d_in * d_out, -1)) >= -1e-12)


def test_liang_barsky_matches_shapely_and_cohen_sutherland(maybe_jit):
    segments = _segments(np.random.default_rng(1), 3000)
    clipped, visible = maybe_jit(clipping.liang_barsky)(segments, jnp.asarray(WINDOW))
    _assert_matches_shapely(segments, clipped, visible)
    cs, cs_visible = clipping.cohen_sutherland(segments, WINDOW)
    np.testing.assert_array_equal(visible, cs_visible)
    np.testing.assert_allclose(clipped, cs, atol=1e-9)


def test_cohen_sutherland_steps_equal_vectorized():
    segments = _segments(np.random.default_rng(2), 1000).reshape(-1, 10, 2, 2)[:50]
    fast = jax.jit(clipping.cohen_sutherland)(segments, WINDOW)
    slow = jax.jit(clipping.cohen_sutherland_steps)(segments, WINDOW)
    np.testing.assert_array_equal(fast[1], slow[1])
    np.testing.assert_array_equal(fast[0], slow[0])  # NaN where invisible, in both
    assert fast[0].shape == (50, 10, 2, 2)


@given(st.lists(st.floats(-20, 20), min_size=4, max_size=4))
def test_trivial_accept_returns_segment_unchanged_and_clip_stays_inside(coords):
    segment = jnp.array(coords).reshape(1, 2, 2)
    clipped, visible = clipping.cohen_sutherland(segment, WINDOW)
    codes = clipping.outcode(segment[0], WINDOW)
    if int(codes[0] | codes[1]) == 0:
        assert bool(visible[0]) and np.array_equal(clipped, segment)
    if int(codes[0] & codes[1]) != 0:
        assert not bool(visible[0])
    if bool(visible[0]):
        assert np.all(clipping.outcode(clipped[0], WINDOW) == 0)


def test_exam_walkthrough_ad_and_ei():
    s = clipping.WALKTHROUGH_EXAMPLE
    window = s["window"]
    assert clipping.EDGE_ORDER == ("top", "bottom", "right", "left")
    code = {name: int(clipping.outcode(jnp.array(s[name]), window)) for name in "ABDEFGHI"}
    assert code == {
        "A": 0,
        "B": 0,
        "D": 0b1001,
        "E": 0b0010,
        "F": 0,
        "G": 0,
        "H": 0b0100,
        "I": 0b0101,
    }

    # The named points are where the exam says: B on the top edge of AD, C on its left
    # edge line, F on the bottom edge of EI, H on its top edge line, G on its right edge.
    def on_line(p, a, b):
        (px, py), (ax, ay), (bx, by) = p, a, b
        return abs((bx - ax) * (py - ay) - (by - ay) * (px - ax)) < 1e-12

    assert on_line(s["B"], s["A"], s["D"]) and s["B"][1] == window[3]
    assert on_line(s["C"], s["A"], s["D"]) and s["C"][0] == window[0]
    for name, axis, value in (("F", 1, window[1]), ("H", 1, window[3]), ("G", 0, window[2])):
        assert on_line(s[name], s["E"], s["I"]) and s[name][axis] == value

    ad = clipping.cohen_sutherland_trace([s["A"], s["D"]], window)
    assert [(r["action"], r["edge"], r["clipped_point"]) for r in ad] == [
        ("clip", "top", "p1"),
        ("accept", None, None),
    ]
    assert (ad[0]["code0"], ad[0]["code1"], ad[0]["and"], ad[0]["or"]) == (0, 9, 0, 9)
    assert ad[0]["new_point"] == s["B"] and ad[1]["p1"] == s["B"]

    ei = clipping.cohen_sutherland_trace([s["E"], s["I"]], window)
    assert [(r["action"], r["edge"], r["clipped_point"]) for r in ei] == [
        ("clip", "bottom", "p0"),
        ("clip", "top", "p1"),
        ("clip", "right", "p1"),
        ("accept", None, None),
    ]
    assert [r["new_point"] for r in ei[:3]] == [s["F"], s["H"], s["G"]]
    assert (ei[0]["code0"], ei[0]["code1"], ei[0]["and"], ei[0]["or"]) == (2, 5, 0, 7)
    assert ei[2]["code1"] == 0b0100
    assert (ei[-1]["p0"], ei[-1]["p1"]) == (s["F"], s["G"])
    # the trace ends where the vectorized clipper does
    clipped, _ = clipping.cohen_sutherland(jnp.array([[s["E"], s["I"]]]), window)
    np.testing.assert_allclose(clipped[0], [s["F"], s["G"]])

    reject = clipping.cohen_sutherland_trace([(0.0, 0.0), (1.0, 9.0)], window)
    assert [r["action"] for r in reject] == ["reject"] and reject[0]["and"] == clipping.LEFT


def test_clipping_gradients():
    segments = jnp.array([[[0.0, 4.0], [7.0, 11.0]], [[5.0, 0.5], [13.0, 6.0]]])
    window = jnp.array(WINDOW)
    for clip in (clipping.cohen_sutherland, clipping.liang_barsky):
        clipped = jax.jit(lambda s, w, clip=clip: clip(s, w)[0])
        check_grads(clipped, (segments, window), order=1, modes=["rev"])
        # a rejected segment (NaN in the output) gives zero, not NaN, gradients
        out, pullback = jax.vjp(clipped, segments + jnp.array([20.0, 0.0]), window)
        assert jnp.all(jnp.isnan(out))
        assert all(jnp.all(g == 0) for g in pullback(jnp.ones_like(out)))


def _star(rng, count, center, low, high):
    # jittered, evenly spread angles: every gap < pi, so the polygon is simple
    angles = (np.arange(count) + rng.uniform(0, 0.8, count)) * 2 * np.pi / count
    radii = rng.uniform(low, high, count)
    return np.stack([center[0] + radii * np.cos(angles), center[1] + radii * np.sin(angles)], -1)


def test_sutherland_hodgman_matches_shapely(maybe_jit):
    rng = np.random.default_rng(3)
    box = shapely.box(*WINDOW)
    clip = maybe_jit(clipping.sutherland_hodgman, static_argnames="max_vertices")
    for trial in range(12):
        if trial % 2:  # convex: 11 points on a circle
            polygon = _star(rng, 11, rng.uniform(0, 12, 2), 5.0, 5.0)
        else:  # simple, usually concave
            polygon = _star(rng, 11, rng.uniform(0, 12, 2), 1.0, 8.0)
        vertices, valid = clip(polygon, jnp.asarray(WINDOW), max_vertices=40)
        expected = shapely.Polygon(polygon).intersection(box)
        np.testing.assert_allclose(clipping.polygon_area(vertices, valid), expected.area, atol=1e-9)
        inside = np.asarray(vertices)[np.asarray(valid)]
        assert np.all(
            (inside >= np.array(WINDOW[:2]) - 1e-12) & (inside <= np.array(WINDOW[2:]) + 1e-12)
        )
        if trial % 2 and not expected.is_empty:  # convex: exactly shapely's vertices
            ref = np.asarray(expected.exterior.coords)[:-1]
            ours = np.unique(np.round(inside, 9), axis=0)
            np.testing.assert_allclose(ours, np.unique(np.round(ref, 9), axis=0), atol=1e-9)


def test_sutherland_hodgman_inside_outside_and_default_size():
    triangle = jnp.array([[3.0, 3.0], [9.0, 4.0], [5.0, 7.0]])
    vertices, valid = clipping.sutherland_hodgman(triangle, WINDOW)
    assert vertices.shape == (14, 2) and int(valid.sum()) == 3
    assert {tuple(v) for v in np.asarray(vertices[valid]).tolist()} == {
        tuple(v) for v in np.asarray(triangle).tolist()
    }
    _, valid = clipping.sutherland_hodgman(triangle + 20.0, WINDOW)
    assert not bool(valid.any())
    big = jnp.array([[0.0, 0.0], [12.0, 0.0], [12.0, 10.0], [0.0, 10.0]])
    vertices, valid = clipping.sutherland_hodgman(big, WINDOW)
    assert float(clipping.polygon_area(vertices, valid)) == 48.0


def test_clipping_bad_inputs():
    segments = jnp.zeros((3, 2, 2))
    for fn in (clipping.cohen_sutherland, clipping.cohen_sutherland_steps, clipping.liang_barsky):
        with pytest.raises(ValueError, match="window"):
            fn(segments, (10.0, 2.0, 2.0, 8.0))  # inverted
        with pytest.raises(ValueError, match="segments"):
            fn(jnp.zeros((3, 2)), WINDOW)
        with pytest.raises(ValueError, match="window"):
            fn(segments, (1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="window"):
        clipping.outcode(jnp.zeros((3, 2)), (0.0, 5.0, 1.0, 5.0))
    with pytest.raises(ValueError, match="points"):
        clipping.outcode(jnp.zeros((3, 3)), WINDOW)
    with pytest.raises(ValueError, match="segment"):
        clipping.cohen_sutherland_trace(jnp.zeros((3, 2)), WINDOW)
    with pytest.raises(TypeError, match="concrete"):
        jax.jit(clipping.cohen_sutherland_trace)(jnp.zeros((2, 2)), jnp.asarray(WINDOW))
    with pytest.raises(ValueError, match="`vertices` must hold at least 3 polygon"):
        clipping.sutherland_hodgman(jnp.zeros((2, 2)), WINDOW)
    with pytest.raises(ValueError, match="max_vertices"):
        clipping.sutherland_hodgman(jnp.zeros((4, 2)), WINDOW, max_vertices=2)
    big = jnp.array([[0.0, 0.0], [12.0, 0.0], [12.0, 10.0], [0.0, 10.0]])
    with pytest.raises(ValueError, match="max_vertices"):
        clipping.sutherland_hodgman(big + jnp.array([0.0, -1.0]), WINDOW, max_vertices=3)
    with pytest.raises(ValueError, match="valid"):
        clipping.polygon_area(big, jnp.ones(3, bool))


NAN, INF = float("nan"), float("inf")
SEG = jnp.array([[[-1.0, 5.0], [12.0, 5.0]]])
TRI = jnp.array([[0.0, 0.0], [12.0, 0.0], [6.0, 9.0]])


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (
            lambda: clipping.cohen_sutherland(SEG.at[0, 0, 0].set(NAN), WINDOW),
            ValueError,
            "`segments` must be finite",
        ),
        (
            lambda: clipping.cohen_sutherland_steps(SEG.at[0, 1, 1].set(INF), WINDOW),
            ValueError,
            "`segments` must be finite",
        ),
        (
            lambda: clipping.liang_barsky(SEG, (0.0, 0.0, INF, 1.0)),
            ValueError,
            "`window` must be finite",
        ),
        (lambda: clipping.liang_barsky(None, WINDOW), TypeError, "`segments` must be an array"),
        (
            lambda: clipping.outcode(jnp.array([[NAN, 0.0]]), WINDOW),
            ValueError,
            "`points` must be finite",
        ),
        (lambda: clipping.outcode(jnp.zeros((1, 2)), None), TypeError, "`window` must be an array"),
        (
            lambda: clipping.cohen_sutherland_trace(SEG[0].at[0, 0].set(NAN), WINDOW),
            ValueError,
            "`segment` must be finite",
        ),
        (
            lambda: clipping.sutherland_hodgman(TRI.at[1, 0].set(INF), WINDOW),
            ValueError,
            "`vertices` must be finite",
        ),
        (
            lambda: clipping.sutherland_hodgman(TRI, WINDOW, max_vertices=10**12),
            ValueError,
            "`max_vertices` must be <= 1000000",
        ),
        (
            lambda: clipping.sutherland_hodgman(TRI, WINDOW, max_vertices=2.5),
            TypeError,
            "`max_vertices` must be an int",
        ),
        (
            lambda: clipping.polygon_area(TRI.at[0, 0].set(NAN)),
            ValueError,
            "`vertices` must be finite",
        ),
        (
            lambda: clipping.polygon_area(TRI, jnp.ones(3)),
            TypeError,
            "`valid` must be a boolean mask",
        ),
        (lambda: clipping.polygon_area(TRI, "abc"), TypeError, "`valid` must be a boolean mask"),
    ],
)
def test_non_finite_and_huge_inputs_are_rejected_naming_the_argument(call, error, message):
    with pytest.raises(error, match=message):
        call()


@pytest.mark.parametrize(
    ("fn", "bad", "message"),
    [
        (
            lambda s: clipping.cohen_sutherland(s, WINDOW),
            SEG.at[0, 0, 0].set(NAN),
            "`segments` must be finite",
        ),
        (
            lambda s: clipping.liang_barsky(s, WINDOW),
            SEG.at[0, 0, 0].set(INF),
            "`segments` must be finite",
        ),
        (
            lambda w: clipping.outcode(jnp.zeros((1, 2)), w),
            jnp.array([0.0, 0, NAN, 1]),
            "`window` must be finite",
        ),
        (
            lambda p: clipping.sutherland_hodgman(p, WINDOW)[0],
            TRI.at[0, 0].set(NAN),
            "`vertices` must be finite",
        ),
    ],
)
def test_non_finite_inputs_under_jit_carry_the_same_message(fn, bad, message):

    with pytest.raises(JIT_ERRORS) as info:
        jax.jit(fn)(bad)
    assert gfxlab.check_message(info.value).startswith(message)
    with pytest.raises(ValueError, match=f"^{message}"):
        gfxlab.checked_jit(fn)(bad)
