"""Time jaxrenderer on a scene written by bench_render: `python jaxrenderer.py SCENE OUT`.

Runs in the anchor's own venv (see jaxrenderer.txt), never with gfxlab imported. SCENE
is an `.npz` (vertices, faces, vertex normals, colour, light direction, camera, image
shapes); OUT is a directory that gets, per shape, the rendered image (`image_HxW.npy`)
and the pixels the mesh covers (`covered_HxW.npy`, from a render lit by ambient light
only), in gfxlab's orientation. The light is gfxlab's: one directional light of intensity
1, diffuse only (no ambient, no specular), on a black background.

Prints one JSON line: jaxrenderer's and jax's versions and, per shape, the first call
(compile + run), the times of the forward call and of forward + backward (mean colour,
with respect to the vertices), both jitted, in seconds, and how many vertices got a
NaN gradient.
"""

import importlib.metadata
import json
import sys
import time
import warnings

warnings.filterwarnings("ignore")  # jaxtyping's notes on jaxrenderer's decorators

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import renderer as jr  # noqa: E402


def samples(fn, repeat: int) -> list:
    jax.block_until_ready(fn())
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - start)
    return times


def timed_shape(scene, height: int, width: int, repeat: int, out_dir: str) -> dict:
    vertices = jnp.asarray(scene["vertices"], jnp.float32)
    faces = jnp.asarray(scene["faces"], jnp.int32)
    normals = jnp.asarray(scene["normals"], jnp.float32)
    uvs = jnp.zeros((vertices.shape[0], 2), jnp.float32)
    texture = jnp.ones((2, 2, 3), jnp.float32) * jnp.asarray(scene["color"], jnp.float32)
    # one field of view both ways: the bench's images are square
    fov = float(np.degrees(scene["fov_y"]))
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
    # jaxrenderer samples pixel i at screen coordinate i, gfxlab at its centre i + 1/2:
    # moving the viewport by half a pixel makes both sample the same rays.
    camera = jr.Renderer.create_camera_from_parameters(camera)
    camera = jr.Camera.create(
        view=camera.view,
        projection=camera.projection,
        viewport=camera.viewport.at[:2, 3].add(-0.5),
        view_inv=camera.view_inv,
    )
    direction = np.asarray(scene["light_direction"], np.float32)
    light = jr.LightParameters(
        direction=jnp.asarray(direction / np.linalg.norm(direction)),
        ambient=jnp.zeros(3),
        diffuse=jnp.ones(3),
        specular=jnp.zeros(3),
    )

    def image(v, light=light):
        model = jr.Model.create(verts=v, norms=normals, uvs=uvs, faces=faces, diffuse_map=texture)
        return jr.Renderer.get_camera_image(
            objects=[jr.ModelObject(model=model)],
            light=light,
            camera=camera,
            width=width,
            height=height,
            colour_default=jnp.zeros(3, jnp.float32),
        )

    forward = jax.jit(image)
    step = jax.jit(jax.value_and_grad(lambda v: jnp.mean(image(v))))
    start = time.perf_counter()
    out = np.asarray(forward(vertices))
    first = time.perf_counter() - start
    _, grad = step(vertices)
    # The coverage: ambient light only, so that faces turned from the light are not black.
    flat = jr.LightParameters(
        direction=light.direction, ambient=jnp.ones(3), diffuse=jnp.zeros(3), specular=jnp.zeros(3)
    )
    covered = np.asarray(jax.jit(lambda v: image(v, flat))(vertices)).max(axis=-1) > 1e-6
    np.save(f"{out_dir}/covered_{height}x{width}.npy", covered.T[::-1])
    # jaxrenderer's canvas is (width, height) with the origin at the bottom left.
    np.save(f"{out_dir}/image_{height}x{width}.npy", out.transpose(1, 0, 2)[::-1])
    return {
        "first": first,
        "forward": samples(lambda: forward(vertices), repeat),
        "step": samples(lambda: step(vertices), repeat),
        "nan_vertices": int(np.count_nonzero(np.isnan(np.asarray(grad)).any(axis=-1))),
    }


def main(scene_path: str, out_dir: str, repeat: str = "5") -> None:
    scene = np.load(scene_path)
    result = {
        "jaxrenderer": importlib.metadata.version("jaxrenderer"),
        "jax": jax.__version__,
        "shapes": {},
    }
    for height, width in scene["shapes"]:
        timed = timed_shape(scene, int(height), int(width), int(repeat), out_dir)
        result["shapes"][f"{height}x{width}"] = timed
    print(json.dumps(result))


if __name__ == "__main__":
    main(*sys.argv[1:])
