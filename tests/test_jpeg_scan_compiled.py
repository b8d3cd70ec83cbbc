"""`jpeg.decode`'s compiled programs (the entropy-decoding loop and the reconstruction,
taken by default from 1024 blocks on) against the Python and NumPy path they replace, on
small files decoded both ways (`compiled=True` / `False`): the same pixels for every
kind of scan, equal to Pillow's, and the same outcome (image or `JPEGError`, same
message) on mutated files."""

from __future__ import annotations

import io
import warnings

import numpy as np
import pytest
from PIL import Image
from test_jpeg_fuzz import SEEDS, _mutate

from gfxlab import jpeg


def _outcome(data: bytes, compiled: bool):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            return jpeg.decode(data, compiled=compiled)
    except jpeg.JPEGError as err:
        return str(err)


def _same(a, b) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    return a.shape == b.shape and np.array_equal(a, b)


def _files() -> list[bytes]:
    rng = np.random.default_rng(5)
    img = np.clip(rng.normal(128, 70, (37, 45, 3)), 0, 255).astype(np.uint8)
    out = []
    for kw in [
        dict(quality=75, subsampling=2),
        dict(quality=95, subsampling=1, optimize=True),
        dict(quality=30, subsampling=0, restart_marker_blocks=3),
        dict(quality=100, subsampling=2, restart_marker_rows=1),
        dict(quality=60, keep_rgb=True),
    ]:
        buf = io.BytesIO()
        Image.fromarray(img).save(buf, "JPEG", **kw)
        out.append(buf.getvalue())
    buf = io.BytesIO()
    Image.fromarray(img[..., 1]).save(buf, "JPEG", quality=85, restart_marker_blocks=1)
    return [*out, buf.getvalue(), jpeg.encode(img[:9, :10], quality=1)]


@pytest.mark.parametrize("data", _files(), ids=lambda d: f"{len(d)}B")
def test_compiled_scan_decoder_equals_python_and_pillow(data):
    ours = _outcome(data, True)
    assert not isinstance(ours, str), ours
    np.testing.assert_array_equal(ours, np.asarray(Image.open(io.BytesIO(data))))
    assert _same(ours, _outcome(data, False))


def test_compiled_scan_decoder_on_mutated_files():
    # Corrupt data must end the compiled loop the way it ends the Python one.
    rng = np.random.default_rng(17)
    kinds = {"image": 0, "error": 0}
    for i in range(150):
        data = _mutate(SEEDS[i % len(SEEDS)], rng)
        compiled = _outcome(data, True)
        assert _same(compiled, _outcome(data, False)), i
        kinds["error" if isinstance(compiled, str) else "image"] += 1
    assert min(kinds.values()) > 10, kinds  # both outcomes exercised


def test_compiled_is_true_false_or_none():
    data = jpeg.encode(np.zeros((8, 8), np.uint8))
    with pytest.raises(TypeError, match="`compiled` must be True, False or None, got 'yes'"):
        jpeg.decode(data, compiled="yes")
    with pytest.raises(TypeError, match="`compiled` must be True, False or None, got 1"):
        jpeg.encode(np.zeros((8, 8), np.uint8), compiled=1)
    assert np.array_equal(jpeg.decode(data, compiled=np.bool_(True)), jpeg.decode(data))
