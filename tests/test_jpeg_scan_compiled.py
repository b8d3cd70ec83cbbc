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


def test_disable_jit_takes_the_numpy_path(monkeypatch):
    # Under jax.disable_jit() the compiled programs would run op by op (minutes for one
    # 300x400 image): encode and decode must take NumPy, even when asked for `compiled`.
    import jax

    from gfxlab.jpeg import _decoder, _encoder

    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (256, 264, 3), dtype=np.uint8)
    data = jpeg.encode(image, compiled=True)
    pixels = jpeg.decode(data, compiled=True)

    def no_program(*args, **kwargs):
        raise AssertionError("a compiled codec program ran under jax.disable_jit()")

    monkeypatch.setattr(_encoder, "compiled_band_events", no_program)
    monkeypatch.setattr(_decoder, "_reconstruct_compiled", no_program)
    monkeypatch.setattr(_decoder, "decode_scan", _python_scan_only(_decoder.decode_scan))
    with jax.disable_jit():
        for compiled in (None, True):
            assert jpeg.encode(image, compiled=compiled) == data
            assert jpeg.encode(image[None], compiled=compiled) == [data]
            np.testing.assert_array_equal(jpeg.decode(data, compiled=compiled), pixels)


def _python_scan_only(decode_scan):
    def checked(*args, compiled=None, **kwargs):
        assert compiled is False, f"decode_scan got compiled={compiled!r} under disable_jit"
        return decode_scan(*args, compiled=compiled, **kwargs)

    return checked


# Records the compiler options of every `jax.jit` program, then encodes and decodes
# 4:2:0, 4:4:4 and grey files through the compiled programs and compares them with
# Pillow's. Prints the options per codec program, the helper's answer, and whether this
# XLA knows the option (an independent probe).
EMITTERS_SCRIPT = """
import functools, io, json
import jax
import numpy as np
from PIL import Image

options_of = {}
real_jit = jax.jit
def recording_jit(fn=None, **kwargs):
    if fn is None:
        return functools.partial(recording_jit, **kwargs)
    name = f"{fn.__module__}.{fn.__qualname__}"
    options_of.setdefault(name, kwargs.get("compiler_options"))
    return real_jit(fn, **kwargs)
jax.jit = recording_jit

from gfxlab import jpeg
from gfxlab._xla_options import legacy_cpu_emitters

try:
    real_jit(lambda x: x + 1, compiler_options={"xla_cpu_use_fusion_emitters": False}).lower(
        np.int32(0)).compile()
    knows = True
except Exception:
    knows = False
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
codec = {k: v for k, v in options_of.items() if k.startswith("gfxlab.jpeg.")}
print(json.dumps({"codec": codec, "helper": legacy_cpu_emitters(), "knows": knows,
                  "rows": rows}))
"""

CODEC_PROGRAMS = {
    "gfxlab.jpeg._encoder.compiled_band_events.<locals>.events",
    "gfxlab.jpeg._encoder._zigzag",
    "gfxlab.jpeg._entropy_xla._program.<locals>.run",
    "gfxlab.jpeg._decoder._compiled_reconstruct.<locals>.reconstruct",
}


def test_codec_programs_compile_with_legacy_emitters_and_give_pillows_bytes():
    """With the user's XLA flags, each of encode's and decode's compiled programs is
    compiled with XLA's legacy CPU emitters (`gfxlab._xla_options`), unless the user's
    flags choose the emitters or this XLA lacks the option, and the files and pixels
    are still Pillow's. In a child process: the suite's own flags choose the legacy
    emitters for every program, so in-process no option is ever passed."""
    user = os.environ["GFXLAB_USER_XLA_FLAGS"]
    result = run_with_user_xla_flags(EMITTERS_SCRIPT)
    assert result["rows"] == [[True, True]] * 3
    options = {"xla_cpu_use_fusion_emitters": False}
    expected = options if result["knows"] and "fusion_emitters" not in user else None
    assert result["helper"] == expected
    codec = result["codec"]
    assert CODEC_PROGRAMS <= set(codec), codec
    assert all(codec[name] == expected for name in CODEC_PROGRAMS), codec
    # The float programs keep XLA's default emitters (faster for them).
    assert codec["gfxlab.jpeg.compress._compress"] is None


def test_a_users_emitter_flag_wins(monkeypatch):
    import jax

    from gfxlab._xla_options import legacy_cpu_emitters

    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_use_fusion_emitters=true")
    assert legacy_cpu_emitters.__wrapped__() is None
    monkeypatch.setenv(
        "XLA_FLAGS", "--xla_force_host_platform_device_count=1 --xla_cpu_use_fusion_emitters=false"
    )
    assert legacy_cpu_emitters.__wrapped__() is None
    options = {"xla_cpu_use_fusion_emitters": False}
    try:
        jax.jit(lambda x: x + 1, compiler_options=options).lower(np.int32(0)).compile()
        knows = jax.default_backend() == "cpu"
    except jax.errors.JaxRuntimeError:  # an XLA without the option
        knows = False
    # A flag that merely contains the name is not the user's choice.
    monkeypatch.setenv("XLA_FLAGS", "--xla_dump_to=/tmp/xla_cpu_use_fusion_emitters")
    assert legacy_cpu_emitters.__wrapped__() == (options if knows else None)
