"""From a world-space mesh and a camera to screen-space triangles.

The projection is the camera's own (`Camera.to_pixels`, `Camera.project`, built on
`gfxlab.transforms.apply`); this module only gathers the per-face quantities the
rasterizers need and decides which faces can be drawn.
"""

from __future__ import annotations

import jax.numpy as jnp

from ..mesh import Mesh
from ..viewing import Camera
from ._tiles import cross2


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
