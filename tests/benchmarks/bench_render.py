"""Renderer speed: the pose step of issue 18, 10k faces, and a dense SoftRas reference.

`python tests/benchmarks/run.py render` (or `make bench BENCH=render`). float32, the
default settings (8x8 tiles, capacity measured from the geometry). Rows:

- pose step: `render` (soft, sigma = 1 px^2) of the 800-face pawn at 256x256, a loss on
  colour and silhouette, differentiated with respect to a pose angle; forward and
  forward + backward, and the backward / forward ratio;
- the same step with the dense SoftRas formula (every pixel against every face, no
  bins): the reference for the soft path, same numbers to rounding;
- 10,000 random faces at 256x256, forward + backward (vertices);
- the shipped 1,600-face pawn rendered eagerly with all defaults.

- the hard (z-buffer) path against `jaxrenderer` 0.3.2, the JAX rasterizer on PyPI:
  the 800-face pawn at 256x256 lit by one directional light, forward and forward +
  backward (mean colour, with respect to the vertices), both jitted. jaxrenderer pins
  jax < 0.5 and numpy < 2, so it runs in a pinned venv of its own
  (`.venv-anchors/jaxrenderer`, made by `make anchors`, which `make bench` runs), in a
  subprocess after our timings; the silhouettes' IoU shows that both drew the same view.
"""

from __future__ import annotations

import json
import math
import pathlib
import subprocess
import tempfile
import time

import jax
import jax.numpy as jnp
import numpy as np
from harness import Table, timeit

from gfxlab import render as R
from gfxlab import transforms as tf
from gfxlab.mesh import Mesh, pawn, read_obj, shipped_model_path
from gfxlab.viewing import Camera

ANCHOR_PYTHON = pathlib.Path(__file__).parents[2] / ".venv-anchors/jaxrenderer/bin/python"
ANCHOR_SCRIPT = pathlib.Path(__file__).parent / "anchors/jaxrenderer.py"

SHAPE = (256, 256)
SIGMA, GAMMA = 1.0, 0.05


def pose_problem():
    model = pawn(segments=16).with_colors(jnp.array([0.85, 0.75, 0.55], jnp.float32))
    camera = Camera(
        jnp.array([0.0, 1.0, 5.0]), jnp.array([0.0, 1.0, 0.0]), fov_y=0.6, near=1.0, far=20.0
    )
    target = R.render(model, camera, SHAPE, sigma=SIGMA, gamma=GAMMA).alpha
    capacity = R.tile_capacity(model, camera, SHAPE, sigma=SIGMA, slack=1.2)

    def loss(angle, binned=True):
        vertices = tf.apply(tf.rotate_y(angle), model.vertices)
        if binned:
            r = R.render(
                model, camera, SHAPE, vertices=vertices, sigma=SIGMA, gamma=GAMMA, capacity=capacity
            )
            color, alpha = r.color, r.alpha
        else:  # dense SoftRas formula: every face in every tile, no bins
            moved = Mesh(vertices, model.faces, model.colors)
            tri, inv, col, valid = R._project_mesh(moved, camera, SHAPE, None, 0.3)
            params = (
                jnp.float32(SIGMA),
                jnp.float32(GAMMA),
                camera.near,
                camera.far,
                jnp.zeros(3, jnp.float32),
                jnp.float32(1e-3),
            )
            out, _ = R._color_core(
                tri,
                inv,
                col,
                valid,
                params,
                shape=SHAPE,
                eps=1e-4,
                tile_size=8,
                capacity=model.num_faces,
                tiles_per_step=16,
                binned=False,
            )
            color, alpha = out[..., :3], out[..., 3]
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


def hard_path_rows() -> None:
    """Our hard path against jaxrenderer's on the pawn (see the module docstring)."""
    table = Table("hard render (z-buffer), 256x256, float32, jitted", "jaxrenderer 0.3.2")
    model, _, _ = pose_problem()
    eye, target = np.array([0.0, 1.0, 5.0]), np.array([0.0, 1.0, 0.0])
    camera = Camera(jnp.asarray(eye), jnp.asarray(target), fov_y=0.6, near=1.0, far=20.0)
    light = R.DirectionalLight(jnp.array([0.0, 0.0, 1.0]))
    capacity = R.tile_capacity(model, camera, SHAPE, sigma=SIGMA)

    def rendering(vertices):
        return R.render(
            model, camera, SHAPE, vertices=vertices, mode="hard", lights=[light], capacity=capacity
        )

    forward = jax.jit(lambda v: rendering(v).color)
    step = jax.jit(jax.value_and_grad(lambda v: jnp.mean(rendering(v).color)))
    t_forward = timeit(lambda: forward(model.vertices), repeat=5)
    t_step = timeit(lambda: step(model.vertices), repeat=3)
    ours = np.asarray(jax.jit(lambda v: rendering(v).alpha)(model.vertices)) > 0.5
    label = f"{model.num_faces}-face pawn, one directional light"
    if not ANCHOR_PYTHON.exists():
        table.add(f"{label}, forward", t_forward, None, "anchor not installed: `make anchors`")
        table.add(f"{label}, forward + backward", t_step, None)
        table.print()
        return
    with tempfile.TemporaryDirectory() as tmp:
        scene = pathlib.Path(tmp) / "scene.npz"
        image = pathlib.Path(tmp) / "image.npy"
        np.savez(
            scene,
            shape=np.array(SHAPE),
            vertices=np.asarray(model.vertices),
            faces=np.asarray(model.faces),
            normals=np.asarray(model.vertex_normals()),
            color=np.asarray(model.colors[0]),
            fov_y=0.6,
            near=1.0,
            far=20.0,
            eye=eye,
            target=target,
            up=np.array([0.0, 1.0, 0.0]),
        )
        run = subprocess.run(
            [str(ANCHOR_PYTHON), str(ANCHOR_SCRIPT), str(scene), str(image)],
            capture_output=True,
            text=True,
            check=False,
        )
        if run.returncode != 0:
            table.add(f"{label}, forward", t_forward, None, "jaxrenderer failed, see below")
            table.print()
            print(run.stderr[-2000:])
            return
        times = json.loads(run.stdout.strip().splitlines()[-1])
        theirs = np.any(np.abs(np.load(image) - 1.0) > 1e-6, axis=-1)  # white background
    iou = np.count_nonzero(ours & theirs) / np.count_nonzero(ours | theirs)
    table.add(
        f"{label}, forward",
        t_forward,
        times["forward"],
        f"silhouette IoU {iou:.3f}; jaxrenderer's first call {times['first']:.1f} s "
        f"(jax {times['jax']})",
    )
    table.add(f"{label}, forward + backward (vertices)", t_step, times["step"])
    table.print()
    print(flush=True)


def main() -> None:
    table = Table("render, 256x256, float32, forward + backward", "dense SoftRas formula")
    model, capacity, loss = pose_problem()
    angle = jnp.float32(0.1)
    forward = jax.jit(loss)
    step = jax.jit(jax.value_and_grad(loss))
    t_fwd = timeit(lambda: forward(angle), repeat=5)
    t_step = timeit(lambda: step(angle), repeat=5)
    dense = jax.jit(jax.value_and_grad(lambda a: loss(a, binned=False)))
    dense = dense.lower(angle).compile()
    start = time.perf_counter()
    ref_value, ref_grad = jax.block_until_ready(dense(angle))
    t_dense = time.perf_counter() - start
    value, grad = step(angle)
    table.add(
        f"pose step, {model.num_faces}-face pawn, sigma 1",
        t_step,
        t_dense,
        f"forward {t_fwd * 1e3:.0f} ms, backward/forward {(t_step - t_fwd) / t_fwd:.1f}x, "
        f"capacity {capacity}; value diff {abs(float(value - ref_value)):.1e}, grad "
        f"{float(grad):.4g} vs {float(ref_grad):.4g}",
    )
    print(f"pose step {t_step * 1e3:.0f} ms (forward {t_fwd * 1e3:.0f} ms)", flush=True)

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
