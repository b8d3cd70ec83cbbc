"""gfxlab.color and gfxlab.brdf against colour-science (and a NumPy loop for albedos)."""

from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np
from harness import Table, timeit

jax.config.update("jax_enable_x64", True)


def main() -> None:
    import colour

    from gfxlab import brdf, color

    wl = color.CIE_WAVELENGTHS
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    rng = np.random.default_rng(0)

    table = Table("colour: spectra -> XYZ, photometry, sRGB", "colour-science")
    to_xyz = jax.jit(color.spectrum_to_xyz)
    for count in (1, 1000):
        spectra = rng.uniform(0, 1, (count, wl.size))
        ours = timeit(lambda s=spectra: to_xyz(wl, s), repeat=5)
        msds = colour.MultiSpectralDistributions(spectra.T, wl) if count > 1 else None
        sd = colour.SpectralDistribution(spectra[0], wl)

        def reference(msds=msds, sd=sd):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if msds is None:
                    return colour.sd_to_XYZ(sd, cmfs, k=683, method="Integration")
                return colour.msds_to_XYZ(msds, cmfs, k=683, method="Integration")

        table.add(f"spectrum_to_xyz x{count}", ours, timeit(reference, repeat=3), "1 nm grid")
    spectrum = rng.uniform(0, 1, wl.size)
    flux = jax.jit(color.luminous_flux)
    sd = colour.SpectralDistribution(spectrum, wl)
    table.add(
        "luminous_flux",
        timeit(lambda: flux(wl, spectrum)),
        timeit(lambda: colour.luminous_flux(sd)),
    )
    xyz = rng.uniform(0, 1, (512 * 512, 3))
    to_srgb = jax.jit(color.xyz_to_srgb)
    table.add(
        "xyz_to_srgb 512x512",
        timeit(lambda: to_srgb(xyz)),
        timeit(lambda: colour.XYZ_to_sRGB(xyz), repeat=3),
    )
    table.print()

    table = Table("brdf: white furnace and shading (ours only)", "-")
    model = brdf.CookTorrance(0.5, 1.0)
    wo = jnp.stack([jnp.array([np.sin(t), 0.0, np.cos(t)]) for t in np.linspace(0, 1.4, 16)])
    albedo = jax.jit(lambda m, w: brdf.directional_albedo(m, w))
    ours = timeit(lambda: albedo(model, wo), repeat=3)

    table.add("directional_albedo x16", ours, None, "256x128 quadrature points each")
    # shade_sphere compiles its own core; an outer jit would constant-fold the whole image
    shade = lambda: brdf.shade_sphere(model, (512, 512))  # noqa: E731
    table.add("shade_sphere 512x512 GGX", timeit(shade), None, "")
    table.print()


if __name__ == "__main__":
    main()
