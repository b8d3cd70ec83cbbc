"""Median filter: gfxlab's selection network against SciPy and OpenCV, same run.

Goal (issue 7): 3x3 on a 1024x1024 uint8 image at least 50x faster than
`scipy.ndimage.median_filter` and within 5x of OpenCV's `cv2.medianBlur`.
"""

from __future__ import annotations

import jax
import numpy as np
import scipy.ndimage as ndi
from harness import Table, timeit

from gfxlab import image as gi


def main() -> None:
    import cv2

    rng = np.random.default_rng(0)
    grey = rng.integers(0, 256, (1024, 1024), dtype=np.uint8)
    colour = rng.integers(0, 256, (512, 512, 3), dtype=np.uint8)
    on_device = jax.device_put(grey)
    colour_on_device = jax.device_put(colour)

    scipy_table = Table("median filter vs scipy.ndimage.median_filter (uint8)", "scipy")
    cv2_table = Table("median filter vs cv2.medianBlur (uint8)", "OpenCV")
    for size in (3, 5, 7):
        ours = jax.jit(lambda x, size=size: gi.median_filter(x, size=size))
        out = np.asarray(ours(on_device))
        same = np.array_equal(out, ndi.median_filter(grey, size=size, mode="reflect"))
        ours_s = timeit(lambda ours=ours: ours(on_device), repeat=20, warmup=2)
        scipy_s = timeit(lambda size=size: ndi.median_filter(grey, size=size), repeat=3)
        cv2_s = timeit(lambda size=size: cv2.medianBlur(grey, size), repeat=20, warmup=2)
        case = f"{size}x{size} on 1024x1024"
        scipy_table.add(case, ours_s, scipy_s, f"identical output: {same}")
        cv2_table.add(case, ours_s, cv2_s, f"ours / OpenCV = {ours_s / cv2_s:.1f}x")

    ours = jax.jit(lambda x: gi.median_filter(x, size=3))
    ours_s = timeit(lambda: ours(colour_on_device), repeat=20, warmup=2)
    cv2_table.add(
        "3x3 on 512x512x3", ours_s, timeit(lambda: cv2.medianBlur(colour, 3), repeat=20), ""
    )
    scipy_table.add(
        "3x3 on 512x512x3",
        ours_s,
        timeit(lambda: ndi.median_filter(colour, size=(3, 3, 1)), repeat=3),
        "",
    )
    cross = jax.jit(lambda x: gi.median_filter(x, footprint=gi.cross_footprint()))
    scipy_table.add(
        "5-pixel cross on 1024x1024",
        timeit(lambda: cross(on_device), repeat=20, warmup=2),
        timeit(lambda: ndi.median_filter(grey, footprint=gi.cross_footprint()), repeat=3),
        "",
    )
    scipy_table.print()
    cv2_table.print()

    linear = Table("linear filters vs scipy.ndimage (float32 1024x1024)", "scipy")
    image = rng.random((1024, 1024), dtype=np.float32)
    image_on_device = jax.device_put(image)
    mean = jax.jit(lambda x: gi.mean_filter(x, size=5))
    gauss = jax.jit(lambda x: gi.gaussian_filter(x, sigma=2.0))
    linear.add(
        "mean 5x5",
        timeit(lambda: mean(image_on_device), repeat=10, warmup=2),
        timeit(lambda: ndi.uniform_filter(image, 5), repeat=5),
    )
    linear.add(
        "gaussian sigma=2",
        timeit(lambda: gauss(image_on_device), repeat=10, warmup=2),
        timeit(lambda: ndi.gaussian_filter(image, 2.0), repeat=5),
    )
    linear.print()


if __name__ == "__main__":
    main()
