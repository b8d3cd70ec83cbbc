"""`render`: a world-space mesh and a camera to colour, silhouette, depth, normals and
per-pixel barycentrics, with a soft (SoftRas) or a hard (z-buffer) rasterizer.

Both rasterizers work on the same tiles and compute, for every pixel and every face
binned into its tile, the screen-space barycentrics and from them the
**perspective-correct** barycentrics `b_k = (beta_k / w_k) / sum_j (beta_j / w_j)` (`w`
the eye depth of the corners). Every per-corner attribute (colour, normal, world
position, texture coordinates, user attributes) is interpolated with them.

- `mode="hard"`: the nearest covering face wins (a z-buffer on eye depth); its
  attributes are exact, and their gradients flow to the vertices inside faces. At
  silhouette edges (mesh boundaries, and folds whose neighbouring face faces the other
  way on screen, as in nvdiffrast) the **antialiasing** blends each pair of neighbouring
  pixels by where the edge crosses the segment between their centres, which gives the
  positions of the edges gradients.
- `mode="soft"`: SoftRas' depth-aware softmax (`sigma`, `gamma`, see `soft`) weights the
  faces; attributes are aggregated with the weights, shaded once per pixel (deferred
  shading) and blended with the background by its weight. Unlit, this is exactly
  SoftRas' colour. As `sigma, gamma -> 0` it becomes the hard image.
"""

from __future__ import annotations

import contextvars
import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .._checks import (
    is_traced,
    safe_normalize,
    trusted_values,
)
from .._pixels import pixel_centers
from ..mesh import Mesh, vertex_normals
from ..viewing import Camera, _pose_checked
from ._inputs import (
    RenderConfig,
    antialias_inputs,
    batched_camera,
    camera_batch,
    check_mesh_axes,
    check_render_inputs,
    check_rendering,
    check_shading,
    interpolate_inputs,
    render_config,
    render_options,
)
from ._project import check_mesh_camera, project_faces
from ._tiles import check_capacity, grown_capacity, logit_limit, pixel_face_planes, tiled
from .shading import sample_texture, shade

__all__ = [
    "render",
    "render_dense",
    "Rendering",
    "interpolate",
    "antialias",
    "shard_cameras",
]


class Rendering(eqx.Module):
    """What `render` returns (a leading batch axis `B` when cameras/vertices are batched).

    **Fields:**

    - `color`: `(H, W, C)` shaded colour (hard: blended with the background at
      antialiased edges; soft: the background is one more term of SoftRas' softmax,
      weighted by `eps_background`, not alpha blending: where faces reach, it barely
      shows).
    - `alpha`: `(H, W)` silhouette (soft: SoftRas' `1 - prod(1 - D)`; hard: coverage,
      antialiased at silhouette edges).
    - `depth`: `(H, W)` eye depth (soft: softmax-weighted, background = far plane;
      hard: of the visible face, far plane where empty).
    - `normal`: `(H, W, 3)` interpolated world-space unit normal (hard: zero where
      empty; soft: the weighted normal normalised, zero only where no face reaches).
    - `position`: `(H, W, 3)` interpolated world position (hard: zero where empty;
      soft: weighted, the background weighing in as the origin).
    - `face_index`: `(H, W)` index of the nearest covering face (-1: none).
    - `barycentrics`: `(H, W, 3)` its perspective-correct barycentric coordinates.
    - `attributes`: `(H, W, A)` the interpolated user `attributes`, or `None`.
    """

    color: Float[Array, "H W C"]
    alpha: Float[Array, "H W"]
    depth: Float[Array, "H W"]
    normal: Float[Array, "H W 3"]
    position: Float[Array, "H W 3"]
    face_index: Int[Array, "H W"]
    barycentrics: Float[Array, "H W 3"]
    attributes: Float[Array, "H W A"] | None

    def __check_init__(self):
        """Check the buffers: each has `color`'s pixel shape `(H, W)` (and 3 channels for
        `normal`, `position`, `barycentrics`), `face_index` is integer, and the floating
        buffers are finite (checked when not traced)."""
        check_rendering(self)


def _fragments(points, sub, slot_mask, ids, params, *, soft, eps):
    """Per-pixel aggregated attributes, coverage, depth, face and barycentrics."""
    tri, inv_w, attrs = sub  # (K, 3, 2), (K, 3), (K, 3, A)
    sigma, gamma, near, far, eps_bg = params
    d2, inside, bary = pixel_face_planes(points, tri)
    cover = slot_mask[None] & inside
    persp = [bary[v] * inv_w[None, :, v] for v in range(3)]  # three (P, K) planes
    total = persp[0] + persp[1] + persp[2]
    depth = 1.0 / jnp.where(total > 0, total, 1.0)  # (P, K) eye depth
    persp = [q * depth for q in persp]
    nearest = jnp.argmin(jnp.where(cover, depth, jnp.inf), -1)
    hit = jnp.any(cover, -1)
    # the nearest face as a one-hot mask: selects whose gradients need no scatter
    pick = (jnp.arange(tri.shape[0])[None] == nearest[:, None]) & hit[:, None]
    picked = [jnp.where(pick, q, 0.0) for q in persp]
    b_near = jnp.stack([jnp.sum(q, -1) for q in picked], -1)  # zero where empty
    face = jnp.where(hit, ids[nearest], -1).astype(tri.dtype)
    if not soft:
        values = sum(picked[v] @ attrs[:, v, :] for v in range(3))  # zero where empty
        weight = hit.astype(tri.dtype)
        alpha = weight
        out_depth = jnp.where(hit, jnp.sum(jnp.where(pick, depth, 0.0), -1), far)
    else:
        keep = slot_mask[None] & (inside | (d2 <= sigma * logit_limit(eps)))
        x = jnp.where(inside, d2, -d2) / sigma
        # 0.0 - x, not -x: where no face reaches, +0.0 rather than -0.0
        alpha = 0.0 - jnp.expm1(jnp.sum(jnp.where(keep, jax.nn.log_sigmoid(-x), 0.0), -1))
        z = (far - depth) / (far - near)
        logits = jnp.where(keep, jax.nn.log_sigmoid(x) + z / gamma, -jnp.inf)
        top = jax.lax.stop_gradient(jnp.maximum(jnp.max(logits, -1), eps_bg / gamma))
        w_faces = jnp.exp(logits - top[:, None])
        w_back = jnp.exp(eps_bg / gamma - top)
        norm = 1.0 / (jnp.sum(w_faces, -1) + w_back)
        w_faces, w_back = w_faces * norm[:, None], w_back * norm
        weight = 1.0 - w_back
        summed = sum((w_faces * persp[v]) @ attrs[:, v, :] for v in range(3))
        some = weight > 1e-30
        values = jnp.where(some[:, None], summed / jnp.where(some, weight, 1.0)[:, None], 0.0)
        out_depth = jnp.sum(w_faces * jnp.where(keep, depth, 0.0), -1) + w_back * far
    extra = jnp.stack([weight, alpha, out_depth, face], -1)
    return jnp.concatenate([values, extra, b_near], -1)


def interpolate(
    attributes: Float[Array, "V A"],
    faces: Int[Array, "F 3"],
    face_index: Int[Array, "*batch"],
    barycentrics: Float[Array, "*batch 3"],
) -> Float[Array, "*batch A"]:
    """Interpolate per-vertex `attributes` at pixels given their face and barycentrics.

    Pixels with `face_index = -1` get zeros. With the perspective-correct
    `Rendering.barycentrics` this is perspective-correct interpolation.
    """
    attributes, faces, face_index, barycentrics = interpolate_inputs(
        attributes, faces, face_index, barycentrics
    )
    corners = attributes[faces[jnp.maximum(face_index, 0)]]  # (..., 3, A)
    values = jnp.einsum("...v,...va->...a", barycentrics, corners)
    return jnp.where((face_index >= 0)[..., None], values, 0.0)


def _edge_values(tri, point):
    """Oriented edge functions (>= 0 inside) of triangles `(..., 3, 2)` at `(..., 2)`."""
    a, b = tri, jnp.roll(tri, -1, axis=-2)
    e = b - a
    r = point[..., None, :] - a
    fn = e[..., 0] * r[..., 1] - e[..., 1] * r[..., 0]
    return fn * jnp.where(_signed_areas(tri) < 0, -1.0, 1.0)[..., None]


def _signed_areas(tri):
    """Twice the signed area of triangles `(..., 3, 2)` (> 0: counter-clockwise)."""
    u, v = tri[..., 1, :] - tri[..., 0, :], tri[..., 2, :] - tri[..., 0, :]
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _edge_neighbours(faces):
    """`(F, 3)`: the face across edge `k` (corners `k`, `k + 1`) of each face, `-1` on a
    boundary; found by sorting the `3F` undirected edges (no Python loop)."""
    a, b = faces, jnp.roll(faces, -1, axis=1)
    lo, hi = jnp.minimum(a, b).ravel(), jnp.maximum(a, b).ravel()
    order = jnp.lexsort((hi, lo))
    same = (lo[order][1:] == lo[order][:-1]) & (hi[order][1:] == hi[order][:-1])
    slot = jnp.arange(order.shape[0])
    partner = jnp.where(
        jnp.pad(same, (0, 1)), slot + 1, jnp.where(jnp.pad(same, (1, 0)), slot - 1, -1)
    )
    face = jnp.where(partner >= 0, order[jnp.maximum(partner, 0)] // 3, -1)
    return jnp.zeros_like(face).at[order].set(face).reshape(faces.shape)


def _silhouette_edges(tri, faces):
    """`(F, 3)` whether edge `k` of each face is on a silhouette in this view: a mesh
    boundary, or a fold whose neighbour faces the other way on screen (nvdiffrast's
    test). Inner edges between faces that face one way are never blended."""
    neighbour = _edge_neighbours(faces)
    facing = _signed_areas(tri) > 0
    return (neighbour < 0) | (facing[jnp.maximum(neighbour, 0)] != facing[:, None])


def _pair_deltas(img_p, img_q, f_p, f_q, d_p, d_q, pt_p, pt_q, tri, silhouette, axis):
    """nvdiffrast-style blend of neighbour pixels `p`, `q` (a pair along `axis`: 0
    vertical, 1 horizontal) across a silhouette edge."""
    a_is_p = (f_q < 0) | ((f_p >= 0) & (d_p <= d_q))
    fa = jnp.where(a_is_p, f_p, f_q)
    pa = jnp.where(a_is_p[..., None], pt_p, pt_q)
    po = jnp.where(a_is_p[..., None], pt_q, pt_p)
    t_a = tri[jnp.maximum(fa, 0)]  # (..., 3, 2)
    e_a, e_o = _edge_values(t_a, pa), _edge_values(t_a, po)
    # `pa` is inside face `a` as rasterised, within rounding: an edge it is on, by
    # this evaluation just outside, is crossed at t = 0.
    exits = (e_o < 0) & (e_a > e_o)
    denom = jnp.where(exits, e_a - e_o, 1.0)
    t = jnp.where(exits, jnp.maximum(e_a, 0.0) / denom, 2.0)  # where it crosses pa -> po
    t_exit = jax.lax.stop_gradient(t)
    k = jnp.argmin(t_exit, -1)[..., None]
    t = jnp.take_along_axis(t, k, -1)[..., 0]
    # A segment through a vertex exits two edges at one t (which is the minimum is
    # float noise): the crossing is on a silhouette if either edge is.
    near = exits & (t_exit <= jnp.min(t_exit, -1, keepdims=True) + 1e-4)
    on_silhouette = jnp.any(near & silhouette[jnp.maximum(fa, 0)], -1)
    # Each edge is blended by the pairs it is closer to perpendicular to, as in
    # nvdiffrast: blended by both, a pixel by a slanted edge would get both blends.
    corners = jax.lax.stop_gradient(t_a)
    start = jnp.take_along_axis(corners, k[..., None], -2)[..., 0, :]
    end = jnp.take_along_axis(corners, ((k + 1) % 3)[..., None], -2)[..., 0, :]
    dx, dy = jnp.abs(end[..., 0] - start[..., 0]), jnp.abs(end[..., 1] - start[..., 1])
    facing_pair = dx > dy if axis == 0 else dy >= dx  # vertical pairs: flatter edges
    active = (f_p != f_q) & (fa >= 0) & on_silhouette & facing_pair
    c_a = jnp.where(a_is_p[..., None], img_p, img_q)
    c_o = jnp.where(a_is_p[..., None], img_q, img_p)
    into_o = jnp.where(active & (t > 0.5), t - 0.5, 0.0)[..., None] * (c_a - c_o)
    into_a = jnp.where(active & (t < 0.5), 0.5 - t, 0.0)[..., None] * (c_o - c_a)
    delta_p = jnp.where(a_is_p[..., None], into_a, into_o)
    delta_q = jnp.where(a_is_p[..., None], into_o, into_a)
    return delta_p, delta_q


def antialias(
    image: Float[Array, "H W C"],
    face_index: Int[Array, "H W"],
    depth: Float[Array, "H W"],
    triangles_2d: Float[Array, "F 3 2"],
    faces: Int[Array, "F 3"],
) -> Float[Array, "H W C"]:
    """Analytic antialiasing of a hard rendering at silhouette edges (nvdiffrast style).

    For every pair of horizontally or vertically neighbouring pixels that show different
    faces (or a face and the background), the front face's edge that the segment
    between the two pixel centres crosses is found. If that edge is on a silhouette (a
    boundary of the mesh, or an edge whose neighbouring face faces the other way on
    screen; an edge between faces that face one way is inner), the pixel on the far
    side of the midpoint is blended towards the other by the distance of the crossing
    from the midpoint. Faces that share an edge must list it in opposite directions (a
    consistently oriented mesh), as `read_obj` and the procedural meshes do.
    The result is differentiable in the edge positions `triangles_2d` (pixels, y up).
    """
    image, face_index, depth, triangles_2d, faces = antialias_inputs(
        image, face_index, depth, triangles_2d, faces
    )
    return _antialias(image, face_index, depth, triangles_2d, faces)


@jax.jit
def _antialias(image, face_index, depth, triangles_2d, faces):
    height, width = face_index.shape
    points = pixel_centers((height, width), dtype=triangles_2d.dtype)
    silhouette = _silhouette_edges(jax.lax.stop_gradient(triangles_2d), faces)
    out = image
    for axis in (0, 1):  # vertical pairs, then horizontal pairs
        lo = [slice(None), slice(None)]
        hi = [slice(None), slice(None)]
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        lo, hi = tuple(lo), tuple(hi)
        dp, dq = _pair_deltas(
            image[lo],
            image[hi],
            face_index[lo],
            face_index[hi],
            depth[lo],
            depth[hi],
            points[lo],
            points[hi],
            triangles_2d,
            silhouette,
            axis,
        )
        pad_p = [(0, 0)] * 3
        pad_q = [(0, 0)] * 3
        pad_p[axis], pad_q[axis] = (0, 1), (1, 0)
        out = out + jnp.pad(dp, pad_p) + jnp.pad(dq, pad_q)
    return out


def _corner_attributes(mesh, vertices, attributes):
    """Per-corner attributes `(F, 3, A)`: albedo | normal | position | uv | user."""
    faces = mesh.faces
    albedo = (
        mesh.colors[faces]
        if mesh.colors is not None
        else jnp.ones(faces.shape + (3,), vertices.dtype)
    )
    if mesh.normals is not None:
        normals = mesh.normals.astype(vertices.dtype)[mesh.normal_faces]
    else:
        normals = vertex_normals(vertices, faces)[faces]
    parts = [albedo, normals, vertices[faces]]
    if mesh.texture is not None:
        parts.append(mesh.uvs.astype(vertices.dtype)[mesh.uv_faces])
    if attributes is not None:
        parts.append(attributes.astype(vertices.dtype)[faces])
    return jnp.concatenate(parts, -1), albedo.shape[-1]


def _render_view(mesh, vertices, camera, extras, config: RenderConfig):
    attributes, lights, brdf, ambient, background, (sigma, gamma, eps_bg) = extras
    dtype = vertices.dtype
    params = (sigma, gamma, camera.near.astype(dtype), camera.far.astype(dtype), eps_bg)
    tri, inv_w, _, valid = project_faces(
        vertices, mesh.faces, camera, config.shape, cull_backfaces=config.cull_backfaces
    )
    attrs, channels = _corner_attributes(mesh, vertices, attributes)
    margin = jnp.sqrt(sigma * logit_limit(config.eps)) if config.soft else jnp.zeros((), tri.dtype)
    out, max_count = tiled(
        functools.partial(_fragments, soft=config.soft, eps=config.eps),
        tri,
        valid,
        (tri, inv_w, attrs),
        params,
        config.shape,
        margin=margin,
        tile_size=config.tile_size,
        capacity=config.capacity,
        tiles_per_step=config.tiles_per_step,
        reference=config.reference,
    )
    size = attrs.shape[-1]
    values, (weight, alpha, depth, face) = out[..., :size], [out[..., size + k] for k in range(4)]
    bary = out[..., size + 4 :]
    face = jax.lax.stop_gradient(face).astype(jnp.int32)
    albedo = values[..., :channels]
    normal = values[..., channels : channels + 3]
    position = values[..., channels + 3 : channels + 6]
    rest = channels + 6
    if mesh.texture is not None:
        albedo = sample_texture(mesh.texture.astype(tri.dtype), values[..., rest : rest + 2])
        albedo = albedo * values[..., :channels] if mesh.colors is not None else albedo
        rest += 2
    color = albedo
    if lights is not None:
        color = shade(
            albedo, normal, position, camera.eye, lights=lights, brdf=brdf, ambient=ambient
        )
    color = weight[..., None] * color + (1.0 - weight[..., None]) * background
    if not config.soft and config.antialias:
        both = _antialias(
            jnp.concatenate([color, alpha[..., None]], -1), face, depth, tri, mesh.faces
        )
        color, alpha = both[..., :-1], both[..., -1]
    normal = safe_normalize(normal)
    user = values[..., rest:] if attributes is not None else None
    return Rendering(color, alpha, depth, normal, position, face, bary, user), max_count


@functools.partial(jax.jit, static_argnames=("config",))
def _render_jit(mesh, vertices, camera, extras, *, config: RenderConfig):
    def one(v, c):
        with trusted_values():  # `render` checked every input
            return _render_view(mesh, v, c, extras, config)

    if config.batched_vertices or config.batched_camera:
        axes = (0 if config.batched_vertices else None, 0 if config.batched_camera else None)
        result, counts = jax.vmap(one, in_axes=axes)(vertices, camera)
        return result, jnp.max(counts)
    return one(vertices, camera)


def render(
    mesh: Mesh,
    camera: Camera,
    shape: tuple[int, int],
    *,
    mode: str = "soft",
    sigma: float | Float[Array, ""] = 1.0,
    gamma: float | Float[Array, ""] = 1e-4,
    lights=None,
    brdf=None,
    ambient=0.0,
    background=0.0,
    vertices: Float[Array, "*B V 3"] | None = None,
    attributes: Float[Array, "V A"] | None = None,
    cull_backfaces: bool = False,
    antialias: bool = True,
    eps: float = 1e-4,
    eps_background: float = 1e-3,
    tile_size: int = 8,
    capacity: int | None = None,
    tiles_per_step: int = 16,
) -> Rendering:
    """Render a world-space mesh seen by a camera (see the module docstring).

    **Arguments:**

    - `mesh`: a `gfxlab.mesh.Mesh`: vertex colours (white if absent), a `texture` with
      `uvs` (times the colours if both), `normals` (else `vertex_normals`).
    - `camera`: a `gfxlab.viewing.Camera`; batched fields render a batch of views.
    - `shape`: image shape `(H, W)` (static).
    - `mode`: `"soft"` (SoftRas) or `"hard"` (z-buffer with edge antialiasing).
    - `sigma` (pixels^2), `gamma`: SoftRas' sharpness and depth temperature (soft only;
      finite and > 0; `gamma` is SoftRas' default: a larger one lets hidden faces show).
    - `lights`, `brdf`, `ambient` (>= 0): shading (`gfxlab.render.shade`);
      `lights=None` renders the unlit albedo (then `brdf` and `ambient` are refused).
    - `background`: background colour (scalar or `(C,)`).
    - `vertices`: optional `(V, 3)` or `(B, V, 3)` positions replacing `mesh.vertices`.
    - `attributes`: optional `(V, A)` per-vertex attributes, interpolated
      perspective-correctly into `Rendering.attributes`.
    - `cull_backfaces`: drop faces that are clockwise on screen. Faces with a corner
      nearer than the near plane are always dropped.
    - `antialias`: edge antialiasing of the hard image (gives silhouettes gradients).
    - `eps`, `eps_background`, `tile_size`, `capacity`, `tiles_per_step`: as in
      `soft_rasterize`; `capacity=None` measures it (eagerly: one more compiled call;
      traced geometry, as in `gfxlab.fit`, needs one from `tile_capacity`).
      A capacity that a tile outgrows is grown with a warning and the call rerun (in
      `gfxlab.fit`, its steps); in your own `jax.jit`, it is an error naming one.

    **Returns:** a `Rendering`.
    """
    check_mesh_axes("render", mesh=mesh, camera=camera, vertices=vertices)
    mesh, vertices, camera, batched, attributes = check_render_inputs(
        mesh, camera, vertices, attributes
    )
    sizes = (tile_size, capacity, tiles_per_step)
    options = (sigma, gamma, ambient, background, eps, eps_background, sizes)
    params, ambient, background, sizes = render_options(mesh, vertices.dtype, *options)
    flags = (antialias, cull_backfaces, _REFERENCE.get())
    config = render_config(
        mesh, vertices, camera, batched, params[0], mode, shape, eps=eps, sizes=sizes, flags=flags
    )
    lights, brdf = check_shading(lights, brdf, ambient, background.shape[-1])
    if is_traced(camera) and camera.rotation is None:  # the core skips a camera's checks
        vertices = _pose_checked(vertices, camera.eye, camera.target, camera.up, prefix="camera.")
    extras = (attributes, lights, brdf, ambient, background, params)
    result, max_count = _render_jit(mesh, vertices, camera, extras, config=config)
    if not is_traced(max_count) and capacity is not None:
        needed = int(np.max(np.asarray(max_count)))
        if needed > config.capacity:  # grown and recompiled, with a warning
            grown = grown_capacity(needed, config.capacity, tile_size, mesh.num_faces)
            config = config._replace(capacity=grown)
            result, max_count = _render_jit(mesh, vertices, camera, extras, config=config)
    color = check_capacity(result.color, max_count, config.capacity, tile_size, mesh.num_faces)
    return eqx.tree_at(lambda r: r.color, result, color)


_REFERENCE = contextvars.ContextVar("gfxlab_render_reference", default=False)


def render_dense(mesh: Mesh, camera: Camera, shape: tuple[int, int], **options) -> Rendering:
    """`render` with every pixel against every face in one step: the O(P·F) reference
    (`P` pixels, `F` faces).

    No tiles, no bins, and plain autodiff instead of the tiles' custom VJP: the values
    and gradients the tiled `render` must reproduce. Time and memory grow with `P * F`:
    for small images and meshes (tests, teaching).

    **Arguments:** `mesh`, `camera`, `shape` and the keyword `options` of `render`. The
    tile options (`tile_size`, `capacity`, `tiles_per_step`) are accepted, so that a
    call switches between `render` and `render_dense` by its name alone, and have no
    effect.

    **Returns:** a `Rendering`.
    """
    check_mesh_camera(mesh, camera)
    token = _REFERENCE.set(True)
    # One "tile" holds every face: no capacity to measure.
    options = {**options, "capacity": max(mesh.num_faces, 1), "tiles_per_step": 1}
    try:
        return render(mesh, camera, shape, **options)
    finally:
        _REFERENCE.reset(token)


def shard_cameras(camera: Camera, devices=None) -> Camera:
    """A batched camera placed across `devices` (default: all) along its batch axis.

    `render` of the result runs sharded (`jax.sharding`): each device renders its share
    of the views. The batch size must be a multiple of the number of devices.
    The views are sharded on an Auto mesh axis: under a `jax.set_mesh` mesh whose axes
    are Explicit (`jax.make_mesh`'s default), this and `render` of sharded inputs are
    errors saying so; a mesh made with `axis_types=(jax.sharding.AxisType.Auto,)` works.
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"`camera` must be a gfxlab.viewing.Camera, got {type(camera).__name__}")
    check_mesh_axes("shard_cameras")
    devices = jax.devices() if devices is None else list(devices)
    batch = camera_batch(camera)
    if batch is None or batch % len(devices):
        raise ValueError(
            f"`camera` must be batched (B views) with B a multiple of the "
            f"{len(devices)} devices, got {'one view' if batch is None else f'{batch} views'}"
        )
    camera = batched_camera(camera, batch)
    grid = jax.sharding.Mesh(np.asarray(devices), ("views",))

    def put(x):
        spec = jax.sharding.PartitionSpec("views", *([None] * (x.ndim - 1)))
        return jax.device_put(x, jax.sharding.NamedSharding(grid, spec))

    return jax.tree_util.tree_map(put, camera)
