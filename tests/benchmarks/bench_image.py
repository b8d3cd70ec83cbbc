"""Image filters: gfxlab called eagerly and inside a user's `jax.jit`, against SciPy and
OpenCV in the same run.

Goals (issue 19): 3x3 and 5x5 medians on a 1024x1024 uint8 image within 2x of OpenCV's
`cv2.medianBlur`; an eager call no slower than 1.3x the jitted one (every public
function is one compiled call); results identical to `scipy.ndimage`.
"""

from __future__ import annotations

import statistics
import time

import jax
import numpy as np
import scipy.ndimage as ndi

from gfxlab import image as gi


def timeit_alternating(*fns, repeat: int = 31, warmup: int = 3) -> list[float]:
    """Median wall times of several functions called in turn (same machine state)."""
    for _ in range(warmup):
        for fn in fns:
            jax.block_until_ready(fn())
    times = [[] for _ in fns]
    for _ in range(repeat):
        for fn, out in zip(fns, times, strict=True):
            start = time.perf_counter()
            jax.block_until_ready(fn())
            out.append(time.perf_counter() - start)
    return [statistics.median(t) for t in times]


def _row(case, eager, jitted, scipy_s, cv2_s, note=""):
    cells = [case, f"{eager * 1e3:.3f}", f"{jitted * 1e3:.3f}", f"{eager / jitted:.2f}x"]
    cells.append(f"{scipy_s * 1e3:.2f}" if scipy_s else "-")
    cells.append(f"{scipy_s / eager:.0f}x" if scipy_s else "-")
    cells.append(f"{cv2_s * 1e3:.3f}" if cv2_s else "-")
    cells.append(f"{eager / cv2_s:.2f}x" if cv2_s else "-")
    print("| " + " | ".join([*cells, note]) + " |")


def _median_rows(cv2, grey, colour):
    device = jax.device_put(grey)
    for size in (3, 5, 7):
        jitted = jax.jit(lambda x, size=size: gi.median_filter(x, size=size))
        same = np.array_equal(
            np.asarray(gi.median_filter(device, size=size)),
            ndi.median_filter(grey, size=size, mode="reflect"),
        )
        eager_s, jit_s, cv2_s = timeit_alternating(
            lambda size=size: gi.median_filter(device, size=size),
            lambda jitted=jitted: jitted(device),
            lambda size=size: cv2.medianBlur(grey, size),
        )
        (scipy_s,) = timeit_alternating(
            lambda size=size: ndi.median_filter(grey, size=size), repeat=3, warmup=1
        )
        _row(
            f"median {size}x{size} 1024x1024 u8",
            eager_s,
            jit_s,
            scipy_s,
            cv2_s,
            f"identical to SciPy: {same}",
        )
    colour_device = jax.device_put(colour)
    jitted = jax.jit(lambda x: gi.median_filter(x, size=3))
    eager_s, jit_s, cv2_s = timeit_alternating(
        lambda: gi.median_filter(colour_device, size=3),
        lambda: jitted(colour_device),
        lambda: cv2.medianBlur(colour, 3),
    )
    (scipy_s,) = timeit_alternating(
        lambda: ndi.median_filter(colour, size=(3, 3, 1)), repeat=3, warmup=1
    )
    _row("median 3x3 512x512x3 u8", eager_s, jit_s, scipy_s, cv2_s)
    cross = gi.cross_footprint()
    jitted = jax.jit(lambda x: gi.median_filter(x, footprint=cross))
    eager_s, jit_s = timeit_alternating(
        lambda: gi.median_filter(device, footprint=cross), lambda: jitted(device)
    )
    (scipy_s,) = timeit_alternating(
        lambda: ndi.median_filter(grey, footprint=cross), repeat=3, warmup=1
    )
    _row("median 5-pixel cross 1024x1024 u8", eager_s, jit_s, scipy_s, None)


def _linear_rows(cv2, image):
    device = jax.device_put(image)
    cases = [
        (
            "mean 5x5",
            lambda x: gi.mean_filter(x, size=5),
            lambda: ndi.uniform_filter(image, 5),
            lambda: cv2.blur(image, (5, 5), borderType=cv2.BORDER_REFLECT),
        ),
        (
            "gaussian sigma=2",
            lambda x: gi.gaussian_filter(x, sigma=2.0),
            lambda: ndi.gaussian_filter(image, 2.0),
            lambda: cv2.GaussianBlur(image, (17, 17), 2.0, borderType=cv2.BORDER_REFLECT),
        ),
    ]
    for name, ours, scipy_fn, cv2_fn in cases:
        jitted = jax.jit(ours)
        eager_s, jit_s, scipy_s, cv2_s = timeit_alternating(
            lambda ours=ours: ours(device), lambda j=jitted: j(device), scipy_fn, cv2_fn, repeat=11
        )
        _row(f"{name} 1024x1024 f32", eager_s, jit_s, scipy_s, cv2_s)


def _small_rows():
    """The fixed overhead of an eager call: a tiny image, eager vs jitted."""
    small = jax.device_put(np.random.default_rng(1).integers(0, 256, (16, 16), dtype=np.uint8))
    for name, fn in [
        ("median 3x3 16x16", lambda x: gi.median_filter(x, size=3)),
        ("mean 3x3 16x16", lambda x: gi.mean_filter(x, size=3)),
        ("gaussian sigma=1 16x16", lambda x: gi.gaussian_filter(x, sigma=1.0)),
    ]:
        jitted = jax.jit(fn)
        eager_s, jit_s = timeit_alternating(
            lambda fn=fn: fn(small), lambda j=jitted: j(small), repeat=51
        )
        _row(name, eager_s, jit_s, None, None, f"eager overhead {(eager_s - jit_s) * 1e6:.0f} us")


def main() -> None:
    import cv2

    rng = np.random.default_rng(0)
    print("\n## image filters: eager vs in jit, SciPy and OpenCV (same run)\n")
    print(
        "| case | ours eager (ms) | ours in jit (ms) | eager/jit | SciPy (ms) | SciPy/ours "
        "| OpenCV (ms) | ours/OpenCV | note |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |")
    _median_rows(
        cv2,
        rng.integers(0, 256, (1024, 1024), dtype=np.uint8),
        rng.integers(0, 256, (512, 512, 3), dtype=np.uint8),
    )
    _linear_rows(cv2, rng.random((1024, 1024), dtype=np.float32))
    _small_rows()


if __name__ == "__main__":
    main()
