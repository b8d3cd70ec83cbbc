"""Section 5 of the course exam: images, median filtering, JPEG, animation."""

from __future__ import annotations

import numpy as np

from ._format import number
from ._model import Answer, Question, Step

_SEED_MEDIAN = np.array([[91, 55, 90], [77, 68, 95], [115, 151, 210]], float)


def _q5c(q: Question) -> Answer:
    import jax.numpy as jnp

    from gfxlab import image

    full = float(np.asarray(image.median_filter(jnp.asarray(_SEED_MEDIAN), size=3))[1, 1])
    cross = float(
        np.asarray(
            image.median_filter(jnp.asarray(_SEED_MEDIAN), footprint=image.cross_footprint(1))
        )[1, 1]
    )
    even = np.array([55.0, 68.0, 77.0, 91.0])
    even_median = float(image.median(jnp.asarray(even)))
    x, y = np.array([1.0, 5.0, 2.0]), np.array([4.0, 0.0, 3.0])
    mx, my, mxy = (float(image.median(jnp.asarray(s))) for s in (x, y, x + y))
    steps = (
        Step(
            "3×3 window, sorted",
            f"{sorted(_SEED_MEDIAN.ravel().astype(int).tolist())} -> "
            f"median (5th of 9) = {number(full)}",
        ),
        Step(
            "5-pixel cross (centre and its 4 neighbours), sorted",
            f"{sorted([55, 77, 68, 95, 151])} -> median (3rd of 5) = {number(cross)}",
        ),
        Step(
            "Even window (2K values): mean of the K-th and (K+1)-th",
            f"{even.astype(int).tolist()} -> ({number(even[1])} + {number(even[2])})/2 = "
            f"{number(even_median)}",
        ),
        Step(
            "Non-linear: median{x + y} != median{x} + median{y}",
            f"x = {x.astype(int).tolist()}, y = {y.astype(int).tolist()}: median(x + y) = "
            f"{number(mxy)} but median(x) + median(y) = {number(mx)} + {number(my)} = "
            f"{number(mx + my)}",
        ),
    )
    return Answer(
        q,
        summary="A median filter replaces each pixel by the median of its neighbourhood: it "
        "removes impulse (salt-and-pepper) noise while keeping edges, and it is "
        "non-linear. The exam's 3×3 block gives 91; the cross gives 77.",
        steps=steps,
        values={"full": full, "cross": cross, "even": even_median},
        errata=(
            "The even-window formula is printed with its denominator garbled "
            "('(K+1)th classified value' under the fraction bar): the output is "
            "(K-th value + (K+1)-th value) / 2.",
            "The key says 'sort the original image values on the 3×3 cross window' for the "
            "5-pixel cross: the cross has 5 values, not 9.",
        ),
        see_also="Lab 07 §median filtering; gfxlab.image.median_filter(image, size=3), "
        "footprint=gfxlab.image.cross_footprint(1).",
    )


# The exam's block after the level shift (pixel - 128).
_SEED_JPEG_BLOCK = np.array(
    [
        [-76, -73, -67, -62, -58, -67, -64, -55],
        [-65, -69, -73, -38, -19, -43, -59, -56],
        [-66, -69, -60, -15, 16, -24, -62, -55],
        [-65, -70, -57, -6, 26, -22, -58, -59],
        [-61, -67, -60, -24, -2, -40, -60, -58],
        [-49, -63, -68, -58, -51, -60, -70, -53],
        [-43, -57, -64, -69, -73, -67, -63, -45],
        [-41, -49, -59, -60, -63, -52, -50, -34],
    ],
    float,
)


def _q5f(q: Question) -> Answer:
    import jax.numpy as jnp

    from gfxlab import jpeg

    coefficients = np.asarray(jpeg.dct2(jnp.asarray(_SEED_JPEG_BLOCK)))
    table = np.asarray(jpeg.LUMINANCE_TABLE)
    quantized = np.asarray(jpeg.quantize(jnp.asarray(coefficients), jnp.asarray(table))).astype(int)
    sequence = np.asarray(jpeg.zigzag(jnp.asarray(quantized))).astype(int)
    last = int(np.max(np.nonzero(sequence)[0])) if np.any(sequence) else -1
    kept = sequence[: last + 1].tolist()
    steps = (
        Step("8×8 block after the level shift (pixel - 128)", _SEED_JPEG_BLOCK),
        Step(
            "DCT-II, G(u,v) = α(u)α(v) Σ g(x,y) cos[(2x+1)uπ/16] cos[(2y+1)vπ/16] (rounded to 2 "
            "decimals)",
            coefficients.round(2),
        ),
        Step("Luminance quantization table (ITU-T T.81 Annex K, all eight rows)", table),
        Step("Quantized B(j,k) = round(G(j,k) / Q(j,k))", quantized),
        Step(
            "Zig-zag sequence up to the last non-zero coefficient, then EOB",
            ", ".join(str(v) for v in kept) + ", EOB",
            note=f"{last + 1} of 64 coefficients kept; the remaining {63 - last} zeros are "
            "replaced by a single end-of-block code.",
        ),
    )
    return Answer(
        q,
        summary=f"The DC coefficient is {coefficients[0, 0]:.2f}, quantized to {quantized[0, 0]}; "
        f"the zig-zag scan is {', '.join(str(v) for v in kept[:10])}, ... ending with EOB "
        f"after {last + 1} coefficients.",
        steps=steps,
        values={"dct": coefficients, "quantized": quantized, "zigzag": np.asarray(kept)},
        errata=(
            "The luminance table is printed with only six of its eight rows. ITU-T T.81 Table K.1 "
            "continues with 49 64 78 87 103 121 120 101 and 72 92 95 98 112 100 103 99; the "
            "quantization above uses all 64 entries.",
            "The key never shows the DCT coefficients, the quantized matrix or the zig-zag "
            "sequence it describes ('We got this result after applying.'); they are computed "
            "above.",
            "The original 8×8 pixel values are not shown, only the block after subtracting 128.",
        ),
        see_also="Lab 07 §JPEG step by step; gfxlab.jpeg.dct2, gfxlab.jpeg.quant_tables, "
        "gfxlab.jpeg.quantize, gfxlab.jpeg.zigzag, gfxlab.jpeg.encode.",
        figure=lambda: _figure_jpeg(coefficients, quantized),
    )


def _figure_jpeg(coefficients, quantized):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(11, 3.5))
    for ax, data, title in (
        (axes[0], _SEED_JPEG_BLOCK, "level-shifted block"),
        (axes[1], coefficients, "DCT coefficients"),
        (axes[2], quantized, "quantized"),
    ):
        # A diverging map centred at 0: zero is white, signs are red and blue.
        limit = float(np.max(np.abs(data))) or 1.0
        im = ax.imshow(data, cmap="RdBu_r", vmin=-limit, vmax=limit)
        ax.set_title(title)
        fig.colorbar(im, ax=ax, shrink=0.8)
    return fig


#: Numeric questions: id -> (title, question text, solver).
NUMERIC = {
    "Q5c": (
        "Median filtering",
        "Explain the concept of median filtering with an example.",
        _q5c,
    ),
    "Q5f": ("JPEG compression", "Explain the JPEG compression process in detail.", _q5f),
}

#: Descriptive questions: id -> (title, question text).
DESCRIPTIVE = {
    "Q5a": (
        "Images and file formats",
        "What is an image? Explain different file formats of an image.",
    ),
    "Q5b": ("Animation and character animation", "Explain animation with character animation."),
    "Q5d": (
        "Key-frame and procedural animation",
        "Distinguish key-frame animation from procedural animation.",
    ),
    "Q5e": ("Deformation", "Explain different types of deformation."),
}

#: Descriptive answers: id -> (summary, see also[, errata]).
ANSWERS = {
    "Q5a": (
        "An image is a two-dimensional signal: a raster image (bitmap) stores samples on a grid "
        "(pixels with one or more channels); a vector image stores geometry (lines, curves, "
        "fills) and is rasterised when shown. Formats: JPEG (lossy DCT compression, 8-bit "
        "photographs, no transparency), PNG (lossless deflate, up to 16-bit, alpha), GIF "
        "(lossless LZW, 256-colour palette, one transparent index, animation), BMP (usually "
        "uncompressed, simple), TIFF (flexible tagged container: many compressions, bit depths, "
        "pages).",
        "Lab 07 §formats (a table built from files the lab writes, and an SVG next to its "
        "rasterisation); gfxlab.image.image_info, gfxlab.image.write_image, "
        "gfxlab.image.write_svg.",
    ),
    "Q5b": (
        "Computer animation is any change of a picture over time — position, shape, colour, "
        "camera, light — shown as a sequence of frames fast enough to look continuous. "
        "Character animation gives a character believable motion and personality: a rigged "
        "skeleton drives a skinned surface, posed by key frames or motion capture and refined "
        "by the animator, following principles such as timing, anticipation and "
        "squash-and-stretch.",
        "Lab 08 §character (a 2D character with bones and a skinned outline walking from key "
        "frames, saved as video); gfxlab.animation.Skeleton, gfxlab.animation.skin.",
    ),
    "Q5d": (
        "Key-frame animation: the animator sets values at chosen times (key frames) and the "
        "computer interpolates the in-betweens (linear, spline, easing curves); full control, "
        "labour grows with the amount of motion. Procedural animation: a program (physics, "
        "rules, noise) generates the motion from initial conditions and parameters; lots of "
        "detailed motion for little work, but harder to direct.",
        "Lab 08 §key frames versus procedural (the same bouncing ball both ways); "
        "gfxlab.animation.interpolate, gfxlab.animation particle and spring simulations.",
    ),
    "Q5e": (
        "Deformers change a shape's vertices. A bone (skeleton) deformer moves each vertex with "
        "the bones that influence it: linear blend skinning v' = Σ w_i M_i v with weights "
        "summing to one (the 'candy-wrapper' collapse at large twists is its known artefact). A "
        "curve deformer bends a shape along a path: each vertex keeps its offset from the path, "
        "measured in the path's moving frame (tangent and normal).",
        "Lab 08 §deformation (skinning weights, the candy-wrapper artefact, a curve deformer); "
        "gfxlab.animation.skin, the curve deformer in gfxlab.animation.",
        (
            "The key pairs 'Curve Deformer' with 'Skinning deformation'. Skinning is the bone "
            "(skeleton) deformer's technique; a curve deformer bends a mesh along a curve.",
        ),
    ),
}
