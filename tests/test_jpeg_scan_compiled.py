"""`jpeg.decode`'s compiled programs (the entropy-decoding loop and the reconstruction,
taken by default from 1024 blocks on) against the Python and NumPy path they replace, on
small files decoded both ways (`compiled=True` / `False`): the same pixels for every
kind of scan, equal to Pillow's, and the same outcome (image or `JPEGError`, same
message) on mutated files."""

from __future__ import annotations

import io
import os
import warnings

import numpy as np
import pytest
from PIL import Image
from test_jpeg_fuzz import SEEDS, _mutate
from user_flags import run_with_user_xla_flags

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


# Encode and decode 4:2:0, 4:4:4 and grey files through the compiled programs and
# compare them with Pillow; prints whether the programs were compiled with options.
EMITTERS_SCRIPT = """
import io, json, sys
import numpy as np
from PIL import Image
from gfxlab import jpeg
from gfxlab._xla_options import legacy_cpu_emitters

rng = np.random.default_rng(3)
y, x = np.mgrid[:67, :93]
img = np.stack([120 + 90 * np.sin(x / 6 + y / 9), 128 + 70 * np.cos(x / 4), 2.0 * y], -1)
img = np.clip(img + rng.normal(0, 25, img.shape), 0, 255).astype(np.uint8)
rows = []
for image, subsampling in [(img, 2), (img, 0), (img[..., 1].copy(), 2)]:
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, "JPEG", quality=80, subsampling=subsampling)
    ours = jpeg.encode(image, quality=80, subsampling=["4:4:4", "", "4:2:0"][subsampling],
                       compiled=True)
    decoded = jpeg.decode(buf.getvalue(), compiled=True)
    pillow = np.asarray(Image.open(io.BytesIO(buf.getvalue())))
    rows.append([ours == buf.getvalue(), bool(np.array_equal(decoded, pillow))])
print(json.dumps({"options": legacy_cpu_emitters(), "rows": rows}))
"""


def test_programs_compiled_with_legacy_emitters_give_pillows_bytes():
    """With the user's XLA flags, encode's and decode's compiled programs select XLA's
    legacy CPU emitters (`gfxlab._xla_options`) and still give Pillow's bytes and
    pixels. In a child process: the suite's own flags already select those emitters
    for every program, so in-process the option is never passed."""
    user = os.environ["GFXLAB_USER_XLA_FLAGS"]
    result = run_with_user_xla_flags(EMITTERS_SCRIPT)
    assert result["rows"] == [[True, True]] * 3
    if "xla_cpu_use_fusion_emitters" not in user:
        assert result["options"] == {"xla_cpu_use_fusion_emitters": False}


def test_a_users_emitter_flag_wins(monkeypatch):
    import jax

    from gfxlab._xla_options import legacy_cpu_emitters

    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_use_fusion_emitters=true")
    assert legacy_cpu_emitters.__wrapped__() is None
    monkeypatch.setenv("XLA_FLAGS", "")
    on_cpu = jax.default_backend() == "cpu"
    expected = {"xla_cpu_use_fusion_emitters": False} if on_cpu else None
    assert legacy_cpu_emitters.__wrapped__() == expected
