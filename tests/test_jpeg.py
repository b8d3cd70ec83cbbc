"""gfxlab.jpeg: stages, exactness against libjpeg (Pillow, jpeglib), compress."""

from __future__ import annotations

import io
import tempfile
from pathlib import Path

import jax
import jax.numpy as jnp
import jpeglib
import numpy as np
import pytest
import scipy.fft
from hypothesis import example, given
from hypothesis import strategies as st
from jax.test_util import check_grads
from PIL import Image

from gfxlab import jpeg

# The seed's Q5f block after the level shift (as printed in the exam answer).
SEED_SHIFTED = np.array(
    [
        [-76, -73, -67, -62, -58, -67, -64, -55],
        [-65, -69, -73, -38, -19, -43, -59, -56],
        [-66, -69, -60, -15, 16, -24, -62, -55],
        [-65, -70, -57, -6, 26, -22, -58, -59],
        [-61, -67, -60, -24, -2, -40, -60, -58],
        [-49, -63, -68, -58, -51, -60, -70, -53],
        [-43, -57, -64, -69, -73, -67, -63, -45],
        [-41, -49, -59, -60, -63, -52, -50, -34],
    ]
)
# ITU-T T.81 Figure A.6: zig-zag sequence of the natural (row-major) indices.
T81_ZIGZAG = [
    0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4, 5, 12, 19, 26, 33, 40, 48,
    41, 34, 27, 20, 13, 6, 7, 14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23,
    30, 37, 44, 51, 58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63,
]  # fmt: skip
SUBSAMPLINGS = {"4:4:4": 0, "4:2:2": 1, "4:2:0": 2}


def photo(height: int, width: int, seed: int = 0, grey: bool = False) -> np.ndarray:
    """A smooth, textured test image (edges, gradients, noise)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[:height, :width]
    img = np.stack(
        [
            128 + 100 * np.sin(x / 5 + y / 7),
            128 + 80 * np.cos(x / 3) * (x > width / 3),
            y * 255 / max(height - 1, 1),
        ],
        -1,
    )
    img = np.clip(img + rng.normal(0, 12, img.shape), 0, 255).astype(np.uint8)
    return img[..., 0] if grey else img


def pillow_bytes(img, quality, subsampling="4:2:0", **kw) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(img).save(
        buf, "JPEG", quality=quality, subsampling=SUBSAMPLINGS[subsampling], **kw
    )
    return buf.getvalue()


def pillow_decode(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)))


# --- the seed's worked example ------------------------------------------------------


def test_seed_q5f_block():
    block = SEED_SHIFTED + 128
    # Independent reference: SciPy's orthonormal DCT-II and the Annex K table.
    reference = scipy.fft.dctn(SEED_SHIFTED.astype(float), norm="ortho")
    coefs = jpeg.dct2(jpeg.level_shift(block))
    np.testing.assert_allclose(coefs, reference, atol=1e-4)
    np.testing.assert_allclose(coefs[0, 0], SEED_SHIFTED.sum() / 8, atol=1e-4)
    expected = np.sign(reference / jpeg.LUMINANCE_TABLE) * np.floor(
        np.abs(reference / jpeg.LUMINANCE_TABLE) + 0.5
    )
    quantized = jpeg.quantize(coefs, jpeg.quant_tables(50)[0])
    np.testing.assert_array_equal(quantized, expected)
    zz = np.asarray(jpeg.zigzag(quantized)).astype(int)
    np.testing.assert_array_equal(zz, expected.reshape(-1)[T81_ZIGZAG])
    # The seed's (and the classic) sequence: -26, -3, 0, -3, -2, -6, 2, -4, 1, -3, ...
    assert zz[:10].tolist() == [-26, -3, 0, -3, -2, -6, 2, -4, 1, -3]
    rle = jpeg.run_length(zz[1:])
    assert rle[-1] == (0, 0)  # EOB
    assert sum(run + 1 for run, _ in rle[:-1]) == np.flatnonzero(zz).max()


def test_seed_table_rows_are_annex_k():
    # The seed prints the first six rows of the luminance table.
    seed_rows = [
        [16, 11, 10, 16, 24, 40, 51, 61],
        [12, 12, 14, 19, 26, 58, 60, 55],
        [14, 13, 16, 24, 40, 57, 69, 56],
        [14, 17, 22, 29, 51, 87, 80, 62],
        [18, 22, 37, 56, 68, 109, 103, 77],
        [24, 35, 55, 64, 81, 104, 113, 92],
    ]
    np.testing.assert_array_equal(jpeg.LUMINANCE_TABLE[:6], seed_rows)
    np.testing.assert_array_equal(jpeg.quant_tables(50)[0], jpeg.LUMINANCE_TABLE)
    np.testing.assert_array_equal(jpeg.quant_tables(50)[1], jpeg.CHROMINANCE_TABLE)


# --- stages -------------------------------------------------------------------------


def test_zigzag_order_is_t81():
    assert jpeg.ZIGZAG.tolist() == T81_ZIGZAG
    x = np.arange(64).reshape(8, 8)
    np.testing.assert_array_equal(jpeg.zigzag(x), T81_ZIGZAG)
    np.testing.assert_array_equal(jpeg.unzigzag(jpeg.zigzag(x)), x)


def test_dct2_matches_scipy(maybe_jit):
    x = np.random.default_rng(0).normal(size=(3, 2, 8, 8))
    out = maybe_jit(jpeg.dct2)(x)
    np.testing.assert_allclose(out, scipy.fft.dctn(x, axes=(-2, -1), norm="ortho"), atol=1e-10)
    np.testing.assert_allclose(maybe_jit(jpeg.idct2)(out), x, atol=1e-10)


def test_colour_matches_pillow_and_inverts(maybe_jit):
    rgb = np.random.default_rng(1).integers(0, 256, (16, 16, 3), dtype=np.uint8)
    ycc = np.asarray(maybe_jit(jpeg.rgb_to_ycbcr)(rgb / 255.0)) * 255
    ref = np.asarray(Image.fromarray(rgb).convert("YCbCr"), float)  # libjpeg's integer table
    assert np.abs(ycc - ref).max() <= 1.0
    back = maybe_jit(jpeg.ycbcr_to_rgb)(ycc / 255)
    np.testing.assert_allclose(back, rgb / 255.0, atol=1e-10)


@pytest.mark.parametrize("subsampling", ["4:4:4", "4:2:2", "4:2:0"])
def test_subsample_upsample(subsampling, maybe_jit):
    x = np.random.default_rng(2).random((2, 7, 9))
    small = maybe_jit(jpeg.subsample, static_argnames="subsampling")(x, subsampling=subsampling)
    h, v = jpeg.SUBSAMPLING[subsampling]
    assert small.shape == (2, -(-7 // v), -(-9 // h))
    padded = np.pad(x, [(0, 0), (0, (-7) % v), (0, (-9) % h)], mode="edge")
    ref = padded.reshape(2, padded.shape[1] // v, v, padded.shape[2] // h, h).mean(axis=(2, 4))
    np.testing.assert_allclose(small, ref, atol=1e-12)
    up = jpeg.upsample(small, (7, 9), subsampling=subsampling)
    assert up.shape == x.shape
    const = jpeg.upsample(jnp.full((8 // v, 10 // h), 0.3), (8, 10), subsampling=subsampling)
    np.testing.assert_allclose(const, 0.3, atol=1e-12)
    with pytest.raises(ValueError, match="`chroma` must have shape"):  # not what subsample gives
        jpeg.upsample(jnp.full((8 // v + 1, 10 // h), 0.3), (8, 10), subsampling=subsampling)


def test_blocks_roundtrip_with_edge_padding(maybe_jit):
    x = np.random.default_rng(3).random((13, 18))
    b = maybe_jit(jpeg.blocks)(x)
    assert b.shape == (2, 3, 8, 8)
    np.testing.assert_array_equal(b[1, 2, -1, -1], x[-1, -1])  # replicated corner
    np.testing.assert_array_equal(jpeg.unblocks(b, x.shape), x)


def test_quantize_roundings():
    # (8, 8) float64 arrays made in NumPy: the eager stages compile once for all of them
    table = jnp.asarray(np.full((8, 8), 4.0))
    grid = np.linspace(-10, 10, 64).reshape(8, 8)
    x = jnp.asarray(grid)
    near = jpeg.quantize(x, table)
    np.testing.assert_array_equal(jpeg.quantize(jnp.asarray(np.full((8, 8), 2.0)), table), 1.0)
    np.testing.assert_array_equal(jpeg.quantize(jnp.asarray(np.full((8, 8), -2.0)), table), -1.0)
    np.testing.assert_array_equal(jpeg.quantize(x, table, rounding="ste"), near)
    g = jax.grad(lambda x: jpeg.quantize(x, table, rounding="ste").sum())(x)
    np.testing.assert_allclose(g, 0.25)
    cubic = jax.jit(lambda x: jpeg.quantize(x, table, rounding="cubic"))
    check_grads(cubic, (jnp.asarray(grid + 0.3),), order=1)
    np.testing.assert_allclose(jpeg.dequantize(near, table), np.asarray(near) * 4)


def test_quant_tables_continuous():
    exact = np.stack([np.stack(jpeg.quant_tables(q)) for q in range(1, 101)])
    smooth = jax.jit(jax.vmap(lambda q: jnp.stack(jpeg.quant_tables_continuous(q))))(
        jnp.asarray(np.arange(1.0, 101.0))
    )
    assert np.abs(exact - np.asarray(smooth)).max() <= 0.5 + 1e-9
    qs = jnp.array([1.0, 1.5, 10.0, 49.999, 50.0, 50.001, 99.9, 100.0])
    grads = jax.jit(
        jax.vmap(jax.grad(lambda q: sum(t.sum() for t in jpeg.quant_tables_continuous(q))))
    )(qs)
    assert np.all(np.isfinite(np.asarray(grads)))
    check_grads(jax.jit(lambda q: jpeg.quant_tables_continuous(q)[0]), (30.3,), order=1, eps=1e-3)


def test_float_stages_gradients():
    x = np.random.default_rng(4).random((8, 8, 3))  # sliced in NumPy, then put on device
    check_grads(jax.jit(jpeg.rgb_to_ycbcr), (jnp.asarray(x[:3, :3]),), order=1, modes="rev")
    check_grads(jax.jit(jpeg.ycbcr_to_rgb), (jnp.asarray(x[:3, :3]),), order=1, modes="rev")
    check_grads(
        jax.jit(lambda p: jpeg.subsample(p, subsampling="4:2:0")),
        (jnp.asarray(x[:5, :5, 0]),),
        order=1,
        modes="rev",
    )
    upsample = jax.jit(lambda p: jpeg.upsample(p, (6, 7)))
    check_grads(upsample, (jnp.asarray(x[:3, :4, 0]),), order=1, modes="rev")
    check_grads(jax.jit(jpeg.dct2), (jnp.asarray(x[..., 0]),), order=1, modes="rev")


def test_run_length_zrl_and_eob():
    ac = np.zeros(63, int)
    ac[[0, 20, 40]] = [5, -1, 2]
    assert jpeg.run_length(ac) == [(0, 5), (15, 0), (3, -1), (15, 0), (3, 2), (0, 0)]
    ac[:] = 0
    ac[-1] = 7
    assert jpeg.run_length(ac) == [(15, 0), (15, 0), (15, 0), (14, 7)]  # no EOB
    assert jpeg.run_length(np.zeros(63)) == [(0, 0)]


def test_huffman_block_matches_pillow_scan():
    block = (SEED_SHIFTED + 128).astype(np.uint8)
    data = pillow_bytes(block, 50)
    start = data.index(b"\xff\xda") + 2 + int.from_bytes(data[data.index(b"\xff\xda") + 2 :][:2])
    scan = data[start:-2].replace(b"\xff\x00", b"\xff")
    zz = jpeg.zigzag(jpeglib_coefs(data)[0][0][0, 0])
    bits = "".join(h + e for _, h, e in jpeg.huffman_code_block(np.asarray(zz)))
    bits += "1" * ((-len(bits)) % 8)
    assert bytes(int(bits[i : i + 8], 2) for i in range(0, len(bits), 8)) == scan


def jpeglib_coefs(data: bytes):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "x.jpg"
        path.write_bytes(data)
        dct = jpeglib.read_dct(str(path))
        planes = [dct.Y] + ([dct.Cb, dct.Cr] if dct.has_chrominance else [])
        return [np.asarray(p) for p in planes], np.asarray(dct.qt)


# --- exactness against libjpeg ------------------------------------------------------


def test_quant_tables_equal_libjpeg_for_every_quality():
    img = photo(8, 8)
    with tempfile.TemporaryDirectory() as tmp:
        for q in range(1, 101):
            path = Path(tmp) / f"{q}.jpg"
            Image.fromarray(img).save(path, quality=q)
            qt = jpeglib.read_dct(str(path)).qt
            luma, chroma = jpeg.quant_tables(q)
            np.testing.assert_array_equal(qt[0], luma, err_msg=f"quality {q}")
            np.testing.assert_array_equal(qt[1], chroma, err_msg=f"quality {q}")


@pytest.mark.parametrize("quality", [1, 10, 50, 75, 90, 95, 100])
@pytest.mark.parametrize("shape", [(17, 23), (40, 64)])
def test_coefficients_equal_libjpeg(quality, shape):
    img = photo(*shape, seed=quality)
    for subsampling in ("4:4:4", "4:2:0", "4:2:2"):
        ref, _ = jpeglib_coefs(pillow_bytes(img, quality, subsampling))
        ours = jpeg.coefficients(img, quality=quality, subsampling=subsampling)
        for a, b in zip(ours, ref, strict=True):
            np.testing.assert_array_equal(a, b)
    ref, _ = jpeglib_coefs(pillow_bytes(img[..., 1], quality))
    np.testing.assert_array_equal(jpeg.coefficients(img[..., 1], quality=quality)[0], ref[0])


# `encode` runs NumPy below 65,536 pixels and compiled XLA programs from there on (as its
# docstring says); `compiled=` takes either path at any size, with the same bytes.
COMPILED_FROM_PIXELS = 65_536


@pytest.mark.parametrize("compiled", [False, True], ids=["numpy", "xla"])
@pytest.mark.parametrize("quality", [1, 10, 50, 75, 90, 95, 100])
def test_encode_is_byte_identical_to_pillow(quality, compiled):
    # Small images: the NumPy path by default; each path in turn. Compiled, (33, 70) is
    # coded in bands: 4:2:0 in three of one MCU row (the last one pixel row), 4:4:4 in
    # bands of 2, 2 and 1 MCU rows; (1, 1) and (9, 17) in one.
    for shape in [(1, 1), (9, 17), (33, 70)]:
        img = photo(*shape, seed=quality + shape[0])
        for subsampling in SUBSAMPLINGS:
            ours = jpeg.encode(img, quality=quality, subsampling=subsampling, compiled=compiled)
            assert ours == pillow_bytes(img, quality, subsampling), (shape, subsampling)
        grey = jpeg.encode(img[..., 2], quality=quality, compiled=compiled)
        assert grey == pillow_bytes(img[..., 2], quality)


def test_encode_large_images_byte_identical_to_pillow():
    # Above the size where `encode` switches to the compiled programs; odd sizes
    # exercise the edge replication and libjpeg's dummy blocks. The compiled encoder
    # codes horizontal bands separately and carries the DC prediction across them: here
    # 4 bands (17 MCU rows of 4:2:0 in 5, 5, 5, 2; 33 of 4:4:4 in 9, 9, 9, 6), and the
    # file is libjpeg's, coded in one pass.
    assert 261 * 259 >= COMPILED_FROM_PIXELS
    img = photo(261, 259, seed=3)
    for quality, subsampling in [(1, "4:2:0"), (75, "4:2:0"), (95, "4:2:2"), (100, "4:4:4")]:
        ours = jpeg.encode(img, quality=quality, subsampling=subsampling)
        assert ours == pillow_bytes(img, quality, subsampling), (quality, subsampling)
    assert b"\xff\x00" in ours  # byte stuffing exercised
    assert jpeg.encode(img, quality=100, subsampling="4:4:4", compiled=False) == ours
    assert jpeg.encode(img[..., 0], quality=60) == pillow_bytes(img[..., 0], 60)


def test_batched_encode_is_byte_identical_to_pillow_per_image():
    # A stack of images gives one file per image, each Pillow's (the compiled path at
    # the size of the test above, so its programs are reused, and the NumPy path).
    stack = np.stack([photo(261, 259, seed=s) for s in (3, 4, 5)])
    files = jpeg.encode(stack, quality=75)
    assert isinstance(files, list) and len(files) == 3
    for img, data in zip(stack, files, strict=True):
        assert data == pillow_bytes(img, 75)
    grey = np.stack([photo(20, 30, seed=s, grey=True) for s in (1, 2)])[..., None]
    for img, data in zip(grey, jpeg.encode(grey, quality=40, subsampling="4:4:4"), strict=True):
        assert data == pillow_bytes(img[..., 0], 40, "4:4:4")
    small = stack[:2, :17, :9] / 255.0  # float input, rounded to uint8 as for one image
    assert jpeg.encode(small, quality=90) == [jpeg.encode(x, quality=90) for x in small]
    with pytest.raises(ValueError, match="`image`"):
        jpeg.encode(np.zeros((2, 8, 8, 2), np.uint8))
    with pytest.raises(ValueError, match="`image`"):
        jpeg.encode(np.zeros((0, 8, 8, 3), np.uint8))


def _basis(u: int, v: int, amplitude: float) -> np.ndarray:
    """An 8 x 8 block of one DCT basis pattern around mid-grey: one nonzero AC value."""
    k = (2 * np.arange(8) + 1) * np.pi / 16
    return 128 + amplitude * np.outer(np.cos(v * k), np.cos(u * k))


_CHECKER = np.where(np.add.outer(np.arange(8), np.arange(8)) % 2 == 0, 0.0, 255.0)
# Blocks the coder must get right: DC only at the ends of its range (0 and 255 at
# quality 100: DC -1024 and 1016, differences of 2040), a lone coefficient after long
# zero runs (ZRLs), one in the last zig-zag slot (no EOB), the largest AC values.
_EDGE_BLOCKS = [
    np.zeros((8, 8)),
    np.full((8, 8), 255.0),
    _basis(7, 7, 127),
    _basis(3, 6, -90),
    _CHECKER,
    np.full((8, 8), 255.0),
    _basis(0, 7, 120),
    np.zeros((8, 8)),
]
# The images are 33 x 70, the size `test_encode_is_byte_identical_to_pillow` compiles
# (5 x 9 blocks, the last row and column partial: edge replication too).
_ROWS, _COLS = 5, 9


def _image_of_blocks(blocks) -> np.ndarray:
    """`_ROWS * _COLS` blocks per channel, `(channels, rows * cols, 8, 8)` -> uint8
    `(33, 70, channels)`."""
    channels = len(blocks)
    planes = np.asarray(blocks).reshape(channels, _ROWS, _COLS, 8, 8)
    image = planes.transpose(1, 3, 2, 4, 0).reshape(8 * _ROWS, 8 * _COLS, channels)
    return np.clip(np.round(image[:33, :70]), 0, 255).astype(np.uint8)


@st.composite
def _block_images(draw):
    """An image whose blocks (per channel) are drawn from flat blocks, single DCT basis
    patterns of any frequency and amplitude, checkerboards and noise."""
    channels = draw(st.sampled_from([1, 3]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    blocks = []
    for _ in range(_ROWS * _COLS * channels):
        kind = draw(st.sampled_from(["flat", "basis", "checker", "noise"]))
        if kind == "flat":
            block = np.full((8, 8), float(draw(st.sampled_from([0, 255]) | st.integers(0, 255))))
        elif kind == "basis":
            u, v = draw(st.integers(0, 7)), draw(st.integers(0, 7))
            block = _basis(u, v, draw(st.floats(-127, 127)))
        elif kind == "checker":
            block = _CHECKER
        else:
            block = rng.integers(0, 256, (8, 8)).astype(float)
        blocks.append(block)
    image = _image_of_blocks(np.reshape(blocks, (channels, -1, 8, 8)))
    quality = draw(st.sampled_from([1, 100]) | st.integers(1, 100))
    subsampling = draw(st.sampled_from(list(SUBSAMPLINGS)))
    return (image[..., 0] if channels == 1 else image), quality, subsampling


_EDGES = [_EDGE_BLOCKS[k % 8] for k in range(_ROWS * _COLS)]
_EDGE_GREY = _image_of_blocks([_EDGES])[..., 0]
_EDGE_RGB = _image_of_blocks([_EDGES, _EDGES[::-1], _EDGES[3:] + _EDGES[:3]])


@given(_block_images())
@example((_EDGE_GREY, 100, "4:4:4"))
@example((_EDGE_GREY, 50, "4:4:4"))
@example((_EDGE_RGB, 100, "4:4:4"))
def test_huffman_coding_of_any_blocks_is_libjpegs(case):
    # Each block's DC difference (from the last block of its own component), ZRLs, run /
    # size codes, EOB, and the bit packing with 0xFF stuffing, in both code paths (the
    # compiled one codes the DCT's transposed layout, then reorders): libjpeg's bytes.
    image, quality, subsampling = case
    expected = pillow_bytes(image, quality, subsampling)
    for compiled in (False, True):
        ours = jpeg.encode(image, quality=quality, subsampling=subsampling, compiled=compiled)
        assert ours == expected, compiled


def test_pillow_decodes_our_files_and_we_decode_them_exactly():
    rng = np.random.default_rng(5)
    for _ in range(6):
        h, w = rng.integers(1, 50, 2)
        img = rng.random((h, w, 3))  # float input in [0, 1]
        data = jpeg.encode(img, quality=int(rng.integers(1, 101)), subsampling="4:2:0")
        decoded = pillow_decode(data)
        assert decoded.shape == (h, w, 3)
        np.testing.assert_array_equal(jpeg.decode(data), decoded)


@pytest.mark.parametrize("subsampling", list(SUBSAMPLINGS))
def test_decode_pillow_files(subsampling):
    for quality in (5, 50, 95):
        for shape in [(16, 16), (21, 35), (64, 48)]:
            img = photo(*shape, seed=quality)
            data = pillow_bytes(img, quality, subsampling)
            ours, ref = jpeg.decode(data), pillow_decode(data)
            assert ours.dtype == np.uint8 and ours.shape == ref.shape
            close = np.abs(ours.astype(int) - ref) <= 1
            assert close.mean() >= 0.99
            np.testing.assert_array_equal(ours, ref)  # in fact bit-exact
    grey = pillow_bytes(photo(19, 30, grey=True), 80)
    np.testing.assert_array_equal(jpeg.decode(grey), pillow_decode(grey))


def test_decode_restart_intervals():
    img = photo(40, 56)
    for kw in ({"restart_marker_blocks": 3}, {"restart_marker_rows": 1}):
        data = pillow_bytes(img, 80, **kw)
        assert b"\xff\xdd" in data
        np.testing.assert_array_equal(jpeg.decode(data), pillow_decode(data))


def test_decode_512_is_fast():
    import time

    data = pillow_bytes(photo(512, 512), 75)
    start = time.perf_counter()
    jpeg.decode(data)  # the first call of a size compiles the reconstruction
    assert time.perf_counter() - start < 20.0
    other = pillow_bytes(photo(512, 512, seed=1), 60)
    start = time.perf_counter()
    jpeg.decode(other)  # same geometry: compiled program reused
    assert time.perf_counter() - start < 1.5


# --- compress -----------------------------------------------------------------------


_compress_jit = jax.jit(jpeg.compress, static_argnames=("subsampling", "rounding"))


@pytest.mark.parametrize("subsampling", list(SUBSAMPLINGS))
def test_compress_forward_equals_pillow_round_trip(subsampling):
    img = photo(21, 30, seed=7)
    for quality in (3, 60, 97):
        out = _compress_jit(img / 255.0, quality=float(quality), subsampling=subsampling)
        ref = pillow_decode(pillow_bytes(img, quality, subsampling))
        np.testing.assert_allclose(np.asarray(out) * 255, ref, atol=1e-9)


def test_compress_grey_and_channel_axis():
    img = photo(9, 11, seed=3, grey=True)
    ref = pillow_decode(pillow_bytes(img, 40))
    out = _compress_jit(img / 255.0, quality=40.0)
    np.testing.assert_allclose(np.asarray(out) * 255, ref, atol=1e-9)
    out = _compress_jit(img[..., None] / 255.0, quality=40.0)
    np.testing.assert_allclose(np.asarray(out[..., 0]) * 255, ref, atol=1e-9)


@pytest.mark.parametrize("rounding", ["deadzone", "ste", "cubic"])
def test_compress_gradients_finite_over_quality(rounding):
    img = jnp.asarray(photo(8, 16, seed=8) / 255.0)
    loss = jax.jit(
        jax.grad(lambda x, q: jnp.sum(jpeg.compress(x, quality=q, rounding=rounding) ** 2), (0, 1))
    )
    for q in [1.0, 1.7, 12.5, 49.99, 50.0, 50.01, 75.0, 99.5, 100.0]:
        gx, gq = loss(img, q)
        assert np.all(np.isfinite(gx)) and np.isfinite(gq), q
    assert float(loss(img, 30.0)[1]) != 0.0


def test_compress_ste_gradient_is_identity_at_full_quality():
    # 4:4:4 with straight-through rounding: the twin pipeline is linear and invertible.
    img = jnp.asarray(photo(10, 12, seed=9) / 255.0)
    g = jax.jit(jax.grad(lambda x: jnp.sum(jpeg.compress(x, quality=100.0, subsampling="4:4:4"))))(
        img
    )
    np.testing.assert_allclose(g, 1.0, atol=1e-9)


# --- bad input ----------------------------------------------------------------------


def test_bad_inputs():
    with pytest.raises(ValueError, match="block"):
        jpeg.dct2(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="coefficients"):
        jpeg.idct2(np.zeros(8))
    with pytest.raises(ValueError, match="rgb"):
        jpeg.rgb_to_ycbcr(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="ycbcr"):
        jpeg.ycbcr_to_rgb(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="subsampling"):
        jpeg.subsample(np.zeros((4, 4)), subsampling="4:1:1")
    with pytest.raises(ValueError, match="method"):
        jpeg.upsample(np.zeros((4, 4)), (8, 8), method="cubic")
    with pytest.raises(ValueError, match="plane"):
        jpeg.blocks(np.zeros(5))
    with pytest.raises(ValueError, match="shape"):
        jpeg.unblocks(np.zeros((1, 1, 8, 8)), (9, 8))
    with pytest.raises(ValueError, match="quality"):
        jpeg.quant_tables(0)
    with pytest.raises(ValueError, match="quality"):
        jpeg.quant_tables(101)
    with pytest.raises(ValueError, match="quality"):
        jpeg.quant_tables_continuous(jnp.ones(2))
    with pytest.raises(ValueError, match="rounding"):
        jpeg.quantize(np.zeros((8, 8)), np.ones((8, 8)), rounding="floor")
    with pytest.raises(ValueError, match="table"):
        jpeg.dequantize(np.zeros((8, 8)), np.ones(8))
    with pytest.raises(ValueError, match="block"):
        jpeg.zigzag(np.zeros((8, 7)))
    with pytest.raises(ValueError, match="sequence"):
        jpeg.unzigzag(np.zeros(63))
    with pytest.raises(ValueError, match="ac"):
        jpeg.run_length(np.zeros(64))
    with pytest.raises(ValueError, match="coefficients"):
        jpeg.huffman_code_block(np.zeros(63))
    with pytest.raises(ValueError, match="image"):
        jpeg.encode(np.zeros((4, 4, 2), np.uint8))
    with pytest.raises(ValueError, match="quality"):
        jpeg.encode(np.zeros((4, 4), np.uint8), quality=0)
    with pytest.raises(TypeError, match="quality"):
        jpeg.encode(np.zeros((4, 4), np.uint8), quality=7.5)
    with pytest.raises(ValueError, match="subsampling"):
        jpeg.encode(np.zeros((4, 4, 3), np.uint8), subsampling="4:1:1")
    with pytest.raises(ValueError, match="image"):
        jpeg.encode(np.full((4, 4), 300))
    with pytest.raises(ValueError, match="image"):
        jpeg.coefficients(np.zeros((0, 4), np.uint8))
    with pytest.raises(TypeError, match="data"):
        jpeg.decode("not bytes")
    with pytest.raises(ValueError, match="image"):
        jpeg.compress(np.zeros((4, 4, 2)), quality=50.0)
    with pytest.raises(ValueError, match="rounding"):
        jpeg.compress(np.zeros((4, 4, 3)), quality=50.0, rounding="soft")
    with pytest.raises(ValueError, match="subsampling"):
        jpeg.compress(np.zeros((4, 4, 3)), quality=50.0, subsampling="4:1:1")
    with pytest.raises(ValueError, match="quality"):
        jpeg.compress(np.zeros((4, 4, 3)), quality=jnp.ones(3))
