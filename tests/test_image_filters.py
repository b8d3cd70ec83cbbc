"""gfxlab.image filters: median (selection networks), mean and Gaussian, against SciPy."""

import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.ndimage as ndi
from hypothesis import given, settings
from hypothesis import strategies as st
from jax.test_util import check_grads

from gfxlab import image as gi

RNG = np.random.default_rng(20261123)
# One image size for most tests, so the compiled primitives are reused across tests.
SHAPE = (11, 14)

# The seed's 3x3 example (Q5c).
SEED_IMAGE = np.array([[91, 55, 90], [77, 68, 95], [115, 151, 210]], dtype=np.uint8)


def random_image(shape, dtype, *, levels=None):
    if levels is not None:  # many ties
        return RNG.integers(0, levels, shape).astype(dtype)
    if np.issubdtype(dtype, np.integer):
        return RNG.integers(0, 256, shape).astype(dtype)
    return RNG.random(shape).astype(dtype)


def scipy_median(image, *, size=None, footprint=None, mode="reflect", cval=0.0):
    """scipy.ndimage.median_filter applied per channel of an (H, W, C) image."""
    if footprint is not None and image.ndim == 3:
        footprint = footprint[..., None]
    if size is not None and image.ndim == 3:
        size = (*np.broadcast_to(size, (2,)), 1)
    return ndi.median_filter(image, size=size, footprint=footprint, mode=mode, cval=cval)


# --------------------------------------------------------------------------- networks


def run_numpy(ops, wires):
    wires = list(wires)
    for keep_min, keep_max, lo, hi in ops:
        a, b = wires[lo], wires[hi]
        if keep_min:
            wires[lo] = np.minimum(a, b)
        if keep_max:
            wires[hi] = np.maximum(a, b)
    return wires


@pytest.mark.parametrize("n", range(1, 15))
def test_selection_network_zero_one_principle(n):
    # A comparator network selects rank r of every input iff it does so for every 0-1
    # input (Knuth 5.3.4): checking all 2^n of them proves the network correct.
    bits = ((np.arange(2**n)[:, None] >> np.arange(n)) & 1).astype(np.uint8)
    ranks = (n // 2,) if n % 2 else (n // 2 - 1, n // 2)
    wires = run_numpy(gi.selection_network(n, ranks), list(bits.T))
    expected = np.sort(bits, axis=1)
    for r in ranks:
        np.testing.assert_array_equal(wires[r], expected[:, r])
    for r in (0, n - 1):
        wires = run_numpy(gi.selection_network(n, (r,)), list(bits.T))
        np.testing.assert_array_equal(wires[r], expected[:, r])


def test_selection_network_is_pruned():
    full_sort = len(gi.selection_network(9, tuple(range(9))))
    median9 = gi.selection_network(9, (4,))
    assert len(median9) < full_sort
    # min and max alone take n - 1 single comparisons.
    assert len(gi.selection_network(9, (0,))) == 8
    assert all(not keep_max for _, keep_max, _, _ in gi.selection_network(9, (0,)))


def test_selection_network_bad_input():
    with pytest.raises(ValueError, match="ranks"):
        gi.selection_network(5, (5,))
    with pytest.raises(ValueError, match="ranks"):
        gi.selection_network(5, ())
    with pytest.raises(ValueError, match="n"):
        gi.selection_network(0, (0,))


# --------------------------------------------------------------------------- median


def test_seed_examples_91_and_77():
    values = sorted(SEED_IMAGE.ravel().tolist())  # the seed sorts the 9 values
    assert values[4] == 91
    cross = sorted([55, 77, 68, 95, 151])  # the 5-pixel cross of the seed
    assert cross[2] == 77
    assert int(gi.median_filter(SEED_IMAGE, size=3)[1, 1]) == values[4] == 91
    assert int(gi.median_filter(SEED_IMAGE, footprint=gi.cross_footprint())[1, 1]) == 77
    assert int(gi.median(jnp.asarray(SEED_IMAGE.ravel()))) == 91


MEDIAN_DTYPES = (np.uint8, np.float64, np.float32, np.int16)
MEDIAN_SIZES = (1, 3, 5, 7)
#: The "thorough" hypothesis profile (`HYPOTHESIS_PROFILE=thorough` or pytest's
#: `--hypothesis-profile=thorough`) sweeps every size for every mode and dtype.
THOROUGH = settings().max_examples >= settings.get_profile("thorough").max_examples


@pytest.mark.parametrize("dtype", MEDIAN_DTYPES)
@pytest.mark.parametrize("mode", gi.MODES)
def test_median_square_matches_scipy(mode, dtype):
    """Each (mode, dtype) runs two of the four sizes, chosen so that every size still
    meets every mode and every dtype (half the compiled programs of the full sweep)."""
    image = random_image(SHAPE, dtype)
    shift = gi.MODES.index(mode) + MEDIAN_DTYPES.index(dtype)
    pair = (MEDIAN_SIZES[shift % 4], MEDIAN_SIZES[(shift + 2) % 4])
    sizes = MEDIAN_SIZES if THOROUGH else pair
    for size in sizes:
        ours = np.asarray(gi.median_filter(image, size=size, mode=mode, cval=3))
        ref = scipy_median(image, size=size, mode=mode, cval=3)
        assert ours.dtype == ref.dtype
        np.testing.assert_array_equal(ours, ref, err_msg=f"size={size}")


@pytest.mark.parametrize("mode", gi.MODES)
def test_median_rectangles_and_ties_match_scipy(mode):
    image = random_image(SHAPE, np.uint8, levels=3)  # heavy ties
    for size in [(3, 5), (5, 3), (1, 7), (7, 1), 3, 5]:
        ours = np.asarray(gi.median_filter(image, size=size, mode=mode))
        np.testing.assert_array_equal(ours, scipy_median(image, size=size, mode=mode))


@pytest.mark.parametrize("mode", gi.MODES)
def test_median_footprints_match_scipy(mode):
    image = random_image((*SHAPE, 2), np.uint8)
    footprints = [gi.cross_footprint(1), gi.cross_footprint(2)]
    while len(footprints) < 8:
        fp = RNG.random((RNG.integers(1, 6), RNG.integers(1, 6))) < 0.6
        if fp.sum() % 2 == 1:
            footprints.append(fp)
    for fp in footprints:
        ours = np.asarray(gi.median_filter(image, footprint=fp, mode=mode, cval=7.0))
        ref = scipy_median(image, footprint=fp, mode=mode, cval=7.0)
        np.testing.assert_array_equal(ours, ref, err_msg=str(fp.astype(int)))


@pytest.mark.parametrize("mode", gi.MODES)
def test_median_even_windows_average_two_middle_values(mode):
    image = random_image(SHAPE, np.uint8)
    even_fp = np.array([[1, 1, 0], [0, 1, 1]], dtype=bool)
    for kwargs in [{"size": 2}, {"size": 4}, {"size": (2, 3)}, {"footprint": even_fp}]:
        n = (
            int(even_fp.sum())
            if "footprint" in kwargs
            else int(np.prod(np.broadcast_to(kwargs["size"], (2,))))
        )
        k = n // 2
        low = ndi.rank_filter(image, rank=k - 1, mode=mode, cval=5, **kwargs).astype(float)
        high = ndi.rank_filter(image, rank=k, mode=mode, cval=5, **kwargs).astype(float)
        ours = gi.median_filter(image, mode=mode, cval=5, **kwargs)
        assert jnp.issubdtype(ours.dtype, jnp.floating)  # half-integers are possible
        np.testing.assert_array_equal(np.asarray(ours), (low + high) / 2)
    floats = random_image(SHAPE, np.float32)
    assert gi.median_filter(floats, size=2).dtype == np.float32


def test_median_even_rule_on_a_window():
    # Window of 4 values 10, 20, 30, 100: the 2nd and 3rd sorted values average to 25.
    assert float(gi.median(jnp.array([30, 10, 100, 20]))) == 25.0
    np.testing.assert_array_equal(gi.median(jnp.array([[1.0, 2.0], [4.0, 3.0]])), [1.5, 3.5])


MEDIAN = jax.jit(gi.median)


@given(st.lists(st.integers(-50, 50), min_size=1, max_size=12))
def test_median_of_values_matches_numpy(values):
    assert float(MEDIAN(jnp.asarray(values))) == float(np.median(values))


def test_median_axis():
    x = RNG.random((4, 7, 5))
    np.testing.assert_array_equal(gi.median(x, axis=1), np.median(x, axis=1))


def test_median_is_not_linear():
    lhs, rhs = gi.median_of_sum(jnp.array([1, 5, 2]), jnp.array([4, 0, 0]))
    assert (int(lhs), int(rhs)) == (5, 2)
    # ...but it commutes with adding a constant and with scaling by a positive number.
    x = jnp.asarray(RNG.random((6, 9)))
    lhs, rhs = gi.median_of_sum(x, jnp.full_like(x, 0.25))
    np.testing.assert_allclose(lhs, rhs)
    np.testing.assert_allclose(gi.median(3 * x), 3 * gi.median(x))


def test_median_filter_jit_and_vmap(maybe_jit):
    images = random_image((3, 9, 8, 3), np.float64)
    f = maybe_jit(gi.median_filter, static_argnames=("size", "mode"))
    for image in images:
        np.testing.assert_array_equal(
            f(image, size=3, mode="wrap"), scipy_median(image, size=3, mode="wrap")
        )
    batched = jax.vmap(lambda im: gi.median_filter(im, size=5, mode="mirror"))(images)
    for image, out in zip(images, batched, strict=True):
        np.testing.assert_array_equal(out, scipy_median(image, size=5, mode="mirror"))


def test_median_filter_removes_salt_and_pepper_better_than_mean():
    clean = jnp.asarray(gi.synthetic_scene((64, 64)))
    noisy = gi.add_salt_and_pepper(clean, amount=0.1, key=jax.random.key(0))
    hit = np.any(np.asarray(noisy) != np.asarray(clean), axis=-1)
    assert 0.07 < hit.mean() < 0.13
    assert set(np.unique(np.asarray(noisy)[hit])) <= {0.0, 1.0}
    err_median = float(jnp.mean(jnp.abs(gi.median_filter(noisy, size=3) - clean)))
    err_mean = float(jnp.mean(jnp.abs(gi.mean_filter(noisy, size=3) - clean)))
    err_noisy = float(jnp.mean(jnp.abs(noisy - clean)))
    assert err_median < 0.5 * err_mean < err_noisy


def test_median_gradient_goes_to_the_selected_pixel():
    # Distinct values (no ties), spaced 1/64 apart: the median is smooth nearby.
    image = jnp.asarray(RNG.permutation(64).reshape(8, 8) / 64.0)
    square = jax.jit(lambda im: gi.median_filter(im, size=3))
    check_grads(square, (image,), order=1, modes=("rev",), eps=1e-4)
    cross = jax.jit(lambda im: gi.median_filter(im, footprint=gi.cross_footprint(), mode="wrap"))
    check_grads(cross, (image,), order=1, modes=("rev",), eps=1e-4)
    # d out[4, 5] / d image, through the VJP check_grads compiled
    pick = np.zeros((8, 8))
    pick[4, 5] = 1.0
    grad = jax.vjp(square, image)[1](jnp.asarray(pick))[0]
    window = np.asarray(image)[3:6, 4:7]
    expected = np.zeros((8, 8))
    r, c = np.argwhere(window == np.median(window))[0]
    expected[3 + r, 4 + c] = 1.0
    np.testing.assert_array_equal(grad, expected)


def test_median_bad_input():
    image = np.zeros((5, 5))
    with pytest.raises(ValueError, match="image"):
        gi.median_filter(np.zeros(5))
    with pytest.raises(ValueError, match="image"):
        gi.median_filter(np.zeros((2, 3, 4, 5)))
    with pytest.raises(ValueError, match="mode"):
        gi.median_filter(image, mode="periodic")
    with pytest.raises(TypeError, match="footprint"):
        gi.median_filter(image, footprint=np.ones((3, 3), dtype=int))
    with pytest.raises(ValueError, match="footprint"):
        gi.median_filter(image, footprint=np.zeros((3, 3), dtype=bool))
    with pytest.raises(ValueError, match="footprint"):
        gi.median_filter(image, footprint=np.ones(3, dtype=bool))
    with pytest.raises(ValueError, match="size"):
        gi.median_filter(image, size=0)
    with pytest.raises(TypeError, match="size"):
        gi.median_filter(image, size=2.5)
    with pytest.raises(ValueError, match="size"):
        gi.median_filter(image, size=(3, 3, 3))
    with pytest.raises(ValueError, match="values"):
        gi.median(jnp.float32(1.0))
    with pytest.raises(ValueError, match="values"):
        gi.median(jnp.zeros((3, 0)))
    with pytest.raises(ValueError, match="one shape"):
        gi.median_of_sum(jnp.zeros(3), jnp.zeros(4))
    with pytest.raises(ValueError, match="radius"):
        gi.cross_footprint(-1)


# --------------------------------------------------------------------------- linear filters


@pytest.mark.parametrize("mode", gi.MODES)
def test_mean_filter_matches_scipy(mode):
    image = random_image((*SHAPE, 3), np.float64)
    for size in (1, 3, 4, (2, 5)):
        ours = gi.mean_filter(image, size=size, mode=mode, cval=0.5)
        full = (*np.broadcast_to(size, (2,)), 1)
        ref = ndi.uniform_filter(image, size=full, mode=mode, cval=0.5)
        np.testing.assert_allclose(ours, ref, rtol=1e-12, atol=1e-12)
    grey = random_image(SHAPE, np.uint8)  # integer input: a float result
    np.testing.assert_allclose(
        gi.mean_filter(grey, size=3), ndi.uniform_filter(grey.astype(float), 3)
    )


@pytest.mark.parametrize("mode", gi.MODES)
def test_gaussian_filter_matches_scipy(mode):
    image = random_image(SHAPE, np.float64)
    for sigma in (0.5, 2.5, (1.0, 2.0)):
        ours = gi.gaussian_filter(image, sigma=sigma, mode=mode, cval=0.2)
        ref = ndi.gaussian_filter(image, sigma=sigma, mode=mode, cval=0.2)
        np.testing.assert_allclose(ours, ref, rtol=1e-12, atol=1e-12)
    ours = gi.gaussian_filter(image, sigma=1.5, truncate=2.0, mode=mode)
    np.testing.assert_allclose(
        ours, ndi.gaussian_filter(image, 1.5, truncate=2.0, mode=mode), atol=1e-12
    )
    ours = gi.gaussian_filter(image, sigma=1.5, radius=2, mode=mode)
    np.testing.assert_allclose(
        ours, ndi.gaussian_filter(image, 1.5, radius=2, mode=mode), atol=1e-12
    )


def test_linear_filters_are_linear_and_differentiable(maybe_jit):
    x, y = random_image(SHAPE, np.float64), random_image(SHAPE, np.float64)
    mean = maybe_jit(gi.mean_filter, static_argnames=("size", "mode"))
    np.testing.assert_allclose(mean(x + 2 * y, size=3), mean(x, size=3) + 2 * mean(y, size=3))
    if maybe_jit is jax.jit:  # gradients once, compiled
        small = x[:5, :6]
        check_grads(jax.jit(lambda im: gi.mean_filter(im, size=3, mode="constant")), (small,), 1)
        check_grads(jax.jit(lambda im: gi.gaussian_filter(im, sigma=1.2, mode="wrap")), (small,), 1)
        # sigma is differentiable once the kernel radius is fixed.
        blur = jax.jit(lambda s: gi.gaussian_filter(small, sigma=s, radius=3))
        check_grads(blur, (1.3,), order=1)


def test_linear_filter_bad_input():
    image = np.zeros((5, 5))
    with pytest.raises(ValueError, match="mode"):
        gi.mean_filter(image, mode="grid")
    with pytest.raises(ValueError, match="image"):
        gi.gaussian_filter(np.zeros(4), sigma=1.0)
    with pytest.raises(ValueError, match="sigma"):
        gi.gaussian_filter(image, sigma=0.0, radius=2)
    with pytest.raises(TypeError, match="radius"):
        jax.jit(lambda s: gi.gaussian_filter(image, sigma=s))(1.0)
    with pytest.raises(ValueError, match="size"):
        gi.mean_filter(image, size=-1)


def test_salt_and_pepper_bad_input():
    with pytest.raises(ValueError, match="amount"):
        gi.add_salt_and_pepper(np.zeros((4, 4)), amount=1.5, key=jax.random.key(0))


def test_modes_cover_scipy_border_rules():
    row = np.arange(1.0, 5.0)[None, :]  # 1 2 3 4
    expected = {  # 3-tap mean at the first pixel: (left neighbour + 1 + 2) / 3
        "reflect": (1 + 1 + 2) / 3,
        "mirror": (2 + 1 + 2) / 3,
        "nearest": (1 + 1 + 2) / 3,
        "wrap": (4 + 1 + 2) / 3,
        "constant": (9 + 1 + 2) / 3,
    }
    for mode, value in expected.items():
        out = gi.mean_filter(row, size=(1, 3), mode=mode, cval=9.0)
        assert float(out[0, 0]) == pytest.approx(value)


def test_all_modes_all_sizes_small_images():
    # Windows much larger than the image: padding has to reflect/wrap repeatedly.
    for mode, (h, w) in itertools.product(gi.MODES, [(1, 1), (1, 2), (2, 3)]):
        image = random_image((h, w), np.uint8)
        np.testing.assert_array_equal(
            gi.median_filter(image, size=5, mode=mode), scipy_median(image, size=5, mode=mode)
        )
