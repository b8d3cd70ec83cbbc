"""Eager calls of every public `gfxlab.brdf` and `gfxlab.color` function against the
same call inside a user's `jax.jit` (issue 19: one compiled call per public function).

For a small and a large input it prints the eager time, the jitted time, their ratio
(target <= 1.3x at the large size) and the fixed overhead of the eager call at the small
size (target <= 100 us). `python tests/benchmarks/run.py color_api`.
"""

from __future__ import annotations

import functools
import sys

import jax
import jax.numpy as jnp
import numpy as np
from harness import timeit_pair

jax.config.update("jax_enable_x64", True)


def _directions(rng, count):
    v = np.abs(rng.normal(size=(count, 3))) + [0.0, 0.0, 0.5]
    return jnp.asarray(v / np.linalg.norm(v, axis=-1, keepdims=True))


def _cases(size: str):
    from gfxlab import brdf, color

    rng = np.random.default_rng(0)
    count = 16 if size == "small" else 100_000
    spectra = 1 if size == "small" else 1000
    wi, wo = _directions(rng, count), _directions(rng, count)
    n = jnp.broadcast_to(jnp.array([0.0, 0.0, 1.0]), wi.shape)
    cos = jnp.asarray(rng.uniform(0.0, 1.0, count))
    wl = jnp.asarray(color.CIE_WAVELENGTHS)
    spd = jnp.asarray(rng.uniform(0.0, 1.0, (spectra, wl.shape[0])))
    spd2 = jnp.asarray(rng.uniform(0.0, 1.0, (spectra, wl.shape[0])))
    xyz = jnp.asarray(rng.uniform(0.05, 1.0, (count, 3)))
    xy = xyz[:, :2] / jnp.sum(xyz, -1, keepdims=True)
    grid = wl if size == "large" else jnp.linspace(380.0, 780.0, 81)
    temps = jnp.asarray(rng.uniform(1000.0, 9000.0, spectra))
    angles = jnp.asarray(rng.uniform(0.0, 1.2, count))
    side = 16 if size == "small" else 512
    ct = brdf.CookTorrance(0.4, 0.5)
    return {
        "brdf.lambert": (brdf.lambert, (wi, wo, n), {}),
        "brdf.phong": (brdf.phong, (wi, wo, n), {"shininess": 20.0, "kd": 0.3}),
        "brdf.blinn_phong": (brdf.blinn_phong, (wi, wo, n), {"shininess": 20.0}),
        "brdf.cook_torrance": (brdf.cook_torrance, (wi, wo, n), {"roughness": 0.4}),
        "brdf.CookTorrance()": (ct, (wi, wo, n), {}),
        "brdf.ggx_distribution": (brdf.ggx_distribution, (cos, 0.3), {}),
        "brdf.smith_visibility": (brdf.smith_visibility, (cos, cos[::-1], 0.3), {}),
        "brdf.schlick_fresnel": (brdf.schlick_fresnel, (cos, 0.04), {}),
        "brdf.reflect": (brdf.reflect, (wi, n), {}),
        "brdf.half_diff_to_directions": (
            brdf.half_diff_to_directions,
            (angles, angles, angles),
            {},
        ),
        "brdf.reciprocity_error": (brdf.reciprocity_error, (ct, wi, wo, n), {}),
        "brdf.directional_albedo": (
            functools.partial(brdf.directional_albedo, num_theta=32, num_phi=16),
            (ct, wi[: count // 100 or 1]),
            {},
        ),
        # the intensity is an argument, so the jitted version is not constant-folded
        "brdf.shade_sphere": (
            lambda m, e: brdf.shade_sphere(m, (side, side), intensity=e),
            (ct, jnp.asarray(1.0)),
            {},
        ),
        "color.cmfs": (color.cmfs, (grid,), {}),
        "color.v_lambda": (color.v_lambda, (grid,), {}),
        "color.spectrum_to_xyz": (color.spectrum_to_xyz, (wl, spd), {}),
        "color.xyz_to_xy": (color.xyz_to_xy, (xyz,), {}),
        "color.xy_to_xyz": (color.xy_to_xyz, (xy, xyz[:, 1]), {}),
        "color.spectral_locus": (color.spectral_locus, (grid,), {}),
        "color.srgb_encode": (color.srgb_encode, (xyz,), {}),
        "color.srgb_decode": (color.srgb_decode, (xyz,), {}),
        "color.xyz_to_srgb": (color.xyz_to_srgb, (xyz,), {}),
        "color.srgb_to_xyz": (color.srgb_to_xyz, (xyz,), {}),
        "color.luminous_flux": (color.luminous_flux, (wl, spd), {}),
        "color.luminance": (color.luminance, (wl, spd), {}),
        "color.luminous_efficiency": (color.luminous_efficiency, (wl, spd), {}),
        "color.luminous_efficacy": (color.luminous_efficacy, (wl, spd), {}),
        "color.planck": (color.planck, (wl, temps), {}),
        "color.planck_total_radiance": (color.planck_total_radiance, (temps,), {}),
        "color.line_spectrum": (color.line_spectrum, (wl, 555.3), {}),
        "color.fundamental_metamer": (color.fundamental_metamer, (wl, spd), {}),
        "color.metameric_black": (color.metameric_black, (wl, spd), {}),
        "color.metameric_black_basis": (color.metameric_black_basis, (grid,), {}),
        "color.make_metamer": (color.make_metamer, (wl, spd, spd2), {}),
        "color.metameric_match": (color.metameric_match, (wl, spd, spd2), {}),
    }


def main(only: str = "") -> None:
    print("\n## brdf, color: eager call vs the same call inside jax.jit\n")
    print("| function | size | eager (ms) | inside jax.jit (ms) | eager/jit | eager overhead |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for size in ("small", "large"):
        for name, (fn, args, kwargs) in _cases(size).items():
            if only and only not in name:
                continue
            eager = lambda fn=fn, args=args, kwargs=kwargs: fn(*args, **kwargs)  # noqa: E731
            jitted_fn = jax.jit(lambda *a, fn=fn, kwargs=kwargs: fn(*a, **kwargs))
            jitted = lambda jitted_fn=jitted_fn, args=args: jitted_fn(*args)  # noqa: E731
            repeat = 21 if size == "small" else 5
            try:
                t_eager, t_jit = timeit_pair(eager, jitted, repeat=repeat, warmup=2)
            except Exception as err:  # noqa: BLE001 - a row that cannot run says why
                print(f"| {name} | {size} | error: {type(err).__name__}: {str(err)[:80]} | | | |")
                continue
            overhead = f"{(t_eager - t_jit) * 1e6:.0f} us" if size == "small" else ""
            print(
                f"| {name} | {size} | {t_eager * 1e3:.3f} | {t_jit * 1e3:.3f} "
                f"| {t_eager / t_jit:.2f}x | {overhead} |"
            )


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "")
