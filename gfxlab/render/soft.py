"""Soft rasterization (SoftRas): the differentiable silhouette and the flat-shaded colour.

Each face `j` gives every pixel a probability `D_j = sigmoid(sign * d^2 / sigma)`, where
`d` is the distance from the pixel centre to the projected triangle and `sign` is +1
inside, -1 outside. The silhouette is `A = 1 - prod_j (1 - D_j)`; the colour is a
softmax over faces weighted by `D_j` and by their normalised inverse depth `z_j` with
temperature `gamma`, plus a background term:

    w_j = D_j exp(z_j / gamma) / (sum_k D_k exp(z_k / gamma) + exp(eps_bg / gamma)).

`sigma` is in pixels^2 and all distances are in pixels (y up, pixel centres on
integers, as in `gfxlab.raster`), so the look does not change with resolution. A face whose
probability at a pixel is below `eps` is dropped there, which makes each face's reach
finite (a margin of `sqrt(sigma * log(1 / eps - 1))` pixels), so the image is cut into
tiles that only see the faces binned into them (see `_tiles`).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from .._checks import (
    as_float,
    check_finite,
    check_shape,
    positive,
    safe_normalize,
    static_shape,
)
from ..mesh import Mesh, face_normals
from ..viewing import Camera
from ._inputs import check_render_inputs, silhouette_inputs
from ._project import check_mesh_camera, measured_tile_count, project_faces
from ._tiles import (
    any_traced,
    check_capacity,
    check_options,
    logit_limit,
    pixel_face_terms,
    resolve_capacity,
    round_capacity,
    tiled,
)

__all__ = [
    "soft_silhouette",
    "soft_silhouette_dense",
    "soft_rasterize",
    "soft_rasterize_dense",
    "tile_capacity",
]


def _silhouette_pixels(points, tri, slot_mask, sigma, eps):
    d2, inside, _ = pixel_face_terms(points, tri)
    keep = slot_mask[None] & (inside | (d2 <= sigma * logit_limit(eps)))
    x = jnp.where(inside, d2, -d2) / sigma
    log_miss = jnp.sum(jnp.where(keep, jax.nn.log_sigmoid(-x), 0.0), axis=-1)
    return -jnp.expm1(log_miss)


def _color_pixels(points, faces, slot_mask, params):
    tri, inv_depth, colors = faces  # (K,3,2), (K,3), (K,3,C)
    sigma, gamma, eps, near, far, background, eps_bg = params
    d2, inside, bary = pixel_face_terms(points, tri)
    keep = slot_mask[None] & (inside | (d2 <= sigma * logit_limit(eps)))
    x = jnp.where(inside, d2, -d2) / sigma
    # 0.0 - x, not -x: where no face reaches, +0.0 rather than -0.0
    alpha = 0.0 - jnp.expm1(jnp.sum(jnp.where(keep, jax.nn.log_sigmoid(-x), 0.0), axis=-1))
    # perspective-correct depth: inverse depth is affine in screen space
    inv = jnp.sum(bary * inv_depth[None], -1)
    depth = 1.0 / jnp.where(keep, inv, 1.0)
    z = (far - depth) / (far - near)
    logits = jnp.where(keep, jax.nn.log_sigmoid(x) + z / gamma, -jnp.inf)
    logits = jnp.concatenate([logits, jnp.broadcast_to(eps_bg / gamma, (logits.shape[0], 1))], 1)
    weights = jax.nn.softmax(logits, axis=-1)
    color = jnp.einsum("pk,pkc->pc", weights[:, :-1], jnp.einsum("pkv,kvc->pkc", bary, colors))
    color = color + weights[:, -1:] * background
    out_depth = jnp.sum(weights[:, :-1] * depth, -1) + weights[:, -1] * far
    return jnp.concatenate([color, alpha[:, None], out_depth[:, None]], axis=-1)


def soft_silhouette(
    vertices_2d: Float[Array, "V 2"],
    faces: Int[Array, "F 3"],
    shape: tuple[int, int],
    *,
    sigma: float | Float[Array, ""],
    eps: float = 1e-4,
    tile_size: int = 8,
    capacity: int | None = None,
    tiles_per_step: int = 16,
) -> Float[Array, "H W"]:
    """The soft silhouette `A = 1 - prod_j (1 - D_j)` of 2D triangles.

    **Arguments:**

    - `vertices_2d`: `(V, 2)` finite vertex positions in pixel coordinates (y up, pixel
      centres on integers); NaN or infinite positions are an error.
    - `faces`: `(F, 3)` integer vertex indices.
    - `shape`: image shape `(H, W)` (static).
    - `sigma`: sharpness in pixels^2 (finite, > 0); small is sharp.
    - `eps`: probability below which a face is dropped at a pixel (sets the bin margin).
    - `tile_size`, `capacity`: tiles of `tile_size^2` pixels see at most `capacity`
      faces each. `None` (default) measures it from the geometry (eager calls); an
      explicit capacity that an eager call overflows is grown with a warning; under
      `jax.jit` pass one (`tile_capacity`) and an overflow is an error naming it
      (inside `gfxlab.fit`, it is grown and the fit's steps rerun).
    - `tiles_per_step`: tiles evaluated together (memory vs. speed).

    **Returns:** `(H, W)` coverage in [0, 1].
    """
    return _silhouette(vertices_2d, faces, shape, sigma, eps, (tile_size, capacity, tiles_per_step))


def soft_silhouette_dense(
    vertices_2d: Float[Array, "V 2"],
    faces: Int[Array, "F 3"],
    shape: tuple[int, int],
    *,
    sigma: float | Float[Array, ""],
    eps: float = 1e-4,
) -> Float[Array, "H W"]:
    """`soft_silhouette` with every pixel against every face in one step: the O(P·F)
    reference (`P` pixels, `F` faces).

    No tiles, no bins, and plain autodiff instead of the tiles' custom VJP: the values
    and gradients the tiled `soft_silhouette` must reproduce. Time and memory grow with
    `P * F`: for small images and scenes (tests, teaching).

    **Arguments:** `vertices_2d`, `faces`, `shape`, `sigma`, `eps` as in
    `soft_silhouette`.

    **Returns:** `(H, W)` coverage in [0, 1].
    """
    return _silhouette(vertices_2d, faces, shape, sigma, eps, (8, None, 1), reference=True)


def _silhouette(vertices_2d, faces, shape, sigma, eps, sizes, *, reference=False):
    """The checks of `soft_silhouette`(`_dense`) and the call of the jitted core."""
    (height, width), vertices_2d, faces, sigma = silhouette_inputs(vertices_2d, faces, shape, sigma)
    sigma, tile_size, capacity, tiles_per_step = check_options(sigma, eps, *sizes)
    tri = vertices_2d[faces]
    if reference:
        capacity = max(faces.shape[0], 1)  # unused: no tiles
    capacity = resolve_capacity(
        capacity,
        tri,
        jnp.ones(tri.shape[0], bool),
        jnp.sqrt(sigma * logit_limit(eps)),
        (height, width),
        tile_size,
        any_traced(vertices_2d, sigma),
    )
    image, max_count = _silhouette_core(
        vertices_2d,
        faces,
        sigma,
        shape=(height, width),
        eps=float(eps),
        tile_size=tile_size,
        capacity=capacity,
        tiles_per_step=tiles_per_step,
        reference=reference,
    )
    return check_capacity(image, max_count, capacity, tile_size, faces.shape[0])


def _silhouette_kernel(points, tri, slot_mask, ids, sigma, *, eps):
    return _silhouette_pixels(points, tri, slot_mask, sigma, eps)[:, None]


def _color_kernel(points, faces, slot_mask, ids, params, *, eps):
    sigma, gamma, near, far, background, eps_bg = params
    full = (sigma, gamma, eps, near, far, background, eps_bg)
    return _color_pixels(points, faces, slot_mask, full)


@functools.partial(
    jax.jit,
    static_argnames=(
        "shape",
        "eps",
        "tile_size",
        "capacity",
        "tiles_per_step",
        "binned",
        "reference",
    ),
)
def _silhouette_core(
    vertices_2d,
    faces,
    sigma,
    *,
    shape,
    eps,
    tile_size,
    capacity,
    tiles_per_step,
    binned=True,
    reference=False,
):
    tri = vertices_2d[faces]
    valid = jnp.ones(tri.shape[0], bool)
    margin = jnp.sqrt(sigma * logit_limit(eps))
    image, max_count = tiled(
        functools.partial(_silhouette_kernel, eps=eps),
        tri,
        valid,
        tri,
        sigma,
        shape,
        margin=margin,
        tile_size=tile_size,
        capacity=capacity,
        tiles_per_step=tiles_per_step,
        binned=binned,
        reference=reference,
    )
    return image[..., 0], max_count


def _flat_colors(mesh: Mesh, light, ambient):
    vertices, faces = mesh.vertices, mesh.faces
    colors = mesh.colors if mesh.colors is not None else jnp.ones_like(vertices)
    corner_colors = colors[faces]
    if light is not None:
        light = as_float(light, "light").astype(vertices.dtype)
        check_shape(light, "light", (3,))
        direction = safe_normalize(light)
        lambert = jnp.abs(face_normals(vertices, faces) @ direction)  # two-sided
        corner_colors = corner_colors * (ambient + (1 - ambient) * lambert)[:, None, None]
    return corner_colors


def _project_mesh(mesh: Mesh, camera: Camera, shape, light, ambient):
    check_mesh_camera(mesh, camera)
    tri, inv_w, _, valid = project_faces(mesh.vertices, mesh.faces, camera, shape)
    return tri, inv_w, _flat_colors(mesh, light, ambient), valid


def tile_capacity(
    mesh: Mesh,
    camera: Camera,
    shape: tuple[int, int],
    *,
    sigma: float | Float[Array, ""] | None,
    eps: float = 1e-4,
    tile_size: int = 8,
    slack: float = 1.0,
) -> int:
    """The tile capacity a render of `mesh` by `camera` needs (call it outside `jax.jit`).

    Counts the largest number of faces whose bounding box, grown by the soft margin,
    reaches one tile, multiplies by `slack` (>= 1; room for the geometry to move during a
    fit) and rounds up to one of four steps per octave (8, 10, 12, 14, 16, 20, ...; at
    most the number of faces). `camera` may be batched.

    **Arguments:**

    - `mesh`, `camera`, `shape`: as in `render`.
    - `sigma`: the `sigma` of the soft render the capacity is for; `None` for
      `render(..., mode="hard")`, whose faces reach only the tiles their boxes touch (a
      soft sigma there over-counts).
    - `eps`, `tile_size`: as in the render (soft only: `eps`).
    - `slack`: a factor >= 1 on the count.

    **Returns:** the capacity, an `int`.
    """
    mesh, _, camera, batched, _ = check_render_inputs(mesh, camera, None, None)
    height, width = static_shape(shape)
    if not isinstance(slack, float | int) or not slack >= 1:
        raise ValueError(f"`slack` must be a number >= 1, got {slack!r}")
    if sigma is None:  # hard mode: no soft margin; the other options are still checked
        _, tile_size, _, _ = check_options(
            jnp.ones((), mesh.vertices.dtype), eps, tile_size, None, 1
        )
    else:
        sigma = as_float(sigma, "sigma").astype(mesh.vertices.dtype)
        check_shape(sigma, "sigma", ())
        sigma, tile_size, _, _ = check_options(sigma, eps, tile_size, None, 1)
    with jax.ensure_compile_time_eval():  # concrete geometry inside a user's jit
        needed = measured_tile_count(
            mesh.vertices,
            mesh.faces,
            camera,
            sigma,
            shape=(height, width),
            tile_size=tile_size,
            eps=float(eps),
            cull_backfaces=False,
            axes=(None, 0 if batched else None),
        )
        needed = int(needed)
    return round_capacity(int(needed * slack + 0.999), mesh.num_faces)


def soft_rasterize(
    mesh: Mesh,
    camera: Camera,
    shape: tuple[int, int],
    *,
    sigma: float | Float[Array, ""],
    gamma: float | Float[Array, ""],
    background=(0.0, 0.0, 0.0),
    light=None,
    ambient: float = 0.3,
    eps: float = 1e-4,
    eps_background: float = 1e-3,
    tile_size: int = 8,
    capacity: int | None = None,
    tiles_per_step: int = 16,
) -> tuple[Float[Array, "H W 4"], Float[Array, "H W"]]:
    """Render a mesh with the soft rasterizer (SoftRas), flat-shaded.

    Differentiable with respect to the mesh vertices and colours and the camera. Faces
    with a vertex nearer than the camera's near plane (or behind it) are culled. For
    smooth shading, textures, normals and the hard rasterizer see `render`.

    **Arguments:**

    - `mesh`: a `gfxlab.mesh.Mesh`; vertex colours (white if absent) are interpolated
      with clamped barycentric coordinates.
    - `camera`: a `gfxlab.viewing.Camera`.
    - `shape`: image shape `(H, W)` (static).
    - `sigma`: edge sharpness in pixels^2 (finite, > 0).
    - `gamma`: depth temperature (finite, > 0); small makes the nearest face win.
    - `background`: background colour `(C,)`.
    - `light`: optional direction towards a light (world space) for two-sided flat
      Lambert shading `ambient + (1 - ambient) |n . l|`.
    - `eps`, `eps_background`: the probability below which a face is dropped at a
      pixel, and SoftRas' background depth term.
    - `tile_size`, `capacity`, `tiles_per_step`: as in `soft_silhouette`.

    **Returns:** `(rgba, depth)`: `(H, W, 4)` colour (background blended in) with the
    soft silhouette as alpha, and the `(H, W)` softmax-weighted eye depth (the
    background counts as the far plane).
    """
    options = (sigma, gamma, background, light, ambient, eps, eps_background)
    return _rasterize(mesh, camera, shape, options, (tile_size, capacity, tiles_per_step))


def soft_rasterize_dense(
    mesh: Mesh,
    camera: Camera,
    shape: tuple[int, int],
    *,
    sigma: float | Float[Array, ""],
    gamma: float | Float[Array, ""],
    background=(0.0, 0.0, 0.0),
    light=None,
    ambient: float = 0.3,
    eps: float = 1e-4,
    eps_background: float = 1e-3,
) -> tuple[Float[Array, "H W 4"], Float[Array, "H W"]]:
    """`soft_rasterize` with every pixel against every face in one step: the O(P·F)
    reference (`P` pixels, `F` faces).

    No tiles, no bins, and plain autodiff instead of the tiles' custom VJP: the values
    and gradients the tiled `soft_rasterize` must reproduce. Time and memory grow with
    `P * F`: for small images and meshes (tests, teaching).

    **Arguments:** as `soft_rasterize`, without the tile options.

    **Returns:** `(rgba, depth)` as `soft_rasterize`.
    """
    options = (sigma, gamma, background, light, ambient, eps, eps_background)
    return _rasterize(mesh, camera, shape, options, (8, None, 1), reference=True)


def _rasterize(mesh, camera, shape, options, sizes, *, reference=False):
    """The checks of `soft_rasterize`(`_dense`) and the call of the jitted core."""
    sigma, gamma, background, light, ambient, eps, eps_background = options
    height, width = static_shape(shape)
    check_mesh_camera(mesh, camera)
    ambient = check_finite(as_float(ambient, "ambient"), "ambient")
    eps_background = check_finite(as_float(eps_background, "eps_background"), "eps_background")
    tri, inv_depth, colors, valid = _project_mesh(mesh, camera, (height, width), light, ambient)
    dtype = tri.dtype
    sigma = as_float(sigma, "sigma").astype(dtype)
    gamma = as_float(gamma, "gamma").astype(dtype)
    check_shape(sigma, "sigma", ())
    check_shape(gamma, "gamma", ())
    sigma, tile_size, capacity, tiles_per_step = check_options(sigma, eps, *sizes)
    gamma = positive(gamma, "gamma")
    background = check_finite(as_float(background, "background").astype(dtype), "background")
    check_shape(background, "background", (colors.shape[-1],))
    if reference:
        capacity = max(mesh.num_faces, 1)  # unused: no tiles
    margin = jnp.sqrt(sigma * logit_limit(eps))
    capacity = resolve_capacity(
        capacity, tri, valid, margin, (height, width), tile_size, any_traced(mesh, camera, sigma)
    )
    near, far = camera.near.astype(dtype), camera.far.astype(dtype)
    params = (sigma, gamma, near, far, background, eps_background.astype(dtype))
    out, max_count = _color_core(
        tri,
        inv_depth,
        colors,
        valid,
        params,
        shape=(height, width),
        eps=float(eps),
        tile_size=tile_size,
        capacity=capacity,
        tiles_per_step=tiles_per_step,
        reference=reference,
    )
    out = check_capacity(out, max_count, capacity, tile_size, mesh.num_faces)
    return out[..., :-1], out[..., -1]


@functools.partial(
    jax.jit,
    static_argnames=(
        "shape",
        "eps",
        "tile_size",
        "capacity",
        "tiles_per_step",
        "binned",
        "reference",
    ),
)
def _color_core(
    tri,
    inv_depth,
    colors,
    valid,
    params,
    *,
    shape,
    eps,
    tile_size,
    capacity,
    tiles_per_step,
    binned=True,
    reference=False,
):
    margin = jnp.sqrt(params[0] * logit_limit(eps))
    return tiled(
        functools.partial(_color_kernel, eps=eps),
        tri,
        valid,
        (tri, inv_depth, colors),
        params,
        shape,
        margin=margin,
        tile_size=tile_size,
        capacity=capacity,
        tiles_per_step=tiles_per_step,
        binned=binned,
        reference=reference,
    )
