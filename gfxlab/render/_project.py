"""From a world-space mesh and a camera to screen-space triangles.

The projection is the camera's own (`Camera.to_pixels`, `Camera.project`, built on
`gfxlab.transforms.apply`); this module only gathers the per-face quantities the
rasterizers need, decides which faces can be drawn, and builds `screen_scene`, the
screen-space triangle scene of the hidden-surface methods (`gfxlab.render.hsr`).
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._checks import (
    as_float,
    check_finite,
    check_shape,
    static_shape,
    trusted_values,
    value_error_if,
)
from ..mesh import Mesh
from ..viewing import Camera
from ._tiles import cross2, logit_limit, max_tile_count


def check_mesh_camera(mesh, camera) -> None:
    if not isinstance(mesh, Mesh):
        raise TypeError(f"`mesh` must be a gfxlab.mesh.Mesh, got {type(mesh).__name__}")
    if not isinstance(camera, Camera):
        raise TypeError(f"`camera` must be a gfxlab.viewing.Camera, got {type(camera).__name__}")


def project_faces(vertices, faces, camera: Camera, shape, *, cull_backfaces=False):
    """Screen-space faces of a mesh seen by `camera`.

    **Returns:** `(tri (F, 3, 2) pixel positions, inv_w (F, 3) inverse eye depths,
    ndc_z (F, 3), valid (F,))`. A face is drawn only when all its corners lie at or
    beyond the near plane (faces crossing it are culled: near-plane handling without
    clipping) and, with `cull_backfaces`, when it is counter-clockwise on screen
    (front-facing for outward counter-clockwise faces).
    """
    dtype = vertices.dtype
    pixels = camera.to_pixels(vertices, shape).astype(dtype)
    ndc_z = camera.project(vertices)[..., 2].astype(dtype)
    w = camera.depth(vertices).astype(dtype)  # eye-space depth
    in_front = w >= camera.near.astype(dtype)
    w_safe = jnp.where(in_front, w, 1.0)
    tri = pixels[faces]
    valid = jnp.all(in_front[faces], axis=-1)
    if cull_backfaces:
        valid = valid & (cross2(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]) > 0)
    return tri, 1.0 / w_safe[faces], ndc_z[faces], valid


def screen_scene(
    mesh: Mesh, camera: Camera, shape: tuple[int, int], *, light=None, ambient: float = 0.3
) -> tuple[Float[Array, "F 3 3"], Float[Array, "F C"]]:
    """A mesh seen by a camera as a screen-space triangle scene for the hard methods.

    **Returns:** `(triangles, colors)`: `(F, 3, 3)` corners as (pixel x, pixel y, NDC z)
    (NDC z is affine across each projected triangle, as the depth tests need; faces
    crossing the near plane become zero-area triangles at the origin, which the methods
    skip), and `(F, C)` face colours (the
    mean of the vertex colours, white if none, shaded as in `soft_rasterize`: `light` is
    None or a non-zero direction `(3,)`, `ambient` in [0, 1]).
    """
    height, width = static_shape(shape)
    check_mesh_camera(mesh, camera)
    dtype = mesh.vertices.dtype
    if light is not None:
        light = check_finite(as_float(light, "light").astype(dtype), "light")
        check_shape(light, "light", (3,))
        with jax.ensure_compile_time_eval():
            zero = jnp.all(light == 0)
        light = value_error_if(light, zero, "`light` must be a non-zero direction (3,)")
    ambient = check_finite(as_float(ambient, "ambient").astype(dtype), "ambient")
    check_shape(ambient, "ambient", ())
    with jax.ensure_compile_time_eval():
        out = (ambient < 0) | (ambient > 1)
    ambient = value_error_if(ambient, out, "`ambient` must be in [0, 1]")
    return _screen_scene(mesh, camera, light, ambient, (height, width))


@eqx.filter_jit
def _screen_scene(mesh, camera, light, ambient, shape):
    from .soft import _flat_colors  # soft imports this module

    tri, _, ndc_z, valid = project_faces(mesh.vertices, mesh.faces, camera, shape)
    scene = jnp.concatenate([tri, ndc_z[..., None]], -1)
    scene = jnp.where(valid[:, None, None], scene, 0.0)
    return scene, _flat_colors(mesh, light, ambient).mean(axis=1)


@functools.partial(jax.jit, static_argnames=("shape", "tile_size", "eps", "cull_backfaces", "axes"))
def measured_tile_count(
    vertices, faces, camera, sigma, *, shape, tile_size, eps, cull_backfaces, axes
):
    """The largest number of faces whose box, grown by the soft margin of `sigma` and
    `eps` (none where `sigma` is None), reaches one tile, over the views of a render
    (`axes`: the batch axes of `vertices` and `camera`, as `jax.vmap`'s `in_axes`).

    One compiled call: an eager `render` measures its tile capacity with it before
    compiling the render itself (op by op, the projection alone was some 30 dispatches).
    """

    def project(v, c):
        with trusted_values():  # the caller checked the mesh and the camera
            return project_faces(v, faces, c, shape, cull_backfaces=cull_backfaces)

    if axes != (None, None):
        project = jax.vmap(project, in_axes=axes)
    tri, _, _, valid = project(vertices, camera)
    margin = jnp.zeros((), tri.dtype) if sigma is None else jnp.sqrt(sigma * logit_limit(eps))
    return max_tile_count(tri, valid, margin, shape=shape, tile_size=tile_size)
