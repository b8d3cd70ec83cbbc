"""gfxlab.jpeg.decode against Pillow (libjpeg-turbo): every sampling, colour space and
table kind a baseline file can have, bounded memory and the decompression-bomb guard."""

from __future__ import annotations

import io
import tempfile
import tracemalloc
import warnings
from pathlib import Path

import jpeglib
import numpy as np
import pytest
from PIL import Image
from test_jpeg_fuzz import peak_bytes_of

from gfxlab import jpeg

PILLOW_SUBSAMPLING = {"4:4:4": 0, "4:2:2": 1, "4:2:0": 2}


def photo(height: int, width: int, seed: int = 0, noise: float = 12.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[:height, :width]
    img = np.stack(
        [128 + 100 * np.sin(x / 5 + y / 7), 128 + 80 * np.cos(x / 3) * (x > width / 3), y / 2.0],
        -1,
    )
    return np.clip(img + rng.normal(0, noise, img.shape), 0, 255).astype(np.uint8)


def pillow_save(img, **kw) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, "JPEG", **kw)
    return buf.getvalue()


def pillow_decode(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)))


def sof_factors(data: bytes) -> list[tuple[int, int]]:
    i = max(data.find(b"\xff\xc0"), data.find(b"\xff\xc1"))
    n = data[i + 9]
    return [(data[i + 11 + 3 * c] >> 4, data[i + 11 + 3 * c] & 15) for c in range(n)]


def assert_decodes_like_pillow(data: bytes) -> np.ndarray:
    ours, ref = jpeg.decode(data), pillow_decode(data)
    assert ours.dtype == np.uint8 and ours.shape == ref.shape
    np.testing.assert_array_equal(ours, ref)
    return ours


def jpeglib_file(img, factors, quality=80) -> bytes:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "x.jpg"
        spatial = jpeglib.from_spatial(img)
        spatial.samp_factor = np.array(factors)
        spatial.write_spatial(str(path), qt=quality)
        return path.read_bytes()


@pytest.mark.parametrize("subsampling", list(PILLOW_SUBSAMPLING))
@pytest.mark.parametrize("shape", [(13, 29), (64, 48), (300, 260)])  # last: compiled path
def test_pillow_files_of_every_subsampling(subsampling, shape):
    img = photo(*shape, seed=shape[0])
    for quality in (10, 75, 97):
        data = pillow_save(img, quality=quality, subsampling=PILLOW_SUBSAMPLING[subsampling])
        assert_decodes_like_pillow(data)


@pytest.mark.parametrize(("h", "v", "name"), [(1, 2, "4:4:0"), (4, 1, "4:1:1")])
@pytest.mark.parametrize("shape", [(37, 45), (16, 32), (260, 270)])
def test_libjpeg_files_440_and_411(h, v, name, shape):
    # jpeglib takes sampling factors as (vertical, horizontal).
    data = jpeglib_file(photo(*shape, seed=5), [[v, h], [1, 1], [1, 1]])
    assert sof_factors(data) == [(h, v), (1, 1), (1, 1)], name
    assert_decodes_like_pillow(data)


def test_grey_optimized_and_restart_markers():
    img = photo(70, 90, seed=2)
    assert_decodes_like_pillow(pillow_save(img[..., 0], quality=85))
    optimized = pillow_save(img, quality=60, optimize=True)
    assert optimized != pillow_save(img, quality=60)  # its own Huffman tables
    assert_decodes_like_pillow(optimized)
    for kw in ({"restart_marker_blocks": 1}, {"restart_marker_rows": 2}):
        data = pillow_save(img, quality=80, **kw)
        assert b"\xff\xdd" in data and b"\xff\xd0" in data
        assert_decodes_like_pillow(data)
    big = photo(280, 300, seed=3)  # compiled reconstruction, optimized + restarts
    assert_decodes_like_pillow(pillow_save(big, quality=90, optimize=True, restart_marker_rows=1))


def test_sixteen_bit_quantization_tables():
    img = photo(40, 56, seed=4)
    tables = [list(range(200, 264)) * 1, [300 + 7 * i for i in range(64)]]
    data = pillow_save(img, qtables=tables, subsampling=0)
    i = data.index(b"\xff\xdb")
    assert data[i + 4] >> 4 == 1  # precision 1: 16-bit entries
    assert b"\xff\xc1" in data  # extended sequential frame
    assert_decodes_like_pillow(data)


def _drop_segment(data: bytes, marker: bytes) -> bytes:
    i = data.index(marker)
    return data[:i] + data[i + 2 + int.from_bytes(data[i + 2 : i + 4]) :]


def test_rgb_coded_files_are_not_colour_converted():
    img = photo(33, 47, seed=6)
    data = pillow_save(img, quality=95, keep_rgb=True, subsampling=0)
    assert b"Adobe" in data and b"JFIF" not in data
    ours = assert_decodes_like_pillow(data)
    assert np.abs(ours.astype(int) - img).max() < 40  # RGB kept, not YCbCr-converted
    # Component ids 'R', 'G', 'B' alone (no Adobe marker) also mean RGB to libjpeg.
    ids_only = _drop_segment(data, b"\xff\xee")
    assert b"RGB" not in ids_only[:2] and bytes([0x52, 0x11, 0x00]) in ids_only  # 'R' id
    np.testing.assert_array_equal(jpeg.decode(ids_only), ours)
    # An Adobe marker saying transform 1 means YCbCr, whatever the ids.
    i = data.index(b"Adobe")
    transform1 = data[: i + 11] + b"\x01" + data[i + 12 :]
    assert_decodes_like_pillow(transform1)
    assert np.abs(jpeg.decode(transform1).astype(int) - ours).max() > 100


def test_cmyk_is_a_clear_error():
    cmyk = np.random.default_rng(0).integers(0, 256, (16, 16, 4), dtype=np.uint8)
    buf = io.BytesIO()
    Image.fromarray(cmyk, "CMYK").save(buf, "JPEG")
    with pytest.raises(jpeg.JPEGError, match="CMYK"):
        jpeg.decode(buf.getvalue())


def test_missing_eoi_after_a_complete_scan_decodes_with_a_warning():
    data = pillow_save(photo(20, 30), quality=70)
    assert data.endswith(b"\xff\xd9")
    with pytest.warns(UserWarning, match="EOI"):
        out = jpeg.decode(data[:-2])
    np.testing.assert_array_equal(out, pillow_decode(data))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        jpeg.decode(data)  # a complete file: no warning
    with pytest.raises(jpeg.JPEGError, match="truncated"):
        jpeg.decode(data[: len(data) // 2])


def _declare_size(data: bytes, height: int, width: int) -> bytes:
    i = data.index(b"\xff\xc0") + 5
    return data[:i] + height.to_bytes(2, "big") + width.to_bytes(2, "big") + data[i + 4 :]


def test_pixel_limit_refuses_before_allocating():
    data = pillow_save(photo(16, 16), quality=50)
    bomb = _declare_size(data, 65535, 65535)  # 4.3 G pixels declared in a tiny file
    tracemalloc.start()
    with pytest.raises(jpeg.JPEGError, match="max_pixels"):
        jpeg.decode(bomb)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 2e6
    assert jpeg.MAX_PIXELS == Image.MAX_IMAGE_PIXELS
    with pytest.raises(jpeg.JPEGError, match="max_pixels"):
        jpeg.decode(data, max_pixels=255)
    assert jpeg.decode(data, max_pixels=256).shape == (16, 16, 3)
    assert jpeg.decode(data, max_pixels=None).shape == (16, 16, 3)
    # Under the limit but far more blocks than the scan can hold: refused before allocating.
    with pytest.raises(jpeg.JPEGError, match="cannot fit"):
        jpeg.decode(_declare_size(data, 8000, 8000))
    # ... and with no pixel limit at all, a bomb is refused from the frame and scan sizes
    tracemalloc.start()
    with pytest.raises(jpeg.JPEGError, match="cannot fit"):
        jpeg.decode(bomb, max_pixels=None)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 2e6
    with pytest.raises(TypeError, match="max_pixels"):
        jpeg.decode(data, max_pixels=1.5)
    with pytest.raises(ValueError, match="max_pixels"):
        jpeg.decode(data, max_pixels=0)
    with pytest.raises(TypeError, match="data"):
        jpeg.decode(None)


def test_peak_memory_is_proportional_to_the_image():
    img = photo(512, 512, seed=9, noise=60.0)
    data = pillow_save(img, quality=95, subsampling=0)
    assert len(data) > 500_000  # the old decoder peaked at ~2 KB per byte of such a scan
    jpeg.decode(data)  # compile the reconstruction first
    peak, out = peak_bytes_of(lambda: jpeg.decode(data))
    assert peak - len(data) - out.nbytes <= 20e6, peak
    np.testing.assert_array_equal(out, pillow_decode(data))
