"""Time jaxrenderer on a scene written by bench_render: `python jaxrenderer.py SCENE OUT`.

Runs in the anchor's own venv (see jaxrenderer.txt), never with gfxlab imported. SCENE
is an `.npz` (vertices, faces, vertex normals, colour, camera, image shape); OUT gets
the rendered image (`.npy`, in gfxlab's orientation). Prints one JSON line: the first
call (compile + run) and the medians of the forward call and of forward + backward
(mean colour, with respect to the vertices), both jitted, in seconds.
"""

import json
import sys
import time
import warnings

warnings.filterwarnings("ignore")  # jaxtyping's notes on jaxrenderer's decorators

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import renderer as jr  # noqa: E402


def median_time(fn, repeat: int) -> float:
    jax.block_until_ready(fn())
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main(scene_path: str, out_path: str) -> None:
    scene = np.load(scene_path)
    height, width = (int(n) for n in scene["shape"])
    vertices = jnp.asarray(scene["vertices"], jnp.float32)
    faces = jnp.asarray(scene["faces"], jnp.int32)
    normals = jnp.asarray(scene["normals"], jnp.float32)
    uvs = jnp.zeros((vertices.shape[0], 2), jnp.float32)
    texture = jnp.ones((2, 2, 3), jnp.float32) * jnp.asarray(scene["color"], jnp.float32)
    fov = float(np.degrees(scene["fov_y"]))  # square image: the same both ways
    camera = jr.CameraParameters(
        viewWidth=width,
        viewHeight=height,
        near=float(scene["near"]),
        far=float(scene["far"]),
        hfov=fov,
        vfov=fov,
        position=jnp.asarray(scene["eye"], jnp.float32),
        target=jnp.asarray(scene["target"], jnp.float32),
        up=jnp.asarray(scene["up"], jnp.float32),
    )
    light = jr.LightParameters()

    def image(v):
        model = jr.Model.create(verts=v, norms=normals, uvs=uvs, faces=faces, diffuse_map=texture)
        return jr.Renderer.get_camera_image(
            objects=[jr.ModelObject(model=model)],
            light=light,
            camera=camera,
            width=width,
            height=height,
        )

    forward = jax.jit(image)
    step = jax.jit(jax.value_and_grad(lambda v: jnp.mean(image(v))))
    start = time.perf_counter()
    out = np.asarray(forward(vertices))
    first = time.perf_counter() - start
    result = {
        "jax": jax.__version__,
        "first": first,
        "forward": median_time(lambda: forward(vertices), 5),
        "step": median_time(lambda: step(vertices), 3),
    }
    # jaxrenderer's canvas is (width, height) with the origin at the bottom left.
    np.save(out_path, out.transpose(1, 0, 2)[::-1])
    print(json.dumps(result))


if __name__ == "__main__":
    main(*sys.argv[1:])
