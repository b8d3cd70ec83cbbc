"""Eager calls versus the same call inside a user's `jax.jit` (`make bench BENCH=api`).

Users call public functions eagerly from notebooks. Each should be one compiled call:
argument checks in Python, all array work in one jitted function. For a sample of
public functions at a small and a large size this prints the eager time, the time of
the same call inside `jax.jit`, their ratio (target: <= 1.3x at the large size) and, at
the small size, the fixed overhead of the eager call (target: <= 100 us).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from harness import timeit_pair

from gfxlab import animation, brdf, clipping, color, curves, image, jpeg, raster, render, transforms
from gfxlab.mesh import pawn
from gfxlab.viewing import Camera


def _cases(n: int, side: int):
    rng = np.random.default_rng(0)
    points = jnp.asarray(rng.normal(size=(n, 3)), jnp.float32)
    segments = jnp.asarray(rng.uniform(-2, 2, size=(n, 2, 2)), jnp.float32)
    window = jnp.array([-1.0, -1.0, 1.0, 1.0], jnp.float32)
    u = jnp.linspace(0.0, 1.0, n, dtype=jnp.float32)
    control = jnp.asarray(rng.normal(size=(8, 2)), jnp.float32)
    w = jnp.asarray(np.abs(rng.normal(size=(n, 3))) + [0, 0, 1], jnp.float32)
    w = w / jnp.linalg.norm(w, axis=-1, keepdims=True)
    normal = jnp.broadcast_to(jnp.array([0.0, 0.0, 1.0], jnp.float32), w.shape)
    wavelengths = jnp.arange(380.0, 781.0, 5.0, dtype=jnp.float32)
    spd = jnp.asarray(rng.uniform(size=(max(n // 100, 1), wavelengths.shape[0])), jnp.float32)
    picture = jnp.asarray(rng.uniform(size=(side, side)), jnp.float32)
    photo = jnp.asarray(rng.uniform(size=(side, side, 3)), jnp.float32)
    q0 = jnp.broadcast_to(jnp.array([1.0, 0.0, 0.0, 0.0], jnp.float32), (n, 4))
    q1 = jnp.broadcast_to(jnp.array([0.0, 0.0, 0.0, 1.0], jnp.float32), (n, 4))
    star = jnp.array([[0, 0], [side - 1, side // 3], [side // 4, side - 1]], jnp.float32)
    matrix = transforms.rotate_z(jnp.float32(0.3))
    model = pawn(segments=16)  # 800 faces
    camera = Camera(jnp.array([0.0, 1.0, 5.0]), jnp.array([0.0, 1.0, 0.0]), fov_y=0.6)
    view = (side // 2, side // 2)  # 8 x 8 and 256 x 256
    # `capacity` given, as a traced call needs it (an eager call measures it itself)
    capacity = render.tile_capacity(model, camera, view, sigma=1.0, slack=1.2)
    return {
        "transforms.apply": (transforms.apply, (matrix, points), {}),
        "clipping.cohen_sutherland": (clipping.cohen_sutherland, (segments, window), {}),
        "curves.bezier": (curves.bezier, (control, u), {}),
        "curves.bspline (cubic)": (lambda cp, t: curves.bspline(cp, 3, t), (control, u), {}),
        "brdf.cook_torrance": (brdf.cook_torrance, (w, w[::-1], normal), {"roughness": 0.4}),
        "color.spectrum_to_xyz": (color.spectrum_to_xyz, (wavelengths, spd), {}),
        "animation.slerp": (animation.slerp, (q0, q1, u), {}),
        "image.median_filter 3x3": (image.median_filter, (picture,), {"size": 3}),
        "image.gaussian_filter": (image.gaussian_filter, (picture,), {"sigma": 1.5}),
        "raster.polygon_coverage": (
            functools.partial(raster.polygon_coverage, shape=(side, side)),
            (star,),
            {},
        ),
        "jpeg.compress q50": (jpeg.compress, (photo,), {"quality": 50.0}),
        "render.render (800 faces, soft)": (
            functools.partial(render.render, shape=view, capacity=capacity),
            (model, camera),
            {},
        ),
    }


def _row(name, fn, args, kwargs):
    jitted = jax.jit(lambda *a: fn(*a, **kwargs))
    return timeit_pair(lambda: fn(*args, **kwargs), lambda: jitted(*args), repeat=21)


def main() -> None:
    print("| function | size | eager (ms) | inside jax.jit (ms) | eager/jit | eager overhead |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for label, n, side in (("small", 16, 16), ("large", 200_000, 512)):
        for name, (fn, args, kwargs) in _cases(n, side).items():
            try:
                eager, jitted = _row(name, fn, args, kwargs)
            except Exception as err:  # a row that cannot run says why, the rest go on
                print(f"| {name} | {label} | error: {type(err).__name__}: {err} | | | |")
                continue
            overhead = f"{(eager - jitted) * 1e6:.0f} us" if label == "small" else ""
            print(
                f"| {name} | {label} | {eager * 1e3:.3f} | {jitted * 1e3:.3f} "
                f"| {eager / jitted:.2f}x | {overhead} |"
            )


if __name__ == "__main__":
    main()
