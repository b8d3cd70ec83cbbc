"""Section 1 of the course exam: displays, scan conversion, aliasing, video, clipping."""

from __future__ import annotations

import numpy as np

from ._format import cell
from ._model import Answer, Question, Step, Table


def _q1b(q: Question, *, radius: int = 10) -> Answer:
    from gfxlab import raster

    trace = np.asarray(raster.midpoint_circle_trace(radius))
    pixels = np.asarray(raster.midpoint_circle(radius))
    rows = tuple((int(k), int(p), (int(x), int(y))) for k, p, x, y in trace)
    steps = [
        Step(
            "Decision parameter",
            "p_k = f(x_k + 1, y_k - 1/2) = (x_k + 1)^2 + (y_k - 1/2)^2 - r^2; "
            "plot (x_k + 1, y_k) if p_k < 0, else (x_k + 1, y_k - 1).",
        ),
        Step(
            "Initial value for integer r",
            f"p0 = 1 - r = {1 - radius}",
            note="5/4 - r rounded; all increments are integers.",
        ),
        Step(
            "Increments",
            "p_{k+1} = p_k + 2 x_{k+1} + 1 if p_k < 0, else p_k + 2 x_{k+1} + 1 - 2 y_{k+1}",
        ),
        Step(
            f"First octant, r = {radius} (from (0, r) until x >= y)",
            Table(("k", "p_k", "(x_{k+1}, y_{k+1})"), rows),
        ),
        Step(
            "Other seven octants by symmetry",
            f"(±x, ±y) and (±y, ±x): {_count(len(pixels), 'distinct pixel')} in all.",
            note="r = 0 draws the single pixel (0, 0): no step to take." if radius == 0 else "",
        ),
    ]
    return Answer(
        q,
        summary=(
            f"Midpoint circle for r = {radius}: start at (0, {radius}) with p0 = {1 - radius}, "
            "step x by one and use the sign of p_k to choose between y_k and y_k - 1; "
            "mirror the octant eight ways."
        ),
        steps=tuple(steps),
        values={"trace": trace, "pixels": pixels, "p0": 1 - radius},
        errata=("The circle equation is printed as 'X_2+Y_2=r_2' (twice); it is x² + y² = r².",),
        see_also="Lab 01 §midpoint circle; gfxlab.raster.midpoint_circle_trace(r), "
        "gfxlab.raster.midpoint_circle(r).",
        figure=lambda: _figure_pixels(pixels, trace, radius),
    )


def _count(n: int, noun: str) -> str:
    """`n` and `noun`, plural unless `n` is 1: "1 distinct pixel", "80 distinct pixels"."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def _figure_pixels(pixels, trace, radius):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 5))
    ax.scatter(pixels[:, 0], pixels[:, 1], marker="s", s=40, c="lightgray", label="all octants")
    ax.scatter(trace[:, 2], trace[:, 3], marker="s", s=40, c="C0", label="traced octant")
    t = np.linspace(0, 2 * np.pi, 400)
    ax.plot(radius * np.cos(t), radius * np.sin(t), "C3", lw=1, label="x² + y² = r²")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Midpoint circle, r = {radius}")
    return fig


def _q1f(q: Question) -> Answer:
    import jax.numpy as jnp

    from gfxlab import clipping

    example = clipping.WALKTHROUGH_EXAMPLE
    window = np.asarray(example["window"], float)
    xmin, ymin, xmax, ymax = window
    xs, ys = (xmin - 1, (xmin + xmax) / 2, xmax + 1), (ymax + 1, (ymin + ymax) / 2, ymin - 1)
    samples = jnp.array([[x, y] for y in ys for x in xs])
    codes = np.asarray(clipping.outcode(samples, jnp.asarray(window))).reshape(3, 3)
    region_table = Table(
        ("", "left", "centre", "right"),
        tuple(
            (name, *(format(int(c), "04b") for c in row))
            for name, row in zip(("top", "middle", "bottom"), codes, strict=True)
        ),
    )
    steps = [
        Step(
            "Outcode bits (read LRBT)",
            "left = 1000 (x < xmin), right = 0100 (x > xmax), "
            "bottom = 0010 (y < ymin), top = 0001 (y > ymax)",
        ),
        Step(f"The nine regions around the window {tuple(window.tolist())}", region_table),
        Step(
            "Tests",
            "trivially accept when code0 OR code1 == 0000; trivially reject when "
            "code0 AND code1 != 0000; otherwise clip an outside endpoint against an edge "
            "whose bit it has set and repeat.",
        ),
    ]
    values = {"region_codes": codes}
    for name in ("AD", "EI"):
        step, values[name] = _clip_segment(example, window, name)
        steps.append(step)
    return Answer(
        q,
        summary=(
            "Each endpoint gets a 4-bit region code. OR = 0000 accepts the segment at once, "
            "AND != 0000 rejects it at once (both ends beyond the same edge); otherwise an "
            "outside endpoint is moved to the window edge named by one of its set bits and "
            "the tests repeat. On the exam's picture AD is clipped once (at the top edge) "
            "and EI three times."
        ),
        steps=tuple(steps),
        values=values,
        errata=(
            "The bit order is stated two ways: the prose sets first = left, second = top, third = "
            "right, fourth = bottom (LTRB), while the conditions, the stated reading order and the "
            "nine-region table use left, right, bottom, top (LRBT; top-left = 1001). LRBT is the "
            "consistent reading.",
            "The EI walkthrough's codes contradict its edges. It gives E = 0100 (right only) but "
            "clips E against the bottom edge, I = 1010 (left and bottom) but clips I against the "
            "top edge, and H = 0010 (bottom) but clips H against the right edge; an endpoint can "
            "only be clipped against an edge whose bit it has set. Coordinates that reproduce the "
            "key's sequence of edges (bottom, top, right), as above, have E = 0010 below the "
            "window, I = 0101 above and right of it, and H = 0100.",
        ),
        see_also="Lab 02 §walkthrough; gfxlab.clipping.outcode, "
        "gfxlab.clipping.cohen_sutherland_trace, gfxlab.clipping.cohen_sutherland.",
        figure=lambda: _figure_clip(example, window, values),
    )


_TRACE_COLUMNS = ("iter", "p0", "p1", "code0", "code1", "AND", "OR", "action", "edge", "new point")


def _clip_segment(example, window, name):
    """Cohen-Sutherland on the exam's segment `name` ("AD"): the step and its trace."""
    import jax.numpy as jnp

    from gfxlab import clipping

    segment = jnp.array([example[name[0]], example[name[1]]], float)
    trace = clipping.cohen_sutherland_trace(segment, jnp.asarray(window))
    rows = tuple(
        (
            i + 1,
            cell(s["p0"]),
            cell(s["p1"]),
            *(format(s[key], "04b") for key in ("code0", "code1", "and", "or")),
            s["action"],
            s["edge"] or "-",
            cell(s["new_point"]) if s["new_point"] is not None else "-",
        )
        for i, s in enumerate(trace)
    )
    title = (
        f"Segment {name}: {name[0]}{tuple(example[name[0]])} to {name[1]}{tuple(example[name[1]])}"
    )
    return Step(title, Table(_TRACE_COLUMNS, rows)), trace


def _figure_clip(example, window, values):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 5))
    xmin, ymin, xmax, ymax = window
    ax.add_patch(plt.Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False, lw=2))
    for name in ("AD", "EI"):
        a, b = np.asarray(example[name[0]], float), np.asarray(example[name[1]], float)
        ax.plot(*np.stack([a, b]).T, "C3:", lw=1)
        last = values[name][-1]
        if last["action"] == "accept":
            ax.plot(*np.asarray([last["p0"], last["p1"]]).T, "C0", lw=3)
        for label, p in ((name[0], a), (name[1], b)):
            ax.annotate(label, p, textcoords="offset points", xytext=(4, 4))
    ax.set_aspect("equal")
    ax.set_title("Cohen-Sutherland: dotted before, solid after clipping")
    return fig


#: Numeric questions: id -> (title, question text, solver).
NUMERIC = {
    "Q1b": (
        "Midpoint circle algorithm",
        "Explain the method of circle drawing using the Midpoint Circle Algorithm.",
        _q1b,
    ),
    "Q1f": (
        "Cohen-Sutherland acceptance and rejection tests",
        "Explain the acceptance and rejection test using bit codes in the Cohen-Sutherland "
        "line clipping algorithm.",
        _q1f,
    ),
}

#: Descriptive questions: id -> (title, question text).
DESCRIPTIVE = {
    "Q1a": (
        "Computer graphics and video display devices",
        "What is computer graphics? How is an image displayed on a video display device?",
    ),
    "Q1c": (
        "Active and passive graphics devices",
        "Distinguish between active and passive graphics devices.",
    ),
    "Q1d": ("Aliasing", "Explain the problems of aliasing with examples."),
    "Q1e": ("Video formats", "Explain different types of video formats."),
}

#: Descriptive answers: id -> (summary, see also[, errata]).
ANSWERS = {
    "Q1a": (
        "Computer graphics is the computation of pictures: modelling shapes, light and motion as "
        "data, and turning that data into an image. On a CRT an electron gun sends a beam, "
        "focused and deflected, onto a phosphor screen that glows where it is hit; the glow fades, "
        "so the picture is redrawn (refreshed) many times a second. A raster-scan display sweeps "
        "the beam over every scan line, left to right and top to bottom (with horizontal and "
        "vertical retrace), lighting each pixel from a frame buffer; a random-scan (vector) "
        "display steers the beam along the line segments of a display list only.",
        "Lab 01 §displays; gfxlab.raster.raster_scan, gfxlab.raster.random_scan, "
        "gfxlab.raster.phosphor_frames.",
    ),
    "Q1c": (
        "An active (interactive) graphics device lets the user change the picture while it is "
        "shown — two-way communication through mouse, keyboard, tablet or touch, with the "
        "program redrawing in response. A passive device only presents pictures the computer "
        "produces (a plotter, a slide show, a film): one-way communication, no control by the "
        "viewer.",
        "Lab 01 §active and passive devices (an ipywidgets demo driven by the user versus a fixed "
        "playback of gfxlab.raster.raster_scan frames).",
    ),
    "Q1d": (
        "Aliasing is the error of sampling a continuous picture at too few points (below twice "
        "its highest frequency): detail above the pixel grid's Nyquist limit reappears as false "
        "low-frequency patterns. It shows as (1) jagged, stair-stepped edges on lines and "
        "polygons; (2) small or thin objects rendered wrongly — vanishing or flickering between "
        "frames when they fall between pixel centres; (3) fine textures disintegrating into "
        "moiré patterns; and in time, wheels that seem to spin backwards. Cures filter before "
        "sampling: supersampling, area coverage, pre-filtered textures (mipmaps), motion blur.",
        "Lab 01 §aliasing (errors measured against a 256× supersampled reference); "
        "gfxlab.raster.supersample, gfxlab.raster.polygon_coverage, gfxlab.raster.line_coverage.",
    ),
    "Q1e": (
        "A video file is a container that interleaves compressed streams (video, audio, "
        "subtitles) with timing and index data. AVI (Microsoft, 1992) is a RIFF container of "
        "chunks; FLV is Adobe Flash's tagged stream container; WMV is Microsoft's Windows Media "
        "Video codec, usually inside an ASF container; MOV is Apple QuickTime's container of "
        "nested atoms; MP4 (MPEG-4 Part 14) is the ISO base media file format derived from it, "
        "typically with H.264/AVC or H.265 video and AAC audio. The codec compresses; the "
        "container only packages.",
        "Lab 08 §video formats (a table built from files the lab writes, with their container "
        "structure); gfxlab.animation.save_animation, gfxlab.animation.container_info.",
    ),
}
