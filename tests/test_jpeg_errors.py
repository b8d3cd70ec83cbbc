"""Every public function of gfxlab.jpeg: bad input gives a clear error naming the
argument, eagerly and (for value checks on arrays) under `jax.jit`."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gfxlab import jpeg

NAN = float("nan")
INF = float("inf")
Z8 = np.zeros((8, 8))
ONES8 = np.ones((8, 8))


def _with(array, index, value):
    out = np.array(array, float)
    out[index] = value
    return out


# (call, exception, message the error must contain); message names the argument.
CASES = [
    # None for array arguments
    (lambda: jpeg.rgb_to_ycbcr(None), TypeError, "`rgb`"),
    (lambda: jpeg.ycbcr_to_rgb(None), TypeError, "`ycbcr`"),
    (lambda: jpeg.subsample(None), TypeError, "`chroma`"),
    (lambda: jpeg.upsample(None, (4, 4)), TypeError, "`chroma`"),
    (lambda: jpeg.upsample(np.zeros((2, 2)), None), ValueError, "`shape`"),
    (lambda: jpeg.blocks(None), TypeError, "`plane`"),
    (lambda: jpeg.unblocks(None, (8, 8)), TypeError, "`block_array`"),
    (lambda: jpeg.unblocks(np.zeros((1, 1, 8, 8)), None), ValueError, "`shape`"),
    (lambda: jpeg.level_shift(None), TypeError, "`samples`"),
    (lambda: jpeg.dct2(None), TypeError, "`block`"),
    (lambda: jpeg.idct2(None), TypeError, "`coefficients`"),
    (lambda: jpeg.quant_tables(None), TypeError, "`quality`"),
    (lambda: jpeg.quant_tables_continuous(None), TypeError, "`quality`"),
    (lambda: jpeg.quantize(None, ONES8), TypeError, "`coefficients`"),
    (lambda: jpeg.quantize(Z8, None), TypeError, "`table`"),
    (lambda: jpeg.dequantize(None, ONES8), TypeError, "`quantized`"),
    (lambda: jpeg.dequantize(Z8, None), TypeError, "`table`"),
    (lambda: jpeg.zigzag(None), TypeError, "`block`"),
    (lambda: jpeg.unzigzag(None), TypeError, "`sequence`"),
    (lambda: jpeg.category(None), TypeError, "`value`"),
    (lambda: jpeg.run_length(None), TypeError, "`ac`"),
    (lambda: jpeg.huffman_code_block(None), TypeError, "`coefficients`"),
    (lambda: jpeg.huffman_code_block(np.zeros(64), previous_dc=None), TypeError, "previous_dc"),
    (lambda: jpeg.huffman_codes(None), TypeError, "`spec`"),
    (lambda: jpeg.encode(None), TypeError, "`image`"),
    (lambda: jpeg.coefficients(None), TypeError, "`image`"),
    (lambda: jpeg.decode(None), TypeError, "`data`"),
    (lambda: jpeg.compress(None, quality=50.0), TypeError, "`image`"),
    (lambda: jpeg.compress(np.zeros((8, 8)), quality=None), TypeError, "`quality`"),
    (lambda: jpeg.exact_tables(None), TypeError, "`quality`"),
    (lambda: jpeg.psnr(None, np.zeros(3)), TypeError, "`a`"),
    (lambda: jpeg.psnr(np.zeros(3), None), TypeError, "`b`"),
    (lambda: jpeg.psnr(np.zeros(3), np.ones(3), peak=None), TypeError, "`peak`"),
    # NaN / inf
    (lambda: jpeg.rgb_to_ycbcr(np.full((2, 3), NAN)), ValueError, "`rgb`"),
    (lambda: jpeg.ycbcr_to_rgb(np.full((2, 3), INF)), ValueError, "`ycbcr`"),
    (lambda: jpeg.subsample(np.full((4, 4), NAN)), ValueError, "`chroma`"),
    (lambda: jpeg.upsample(np.full((2, 2), INF), (4, 4)), ValueError, "`chroma`"),
    (lambda: jpeg.blocks(np.full((4, 4), NAN)), ValueError, "`plane`"),
    (lambda: jpeg.level_shift(np.array([NAN])), ValueError, "`samples`"),
    (lambda: jpeg.dct2(_with(Z8, (0, 0), NAN)), ValueError, "`block`"),
    (lambda: jpeg.idct2(_with(Z8, (1, 1), INF)), ValueError, "`coefficients`"),
    (lambda: jpeg.quant_tables_continuous(NAN), ValueError, "`quality`"),
    (lambda: jpeg.quantize(Z8, _with(ONES8, (2, 2), NAN)), ValueError, "`table`"),
    (lambda: jpeg.quantize(Z8, _with(ONES8, (2, 2), INF)), ValueError, "`table`"),
    (lambda: jpeg.dequantize(Z8, _with(ONES8, (0, 0), NAN)), ValueError, "`table`"),
    (lambda: jpeg.zigzag(_with(Z8, (0, 0), NAN)), ValueError, "`block`"),
    (lambda: jpeg.unzigzag(np.full(64, INF)), ValueError, "`sequence`"),
    (lambda: jpeg.category(NAN), ValueError, "`value`"),
    (lambda: jpeg.run_length(np.full(63, NAN)), ValueError, "`ac`"),
    (lambda: jpeg.encode(np.full((4, 4), NAN)), ValueError, "`image`"),
    (lambda: jpeg.encode(np.zeros((4, 4)), quality=NAN), TypeError, "`quality`"),
    (lambda: jpeg.compress(np.full((8, 8), NAN), quality=50.0), ValueError, "`image`"),
    # levels 0-255 instead of [0, 1]: an error, not a white picture
    (
        lambda: jpeg.compress(np.full((8, 8), 128.0), quality=50.0),
        ValueError,
        r"`image` must be in \[0, 1\]",
    ),
    (
        lambda: jpeg.compress(np.full((8, 8), 128, np.uint8), quality=50.0),
        TypeError,
        "`image` must be a floating",
    ),
    (lambda: jpeg.compress(np.zeros((8, 8)), quality=INF), ValueError, "`quality`"),
    (lambda: jpeg.exact_tables(NAN), ValueError, "`quality`"),
    (lambda: jpeg.psnr(np.array([NAN]), np.zeros(1)), ValueError, "`a`"),
    (lambda: jpeg.psnr(np.zeros(2), np.ones(2), peak=INF), ValueError, "`peak`"),
    # degenerate values
    (lambda: jpeg.quantize(Z8, np.zeros((8, 8))), ValueError, "`table`"),
    (lambda: jpeg.quantize(Z8, -ONES8), ValueError, "`table`"),
    (lambda: jpeg.psnr(np.zeros(2), np.ones(2), peak=0.0), ValueError, "`peak`"),
    (lambda: jpeg.psnr(np.zeros(2), np.ones(2), peak=-1.0), ValueError, "`peak`"),
    (lambda: jpeg.psnr(np.zeros(2), np.ones(3)), ValueError, "`b`"),
    (lambda: jpeg.psnr(np.zeros(0), np.zeros(0)), ValueError, "empty"),
    (lambda: jpeg.upsample(np.zeros((0, 3)), (4, 6)), ValueError, "`chroma`"),
    (lambda: jpeg.upsample(np.zeros((3, 0)), (6, 4)), ValueError, "`chroma`"),
    (lambda: jpeg.subsample(np.zeros((2, 0))), ValueError, "`chroma`"),
    (lambda: jpeg.unblocks(np.zeros((0, 1, 8, 8)), (1, 1)), ValueError, "`block_array`"),
    (lambda: jpeg.huffman_code_block(np.zeros(64), previous_dc=-100001), ValueError, "DC"),
    (lambda: jpeg.huffman_code_block(_with(np.zeros(64), 0, 4000)), ValueError, "DC"),
    (lambda: jpeg.huffman_code_block(_with(np.zeros(64), 5, 2000)), ValueError, "AC"),
    (lambda: jpeg.huffman_code_block(np.zeros(64), previous_dc=0.5), ValueError, "previous_dc"),
    (lambda: jpeg.huffman_code_block(_with(np.zeros(64), 3, 0.5)), ValueError, "coefficients"),
    (lambda: jpeg.category(2.5), ValueError, "`value`"),
    (lambda: jpeg.category("x"), TypeError, "`value`"),
    (lambda: jpeg.run_length(np.array(["a"] * 63)), TypeError, "`ac`"),
    (lambda: jpeg.huffman_codes(((1,) * 15, ())), ValueError, "`spec`"),
    (lambda: jpeg.huffman_codes(((3,) + (0,) * 15, (0, 1, 2))), ValueError, "oversubscribe"),
    (lambda: jpeg.quant_tables(101), ValueError, "`quality`"),
    (lambda: jpeg.upsample(np.zeros((2, 2)), (0, 4)), ValueError, "shape"),
    (lambda: jpeg.blocks(np.zeros((4, 4)), size=0), ValueError, "`size`"),
    # huge sizes and values, out-of-range qualities, inconsistent shapes
    (lambda: jpeg.blocks(np.zeros((4, 4)), size=10**12), ValueError, "`size`"),
    (lambda: jpeg.blocks(np.zeros((4, 4)), size=1025), ValueError, "`size`"),
    (lambda: jpeg.category(10**12), ValueError, "`value`"),
    (lambda: jpeg.category(-32768), ValueError, "`value`"),
    (lambda: jpeg.compress(np.zeros((8, 8)), quality=1e12), ValueError, "`quality`"),
    (lambda: jpeg.compress(np.zeros((8, 8)), quality=0.5), ValueError, "`quality`"),
    (lambda: jpeg.compress(np.zeros((0, 8)), quality=50.0), ValueError, "`image`"),
    (lambda: jpeg.exact_tables(100.5), ValueError, "`quality`"),
    (lambda: jpeg.quant_tables_continuous(1e12), ValueError, "`quality`"),
    (lambda: jpeg.quant_tables_continuous(0.0), ValueError, "`quality`"),
    (lambda: jpeg.upsample(np.zeros((4, 7)), (8, 8)), ValueError, "`chroma`"),
    (lambda: jpeg.upsample(np.zeros((4, 4)), (8, 8), subsampling="4:2:2"), ValueError, "`chroma`"),
    (lambda: jpeg.psnr(np.zeros((0, 8)), np.zeros((8, 8))), ValueError, "`a`"),
    (lambda: jax.jit(jpeg.encode)(jnp.zeros((8, 8))), TypeError, "`image`"),
    (
        lambda: jpeg.encode(np.zeros((0, 8, 8, 3), np.uint8)),
        ValueError,
        "`image` is an empty stack",
    ),
    (lambda: jpeg.encode(np.zeros((2, 8, 8, 2), np.uint8)), ValueError, "`image` must be a stack"),
    (lambda: jpeg.encode("abc"), TypeError, "`image` must be an image array.*got str"),
    (lambda: jpeg.encode(3), TypeError, "`image` must be an image array.*got int"),
    (lambda: jpeg.encode(np.zeros((1, 2, 8, 8, 3))), ValueError, "`image` must have shape.*stack"),
    (lambda: jpeg.decode(np.uint8(5)), TypeError, "`data` as an array must be 1-D uint8.*0-D"),
    (lambda: jax.vmap(jpeg.encode)(jnp.zeros((2, 8, 8))), TypeError, "jax.jit / vmap / grad"),
    (lambda: jax.jit(jpeg.coefficients)(jnp.zeros((8, 8, 3))), TypeError, "`image`"),
]


@pytest.mark.parametrize(("call", "error", "message"), CASES)
def test_bad_input_is_a_clear_error(call, error, message):
    with pytest.raises(error, match=message.replace("(", r"\(").replace("`", "`")):
        call()


# Value checks on traced arrays: the same message under `jax.jit`.
TRACED = [
    (lambda t: jpeg.quantize(Z8, t), np.zeros((8, 8)), "`table`"),
    (lambda t: jpeg.quantize(Z8, t), _with(ONES8, (1, 2), NAN), "`table`"),
    (lambda t: jpeg.dequantize(Z8, t), _with(ONES8, (1, 2), INF), "`table`"),
    (lambda p: jpeg.psnr(jnp.zeros(2), jnp.ones(2), peak=p), 0.0, "`peak`"),
    (lambda p: jpeg.psnr(jnp.zeros(2), jnp.ones(2), peak=p), NAN, "`peak`"),
    (lambda x: jpeg.dct2(x), _with(Z8, (3, 3), NAN), "`block`"),
    (lambda x: jpeg.rgb_to_ycbcr(x), np.full((2, 3), INF), "`rgb`"),
    (lambda x: jpeg.upsample(x, (4, 4)), np.full((2, 2), NAN), "`chroma`"),
    (lambda q: jpeg.quant_tables_continuous(q)[0], NAN, "`quality`"),
    (lambda q: jpeg.compress(jnp.zeros((8, 8)), quality=q), NAN, "`quality`"),
    (lambda x: jpeg.compress(x, quality=50.0), np.full((8, 8), NAN), "`image`"),
    (lambda q: jpeg.exact_tables(q)[0], INF, "`quality`"),
    (lambda q: jpeg.exact_tables(q)[0], 101.0, "`quality`"),
    (lambda q: jpeg.quant_tables_continuous(q)[0], 0.5, "`quality`"),
    (lambda q: jpeg.compress(jnp.zeros((8, 8)), quality=q), 1e12, "`quality`"),
]


@pytest.mark.parametrize(("fn", "arg", "message"), TRACED)
def test_value_checks_under_jit_name_the_argument(fn, arg, message):
    with pytest.raises(ValueError, match=message):
        fn(arg)
    with pytest.raises(Exception, match=message):  # noqa: B017 (JAX's runtime error type)
        jax.block_until_ready(jax.jit(fn)(arg))


def test_good_calls_still_work_under_jit():
    # The checks must not change results: a sample of valid calls, eager vs jit.
    table = jpeg.quant_tables(50)[0].astype(float)
    x = jnp.asarray(np.random.default_rng(0).normal(0, 50, (8, 8)))
    np.testing.assert_array_equal(jax.jit(jpeg.quantize)(x, table), jpeg.quantize(x, table))
    assert float(jax.jit(jpeg.psnr)(jnp.zeros(4), jnp.full(4, 0.1))) == pytest.approx(20.0)
    assert float(jpeg.psnr(np.zeros(4), np.full(4, 25.5), peak=255)) == pytest.approx(20.0)
    assert jpeg.psnr(np.ones(3), np.ones(3)) == np.inf
    assert jpeg.category(np.int64(-5)) == 3 and jpeg.category(4.0) == 3
    assert jpeg.category(-32767) == 15 and jpeg.category(0) == 0
    # the range ends of `quality` are valid
    assert float(jpeg.quant_tables_continuous(1.0)[0].max()) == 255.0
    assert int(jpeg.exact_tables(100.0)[0].max()) == 1
