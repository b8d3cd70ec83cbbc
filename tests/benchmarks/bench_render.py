"""Renderer speed: the pose step of issue 18, 10k faces, and two anchors.

`python tests/benchmarks/run.py render` (or `make bench BENCH=render`). float32, the
default settings (8x8 tiles, capacity measured from the geometry). Rows:

- pose step: `render` (soft, sigma = 1 px^2) of the 800-face pawn at 256x256, a loss on
  colour and silhouette, differentiated with respect to a pose angle; forward and
  forward + backward, and the backward / forward ratio; against `render_dense`, the
  dense SoftRas formula (every pixel against every face, no tiles, plain autodiff):
  the reference for the soft path, the same numbers to rounding. Its gradient holds
  every pixel x face pair (~13 GB at 256x256): on a machine with less than 20 GiB the
  row runs at 128x128 instead, and says so;
- 10,000 random faces at 256x256, forward + backward (vertices);
- the shipped 1,600-face pawn rendered eagerly with all defaults;
- the hard (z-buffer) path against `jaxrenderer`, the JAX rasterizer on PyPI: the
  800-face pawn tilted about the view axis, fixed vertex normals, one directional light,
  at 64x64 and 256x256; forward and forward + backward (mean colour, with respect to the
  vertices), both jitted; medians and min-max spread, first calls, whether each side's
  gradient is finite (jaxrenderer's is NaN at some vertices: flagged), and a match
  check (silhouette IoU >= 0.95, also against the mirror image; mean colour difference
  where both drew the pawn <= 0.03). jaxrenderer pins jax < 0.5 and numpy < 2, so it
  runs in a pinned venv of its own (`.venv-anchors/jaxrenderer`, made by `make
  anchors`, which `make bench` runs; jaxlib 0.4.13 has wheels up to Python 3.11), in a
  subprocess before and after our timings.
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import statistics
import subprocess
import tempfile
import time

import jax
import jax.numpy as jnp
import numpy as np
from harness import Table, samples, timeit, timeit_pair

from gfxlab import render as R
from gfxlab import transforms as tf
from gfxlab.mesh import Mesh, pawn, read_obj, shipped_model_path
from gfxlab.viewing import Camera

ANCHOR_PYTHON = pathlib.Path(__file__).parents[2] / ".venv-anchors/jaxrenderer/bin/python"
ANCHOR_SCRIPT = pathlib.Path(__file__).parent / "anchors/jaxrenderer.py"

SHAPE = (256, 256)
SIGMA, GAMMA = 1.0, 0.05
DENSE_MEMORY = 20 * 2**30  # bytes the dense 256² reference needs with room to spare


def pose_problem(shape=SHAPE):
    model = pawn(segments=16).with_colors(jnp.array([0.85, 0.75, 0.55], jnp.float32))
    camera = Camera(
        jnp.array([0.0, 1.0, 5.0]), jnp.array([0.0, 1.0, 0.0]), fov_y=0.6, near=1.0, far=20.0
    )
    target = R.render(model, camera, shape, sigma=SIGMA, gamma=GAMMA).alpha
    capacity = R.tile_capacity(model, camera, shape, sigma=SIGMA, slack=1.2)

    def loss(angle, binned=True):
        vertices = tf.apply(tf.rotate_y(angle), model.vertices)
        if binned:
            r = R.render(
                model, camera, shape, vertices=vertices, sigma=SIGMA, gamma=GAMMA, capacity=capacity
            )
            color, alpha = r.color, r.alpha
        else:  # the dense SoftRas formula: every pixel against every face, no bins
            r = R.render_dense(model, camera, shape, vertices=vertices, sigma=SIGMA, gamma=GAMMA)
            color, alpha = r.color, r.alpha
        return jnp.mean((alpha - target) ** 2) + jnp.mean(color)

    return model, capacity, loss


def random_scene(faces: int, coverage: float = 0.5, seed: int = 0):
    """`faces` random triangles of equal area covering `coverage` of the screen in total."""
    rng = np.random.default_rng(seed)
    camera = Camera(jnp.array([0.0, 0.0, 4.0]), fov_y=0.5, near=1.0, far=10.0)
    half = 4.0 * math.tan(0.25)
    area = coverage * (2 * half) ** 2 / faces
    radius = math.sqrt(area / (0.75 * math.sqrt(3)))
    angle = rng.uniform(0, 2 * np.pi, (faces, 1)) + np.array([0, 2, 4]) * np.pi / 3
    centre = rng.uniform(-half, half, (faces, 1, 2))
    xy = centre + radius * np.stack([np.cos(angle), np.sin(angle)], -1)
    z = rng.uniform(-0.5, 0.5, (faces, 1, 1)) * np.ones((1, 3, 1))
    vertices = np.concatenate([xy, z], -1).reshape(-1, 3).astype(np.float32)
    colors = rng.uniform(0, 1, vertices.shape).astype(np.float32)
    return Mesh(jnp.asarray(vertices), jnp.arange(3 * faces).reshape(faces, 3), colors), camera


HARD_SHAPES = ((64, 64), (256, 256))
HARD_EYE, HARD_TARGET, HARD_UP = (0.0, 1.0, 5.0), (0.0, 1.0, 0.0), (0.0, 1.0, 0.0)
HARD_LIGHT = (0.4, 0.5, 1.0)


def hard_scene():
    """The 800-face pawn tilted about the view axis (so that a mirrored image is told
    apart), with fixed vertex normals that both renderers interpolate."""
    model, _, _ = pose_problem()
    vertices = tf.apply(tf.rotate_z(0.35), model.vertices)
    tilted = Mesh(vertices, model.faces, model.colors)
    normals = tilted.vertex_normals()
    mesh = Mesh(vertices, model.faces, model.colors, normals=normals, normal_faces=model.faces)
    camera = Camera(jnp.asarray(HARD_EYE), jnp.asarray(HARD_TARGET), fov_y=0.6, near=1.0, far=20.0)
    return mesh, camera


def run_anchor(mesh: Mesh, tmp: pathlib.Path, repeat: int) -> dict:
    """jaxrenderer on the scene, in its own venv; its JSON, or {"error": stderr}."""
    scene = tmp / "scene.npz"
    np.savez(
        scene,
        shapes=np.array(HARD_SHAPES),
        vertices=np.asarray(mesh.vertices),
        faces=np.asarray(mesh.faces),
        normals=np.asarray(mesh.normals),
        color=np.asarray(mesh.colors[0]),
        light_direction=np.array(HARD_LIGHT),
        fov_y=0.6,
        near=1.0,
        far=20.0,
        eye=np.array(HARD_EYE),
        target=np.array(HARD_TARGET),
        up=np.array(HARD_UP),
    )
    run = subprocess.run(
        [str(ANCHOR_PYTHON), str(ANCHOR_SCRIPT), str(scene), str(tmp), str(repeat)],
        capture_output=True,
        text=True,
        check=False,
    )
    if run.returncode != 0:
        return {"error": run.stderr[-2000:]}
    return json.loads(run.stdout.strip().splitlines()[-1])


def spread(times: list[float]) -> str:
    return f"{min(times) * 1e3:.1f}-{max(times) * 1e3:.1f} ms"


def hard_path_rows() -> None:
    """Our hard path against jaxrenderer's on the tilted pawn (see the module docstring).

    Order: jaxrenderer, ours, jaxrenderer again (so that a machine that slows down or
    speeds up during the run shows as a spread, not as a ratio); medians of both anchor
    runs' samples.
    """
    mesh, camera = hard_scene()
    light = R.DirectionalLight(jnp.asarray(HARD_LIGHT))
    installed = ANCHOR_PYTHON.exists()
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = pathlib.Path(tmp_name)
        before = run_anchor(mesh, tmp, repeat=5) if installed else {}
        ours = {}
        for shape in HARD_SHAPES:
            capacity = R.tile_capacity(mesh, camera, shape, sigma=None)

            def rendering(vertices, shape=shape, capacity=capacity):
                return R.render(
                    mesh,
                    camera,
                    shape,
                    vertices=vertices,
                    mode="hard",
                    lights=[light],
                    capacity=capacity,
                )

            forward = jax.jit(lambda v, rendering=rendering: rendering(v).color)
            step = jax.jit(jax.value_and_grad(lambda v, r=rendering: jnp.mean(r(v).color)))
            start = time.perf_counter()
            jax.block_until_ready(forward(mesh.vertices))
            first = time.perf_counter() - start
            _, grad = step(mesh.vertices)
            image = jax.jit(rendering)(mesh.vertices)
            ours[shape] = {
                "first": first,
                "forward": samples(lambda f=forward: f(mesh.vertices), repeat=5),
                "step": samples(lambda s=step: s(mesh.vertices), repeat=5),
                "finite": bool(np.isfinite(np.asarray(grad)).all()),
                "capacity": capacity,
                "color": np.asarray(image.color),
                "alpha": np.asarray(image.alpha),
            }
        after = run_anchor(mesh, tmp, repeat=5) if installed else {}
        theirs = {}
        for shape in HARD_SHAPES:
            key = f"{shape[0]}x{shape[1]}"
            if key in before.get("shapes", {}) and key in after.get("shapes", {}):
                theirs[shape] = {
                    **after["shapes"][key],
                    "forward": before["shapes"][key]["forward"] + after["shapes"][key]["forward"],
                    "step": before["shapes"][key]["step"] + after["shapes"][key]["step"],
                    "first": before["shapes"][key]["first"],
                    "image": np.load(tmp / f"image_{key}.npy"),
                    "covered": np.load(tmp / f"covered_{key}.npy"),
                }
    versions = f"ours: jax {jax.__version__}"
    if theirs:
        versions += f"; jaxrenderer {before['jaxrenderer']} on jax {before['jax']}"
    table = Table(f"hard render (z-buffer), float32, jitted ({versions})", "jaxrenderer")
    label = f"{mesh.num_faces}-face pawn, tilted, one directional light"
    for shape in HARD_SHAPES:
        size = f"{shape[0]}x{shape[1]}"
        mine = ours[shape]
        grad_note = "gradient finite" if mine["finite"] else "OUR GRADIENT HAS NaN/inf"
        notes = [
            f"ours {spread(mine['forward'])}, first call {mine['first']:.2f} s, "
            f"capacity {mine['capacity']}"
        ]
        step_notes = [f"ours {spread(mine['step'])}, {grad_note}"]
        other = theirs.get(shape)
        if other is None:
            reason = before.get("error") or after.get("error") or "not installed: `make anchors`"
            notes.append(f"jaxrenderer {reason.strip().splitlines()[-1] if reason else ''}")
            forward_ref = step_ref = None
        else:
            match = compare_images(mine["color"], mine["alpha"], other["image"], other["covered"])
            notes.append(f"theirs {spread(other['forward'])}, first call {other['first']:.1f} s")
            notes.append(match)
            step_notes.append(f"theirs {spread(other['step'])}")
            if other["nan_vertices"]:
                step_notes.append(
                    f"FLAG: jaxrenderer's gradient is NaN at {other['nan_vertices']} of "
                    f"{mesh.num_vertices} vertices"
                )
            forward_ref = statistics.median(other["forward"])
            step_ref = statistics.median(other["step"])
        table.add(
            f"{label}, {size}, forward",
            statistics.median(mine["forward"]),
            forward_ref,
            "; ".join(notes),
        )
        table.add(
            f"{label}, {size}, forward + backward (mean colour, vertices)",
            statistics.median(mine["step"]),
            step_ref,
            "; ".join(step_notes),
        )
    table.print()
    print(
        "\nThe gap is algorithmic: jaxrenderer tests every pixel against every face "
        "(O(pixels x faces)); ours bins faces into 8x8 tiles and tests each pixel against "
        "its tile's faces only.",
        flush=True,
    )
    if theirs:
        print(
            "Shading differs by design: ours is two-sided Lambert with pi * f = 1 "
            "(a back-facing normal is flipped), theirs max(n . l, 0). jaxrenderer samples "
            "pixel corners: its viewport is moved by half a pixel to sample our pixel "
            "centres. Most silhouette pixels that differ are edge pixels and the pawn's "
            "thin bottom lip, whose faces face the camera but whose vertex normals "
            "(shared with the bottom disc) point away: we draw it, jaxrenderer does not.",
            flush=True,
        )


def compare_images(color, alpha, theirs, covered, *, iou_min=0.95, color_max=0.03) -> str:
    """Silhouette IoU of our hard image against jaxrenderer's coverage (and against its
    mirror image, to show that the tilt tells the two apart), and the mean colour difference
    where both drew the pawn; a verdict against the thresholds."""
    ours = alpha > 0.5

    def iou(a, b):
        return np.count_nonzero(a & b) / max(np.count_nonzero(a | b), 1)

    both = ours & covered
    color_diff = float(np.mean(np.abs(color[both] - theirs[both]))) if both.any() else math.inf
    same, mirrored = iou(ours, covered), iou(ours, covered[:, ::-1])
    verdict = "match" if same >= iou_min and color_diff <= color_max else "MISMATCH"
    return (
        f"{verdict}: silhouette IoU {same:.3f} (>= {iou_min}; mirrored {mirrored:.3f}), "
        f"mean |colour diff| {color_diff:.4f} (<= {color_max})"
    )


def physical_memory() -> float:
    """This machine's physical memory in bytes (0 where it cannot be read)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0.0


def pose_step_row(table: Table, shape) -> None:
    """Our pose step against the dense SoftRas formula at `shape`, in one row."""
    model, capacity, loss = pose_problem(shape)
    angle = jnp.float32(0.1)
    forward = jax.jit(loss)
    step = jax.jit(jax.value_and_grad(loss))
    # alternately, so that the backward / forward ratio sees one machine state
    t_fwd, t_step = timeit_pair(lambda: forward(angle), lambda: step(angle), repeat=15)
    dense = jax.jit(jax.value_and_grad(lambda a: loss(a, binned=False)))
    ref_value, ref_grad = jax.block_until_ready(dense(angle))  # compiles
    t_dense = timeit(lambda: dense(angle), repeat=3, warmup=0)
    value, grad = step(angle)
    table.add(
        f"pose step, {model.num_faces}-face pawn, {shape[0]}x{shape[1]}, sigma 1",
        t_step,
        t_dense,
        f"forward {t_fwd * 1e3:.0f} ms, backward/forward {(t_step - t_fwd) / t_fwd:.1f}x, "
        f"capacity {capacity}; value diff {abs(float(value - ref_value)):.1e}, grad "
        f"{float(grad):.4g} vs {float(ref_grad):.4g}",
    )
    print(f"pose step {shape}: {t_step * 1e3:.0f} ms (forward {t_fwd * 1e3:.0f} ms)", flush=True)


def main() -> None:
    table = Table("soft render, float32, forward + backward", "dense SoftRas formula")
    # The dense reference holds every pixel x face pair: ~13 GB for its gradient at 256².
    if physical_memory() >= DENSE_MEMORY:
        pose_step_row(table, SHAPE)
    else:
        print(
            f"this machine has {physical_memory() / 2**30:.0f} GiB: the dense reference "
            f"runs at 128x128, not {SHAPE[0]}x{SHAPE[1]}",
            flush=True,
        )
        pose_step_row(table, (128, 128))

    mesh, camera = random_scene(10_000)
    cap = R.tile_capacity(mesh, camera, SHAPE, sigma=SIGMA)

    def loss10k(vertices):
        r = R.render(mesh, camera, SHAPE, vertices=vertices, sigma=SIGMA, gamma=GAMMA, capacity=cap)
        return jnp.mean(r.color) + jnp.mean(r.alpha)

    step10k = jax.jit(jax.value_and_grad(loss10k))
    t10k = timeit(lambda: step10k(mesh.vertices), repeat=3)
    table.add("10,000 random faces (50 % coverage)", t10k, None, f"capacity {cap}")
    print(f"10k faces {t10k * 1e3:.0f} ms", flush=True)

    shipped = read_obj(shipped_model_path("pawn.obj"))
    camera = Camera(jnp.array([2.2, 2.4, 4.2]), jnp.array([0.0, 0.95, 0.0]), fov_y=0.6)
    eager = timeit(lambda: R.render(shipped, camera, SHAPE).color, repeat=3)
    found = R.tile_capacity(shipped, camera, SHAPE, sigma=SIGMA)
    table.add(
        f"shipped {shipped.num_faces}-face pawn, eager call, defaults",
        eager,
        None,
        f"forward only; capacity found automatically: {found}",
    )
    table.print()
    print(flush=True)
    hard_path_rows()


if __name__ == "__main__":
    main()
