"""gfxlab.jpeg.decode on corrupt, truncated and unsupported input: only JPEGError."""

from __future__ import annotations

import io
import time
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from gfxlab.jpeg import JPEGError, decode, encode


def _seeds() -> list[bytes]:
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, (16, 24, 3), dtype=np.uint8)
    files = [encode(img, quality=q, subsampling=s) for q, s in [(50, "4:2:0"), (90, "4:4:4")]]
    files.append(encode(img[..., 0], quality=75))
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, "JPEG", quality=80, restart_marker_blocks=2)
    files.append(buf.getvalue())
    return files


SEEDS = _seeds()


def _decode_or_jpeg_error(data: bytes) -> str:
    try:
        out = decode(data)
    except JPEGError:
        return "JPEGError"
    assert out.dtype == np.uint8 and out.ndim in (2, 3)
    return "decoded"


def _mutate(data: bytes, rng: np.random.Generator) -> bytes:
    arr = bytearray(data)
    kind = rng.integers(0, 6)
    if kind == 0:  # flip bytes anywhere
        for i in rng.integers(0, len(arr), rng.integers(1, 6)):
            arr[i] = int(rng.integers(0, 256))
    elif kind == 1:  # flip bytes in the headers (tables, frame, scan headers)
        for i in rng.integers(2, min(len(arr), 640), rng.integers(1, 4)):
            arr[i] = int(rng.integers(0, 256))
    elif kind == 2:  # truncate
        arr = arr[: int(rng.integers(0, len(arr)))]
    elif kind == 3:  # insert random bytes
        at = int(rng.integers(0, len(arr)))
        arr[at:at] = rng.integers(0, 256, int(rng.integers(1, 16)), dtype=np.uint8).tobytes()
    elif kind == 4:  # delete a chunk
        at = int(rng.integers(0, len(arr)))
        del arr[at : at + int(rng.integers(1, 64))]
    else:  # plant a marker
        at = int(rng.integers(2, len(arr) - 1))
        arr[at : at + 2] = bytes([0xFF, int(rng.integers(0xC0, 0x100))])
    return bytes(arr)


def _return_freed_memory() -> None:
    """Make glibc give large freed blocks back to the system at once (a fixed mmap
    threshold and no heap-top slack), so that the resident high-water mark counts what
    a call allocates even when earlier calls freed as much."""
    import ctypes

    libc = ctypes.CDLL("libc.so.6")
    m_trim_threshold, m_mmap_threshold = -1, -3
    if not (libc.mallopt(m_mmap_threshold, 1 << 16) and libc.mallopt(m_trim_threshold, 1 << 16)):
        raise OSError("mallopt failed")
    libc.malloc_trim(0)


def peak_bytes_of(fn):
    """Peak memory `fn()` adds, and its result. On Linux: the resident set's high-water
    mark (reset through /proc/self/clear_refs), which counts every allocation (NumPy,
    XLA) at full speed; elsewhere (no /proc, no glibc) tracemalloc (Python and NumPy
    allocations only)."""
    status, clear = Path("/proc/self/status"), Path("/proc/self/clear_refs")

    def field(name):
        line = next(x for x in status.read_text().splitlines() if x.startswith(name + ":"))
        return int(line.split()[1]) * 1024

    try:
        _return_freed_memory()
        clear.write_text("5")
    except OSError:
        tracemalloc.start()
        out = fn()
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        return peak, out
    before = field("VmRSS")
    out = fn()
    return field("VmHWM") - before, out


def run_fuzz(n: int, seed: int) -> dict:
    """Decode `n` mutated seed files; count outcomes (any other exception propagates)."""
    rng = np.random.default_rng(seed)
    outcomes = {"decoded": 0, "JPEGError": 0}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # e.g. "no EOI marker"
        for case in range(n):
            outcomes[_decode_or_jpeg_error(_mutate(SEEDS[case % len(SEEDS)], rng))] += 1
    return outcomes


def test_mutated_files_raise_only_jpeg_error():
    run_fuzz(200, 1)  # warm up: compile what the decoded images need
    start = time.perf_counter()
    peak, outcomes = peak_bytes_of(lambda: run_fuzz(3000, 1234))
    assert time.perf_counter() - start < 120  # no hangs
    assert outcomes["decoded"] > 100 and outcomes["JPEGError"] > 100, outcomes
    assert peak < 200e6  # bounded memory: no allocation from a declared size


@given(st.binary(max_size=300))
def test_garbage_after_soi(tail):
    _decode_or_jpeg_error(b"\xff\xd8" + tail)


@given(st.binary(max_size=64), st.integers(0, len(SEEDS[0])))
def test_spliced_garbage(garbage, at):
    _decode_or_jpeg_error(SEEDS[0][:at] + garbage + SEEDS[0][at:])


def _replace_sof(data: bytes, marker: int, precision: int = 8) -> bytes:
    i = data.index(b"\xff\xc0")
    return data[:i] + bytes([0xFF, marker, data[i + 2], data[i + 3], precision]) + data[i + 5 :]


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: b"GIF89a" + d, "not a JPEG"),
        (lambda d: d[: len(d) // 2], "truncated"),
        (lambda d: d[:-40], "truncated"),
        (lambda d: _replace_sof(d, 0xC2), "progressive"),
        (lambda d: _replace_sof(d, 0xC9), "arithmetic"),
        (lambda d: _replace_sof(d, 0xC3), "lossless"),
        (lambda d: _replace_sof(d, 0xC0, precision=12), "precision 12"),
        (
            lambda d: d.replace(
                b"\xff\xc4\x00\x1f\x00\x00\x01\x05", b"\xff\xc4\x00\x1f\x00\x03\x00\x03"
            ),
            "bad Huffman table",
        ),
        (lambda d: d[:2] + d[-2:], "EOI before any image"),
    ],
)
def test_specific_errors(make, message):
    with pytest.raises(JPEGError, match=message):
        decode(make(SEEDS[0]))


def test_pillow_progressive_is_unsupported():
    buf = io.BytesIO()
    Image.fromarray(np.zeros((16, 16, 3), np.uint8)).save(buf, "JPEG", progressive=True)
    with pytest.raises(JPEGError, match="progressive"):
        decode(buf.getvalue())
    assert issubclass(JPEGError, ValueError)
