"""Section 3 of the course exam: viewing, the BRDF, photometry and colorimetry."""

from __future__ import annotations

import numpy as np

from ._model import Answer, Question, Step, Table


def _q3d(q: Question) -> Answer:
    import jax.numpy as jnp

    from gfxlab import color

    wl = jnp.asarray(color.CIE_WAVELENGTHS)
    v = np.asarray(color.v_lambda(wl))
    peak = float(wl[int(np.argmax(v))])
    sources = []
    for name, spd, power in (
        ("1 W laser at 555 nm", color.line_spectrum(wl, 555.0, 1.0), None),
        ("1 W laser at 650 nm (red)", color.line_spectrum(wl, 650.0, 1.0), None),
        ("equal-energy spectrum, 360-830 nm", jnp.full(wl.shape, 1.0), None),
        (
            "blackbody 2856 K (CIE illuminant A), all wavelengths",
            color.planck(wl, 2856.0),
            color.planck_total_radiance(2856.0),
        ),
        (
            "blackbody 6500 K, all wavelengths",
            color.planck(wl, 6500.0),
            color.planck_total_radiance(6500.0),
        ),
    ):
        flux = float(color.luminous_flux(wl, spd))
        efficacy = float(color.luminous_efficacy(wl, spd, radiant_power=power))
        sources.append((name, f"{flux:.4g}", f"{efficacy:.4g}"))
    # A screen-like white: three narrow-ish primaries, 1 W/(sr m^2) in total.
    screen = sum(
        a * jnp.exp(-0.5 * ((wl - c) / 12.0) ** 2)
        for a, c in ((0.35, 610.0), (0.3, 545.0), (0.35, 455.0))
    )
    screen = screen / jnp.trapezoid(screen, wl)
    screen_luminance = float(color.luminance(wl, screen))
    steps = (
        Step(
            "Photometric quantity",
            "f_p = 683 lm/W · ∫ V(λ) f_r(λ) dλ (V = ȳ, the CIE 1924 "
            "photopic luminous efficiency function)",
        ),
        Step("Peak of V(λ)", f"{peak:g} nm, V = {v.max():.4g}"),
        Step(
            "Luminous flux and efficacy of example sources (1 W of radiant power each, "
            "spectrum normalised on the CIE grid)",
            Table(("source", "flux (lm per W)", "efficacy (lm/W)"), tuple(sources)),
        ),
        Step(
            "Luminance of a screen-like white spectrum of radiance 1 W/(sr·m²)",
            f"{screen_luminance:.4g} cd/m² (lm per sr per m²)",
        ),
    )
    return Answer(
        q,
        summary="Photometry weights a radiometric quantity by the eye's sensitivity V(λ) and the "
        "constant 683 lm/W: radiant flux becomes luminous flux (lm), radiance becomes "
        "luminance (cd/m²). Light at 555 nm gives the maximum 683 lm/W; an incandescent "
        "lamp gives about 16 lm/W because most of its power is infrared.",
        steps=steps,
        values={"peak_nm": peak, "sources": sources, "screen_luminance": screen_luminance},
        errata=(
            "The key integrates from 380 to 800 nm and says ȳ is zero outside; the CIE tables "
            "run from 360 to 830 nm and V is small but not zero there (V(800 nm) ≈ "
            f"{float(np.interp(800.0, np.asarray(wl), v)):.1e}), so the limits change the "
            "result slightly.",
        ),
        see_also="Lab 04 §photometry; gfxlab.color.luminous_flux, luminous_efficacy, luminance, "
        "planck, line_spectrum.",
        figure=lambda: _figure_v(np.asarray(wl), v),
    )


def _figure_v(wl, v):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3))
    ax.plot(wl, v)
    ax.axvline(555, color="k", ls=":")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("V(λ)")
    ax.set_title("CIE 1924 photopic luminous efficiency")
    return fig


def _q3e(q: Question) -> Answer:
    import jax
    import jax.numpy as jnp

    from gfxlab import color

    wl = jnp.asarray(color.CIE_WAVELENGTHS)
    key_a, key_b, key_c = jax.random.split(jax.random.PRNGKey(0), 3)
    a = jax.random.uniform(key_a, (1000, wl.shape[0]))
    c = jax.random.uniform(key_b, (1000, wl.shape[0]))
    alpha = jax.random.uniform(key_c, (1000, 1), minval=0.1, maxval=10.0)
    xyz = lambda s: color.spectrum_to_xyz(wl, s)  # noqa: E731
    additivity = float(jnp.max(jnp.abs(xyz(a + c) - xyz(a) - xyz(c)) / jnp.abs(xyz(a + c))))
    proportionality = float(
        jnp.max(jnp.abs(xyz(alpha * a) - alpha * xyz(a)) / jnp.abs(xyz(alpha * a)))
    )
    steps = (
        Step("Symmetry", "A ~ B implies B ~ A."),
        Step("Transitivity", "A ~ B and B ~ C imply A ~ C."),
        Step("Proportionality", "A ~ B implies αA ~ αB for α > 0."),
        Step("Additivity", "A ~ B and C ~ D imply A + C ~ B + D."),
        Step(
            "Why they hold: a match means equal tristimulus values, and XYZ = ∫ spectrum · CMF "
            "is linear. Checked on 1000 random spectra",
            f"max relative error, additivity {additivity:.1e}; "
            f"proportionality {proportionality:.1e}",
        ),
    )
    return Answer(
        q,
        summary="Colour matches obey the rules of linear algebra (Grassmann 1853): matching is an "
        "equivalence (symmetric, transitive) that survives scaling and adding. That is why "
        "three numbers (XYZ, or RGB) suffice to describe a colour.",
        steps=steps,
        values={"additivity": additivity, "proportionality": proportionality},
        errata=(
            "The additivity law is stated as 'if A matches B, C matches D, and A + C matches "
            "B + D, then A + D matches B + C': the middle premise is redundant (it follows "
            "from the first two), and the usual statement is simply 'A ~ B and C ~ D imply "
            "A + C ~ B + D'.",
        ),
        see_also="Lab 04 §Grassmann's laws; gfxlab.color.spectrum_to_xyz, "
        "gfxlab.color.make_metamer.",
    )


#: Numeric questions: id -> (title, question text, solver).
NUMERIC = {
    "Q3d": ("Photometry", "Write a note on photometry.", _q3d),
    "Q3e": ("Grassmann's laws", "Explain Grassmann's laws.", _q3e),
}

#: Descriptive questions: id -> (title, question text).
DESCRIPTIVE = {
    "Q3a": (
        "Viewing and the canonical view volume",
        "What is viewing? Explain the canonical view volume.",
    ),
    "Q3b": (
        "Camera model and viewing pyramid",
        "Explain the camera model and the viewing pyramid with a diagram.",
    ),
    "Q3c": ("Properties of the BRDF", "Explain different properties of the BRDF."),
    "Q3f": ("Colorimetry", "Explain colour with the help of colorimetry."),
}

#: Descriptive answers: id -> (summary, see also[, errata]).
ANSWERS = {
    "Q3a": (
        "Viewing places a camera in the scene and maps what it sees to the screen: world → eye "
        "coordinates (the view transform), eye → clip coordinates (the projection), a divide by "
        "w to normalised device coordinates, and the viewport map to pixels. The view volume (a "
        "box for orthographic, a frustum for perspective viewing) is mapped onto the canonical "
        "view volume, the cube [-1, 1]³: clipping becomes comparisons with ±1, independent of "
        "the camera.",
        "Lab 03 §8; gfxlab.viewing.perspective, gfxlab.viewing.orthographic, "
        "gfxlab.viewing.in_view_volume, gfxlab.viewing.ndc_to_pixels.",
    ),
    "Q3b": (
        "The pinhole camera model: a camera position C, a point A it looks at (the view axis "
        "A − C), an up direction and a field of view α. Rays through C and the image window form "
        "a pyramid with apex C (the viewing pyramid); near and far planes cut it into a frustum, "
        "and the viewing transform maps that frustum onto −1 <= x, y, z <= 1.",
        "Lab 03 §8 (the pyramid drawn in 3D) and §10 (a camera pose fitted to projected points); "
        "gfxlab.viewing.Camera, gfxlab.viewing.look_at, gfxlab.viewing.frustum.",
    ),
    "Q3c": (
        "A BRDF f_r(ω_i, ω_o) gives reflected radiance per unit incident irradiance. Domain: "
        "pairs of directions in the hemisphere above the surface (4 angles; 3 for isotropic "
        "surfaces), zero below it. Range: non-negative values in 1/sr, unbounded (a mirror is a "
        "delta). Reciprocity (Helmholtz): f_r(ω_i, ω_o) = f_r(ω_o, ω_i). Energy conservation: "
        "the directional albedo ∫ f_r cos θ_i dω_i is at most 1 for every outgoing direction.",
        "Lab 04 §BRDF properties (original Phong is not reciprocal; GGX loses energy at high "
        "roughness); gfxlab.brdf.reciprocity_error, gfxlab.brdf.directional_albedo, "
        "gfxlab.brdf.cook_torrance.",
    ),
    "Q3f": (
        "Colorimetry measures colour by what a standard observer matches. Three cone types make "
        "colour vision three-dimensional, so any stimulus can be matched by a mix of three "
        "primaries; the CIE 1931 colour-matching functions x̄, ȳ, z̄ turn a spectrum into "
        "tristimulus values X, Y, Z (Y is luminance), and chromaticity (x, y) = (X, Y)/(X+Y+Z) "
        "separates colour from brightness. Different spectra with equal XYZ (metamers) look the "
        "same.",
        "Lab 04 §colorimetry (chromaticity diagram with the sRGB gamut, metamers); "
        "gfxlab.color.spectrum_to_xyz, gfxlab.color.xyz_to_xy, gfxlab.color.xyz_to_srgb.",
    ),
}
