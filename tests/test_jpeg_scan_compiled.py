"""The compiled entropy decoder (`_entropy_xla`, used from `COMPILE_FROM_BLOCKS` blocks
on) against the Python loop it replaces, on small files forced through it: the same
coefficients for every kind of scan, the same outcome (image or `JPEGError`, same
message) on mutated files, and pixels equal to Pillow's."""

from __future__ import annotations

import io
import warnings

import numpy as np
import pytest
from PIL import Image
from test_jpeg_fuzz import SEEDS, _mutate

from gfxlab import jpeg
from gfxlab.jpeg import _entropy


def _outcome(data: bytes, compiled: bool, monkeypatch):
    monkeypatch.setattr(_entropy, "COMPILE_FROM_BLOCKS", 0 if compiled else 1 << 62)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            return jpeg.decode(data)
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
def test_compiled_scan_decoder_equals_python_and_pillow(data, monkeypatch):
    ours = _outcome(data, True, monkeypatch)
    assert not isinstance(ours, str), ours
    np.testing.assert_array_equal(ours, np.asarray(Image.open(io.BytesIO(data))))
    assert _same(ours, _outcome(data, False, monkeypatch))


def test_compiled_scan_decoder_on_mutated_files(monkeypatch):
    # Corrupt data must end the compiled loop the way it ends the Python one.
    rng = np.random.default_rng(17)
    kinds = {"image": 0, "error": 0}
    for i in range(150):
        data = _mutate(SEEDS[i % len(SEEDS)], rng)
        compiled = _outcome(data, True, monkeypatch)
        assert _same(compiled, _outcome(data, False, monkeypatch)), i
        kinds["error" if isinstance(compiled, str) else "image"] += 1
    assert min(kinds.values()) > 10, kinds  # both outcomes exercised
