"""Tensor-product Bezier patches, their triangle meshes, and the Utah teapot."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float, check_shape, static_int
from .._resources import data_file
from ..mesh import Mesh
from ._bezier import _bernstein
from ._common import (
    MAX_DEGREE,
    MAX_RESOLUTION,
    _check_unit_interval,
    _float_dtype,
    _floats,
    _not_finite,
    _require,
)


def bezier_patch(
    control_net: Float[ArrayLike, "*batch m+1 n+1 d"],
    u: Float[ArrayLike, " U"],
    v: Float[ArrayLike, " V"],
) -> Float[Array, "*batch U V d"]:
    """A tensor-product Bezier patch `S(u, v) = sum_ij B_{i,m}(u) B_{j,n}(v) p_ij` on the
    grid `u x v`.

    **Arguments:**

    - `control_net`: `(..., m+1, n+1, d)`; the first net axis goes with `u`.
    - `u`, `v`: `(U,)` and `(V,)` parameters in `[0, 1]`.

    **Returns:** `(..., U, V, d)`.

    **Raises:** `ValueError` for bad shapes, non-finite nets or parameters outside
    `[0, 1]`.
    """
    net = as_float(control_net, "control_net")
    if net.ndim < 3:
        raise ValueError(
            f"`control_net` must have shape (..., m+1, n+1, d), got {tuple(net.shape)}"
        )
    if max(net.shape[-3], net.shape[-2]) > MAX_DEGREE + 1:
        raise ValueError(
            f"`control_net` must have at most MAX_DEGREE + 1 = {MAX_DEGREE + 1} points per "
            f"side, got shape {tuple(net.shape)}"
        )
    net = _require(net, "`control_net` must be finite (no NaN or inf)", _not_finite)
    net, u, v = _floats(net, u, v, names=("control_net", "u", "v"))
    check_shape(u, "u", (None,))
    check_shape(v, "v", (None,))
    u = _check_unit_interval(u, "u")
    v = _check_unit_interval(v, "v")
    return _patch_kernel(net, u, v)


@jax.jit
def _patch_kernel(net, u, v) -> jax.Array:
    bu = _bernstein(net.shape[-3] - 1, u)
    bv = _bernstein(net.shape[-2] - 1, v)
    return jnp.einsum("ai,bj,...ijd->...abd", bu, bv, net)


def patch_mesh(control_nets: Float[ArrayLike, "P m+1 n+1 3"], resolution: int) -> Mesh:
    """Triangulate Bezier patches on a regular `(resolution + 1)^2` parameter grid each.

    **Arguments:**

    - `control_nets`: `(P, m+1, n+1, 3)` (or one net `(m+1, n+1, 3)`), finite.
    - `resolution`: grid cells per side of a patch, a static int in
      `[1, MAX_RESOLUTION]`.

    **Returns:** a `gfxlab.mesh.Mesh` with vertices `(P (r+1)^2, 3)` (patch-major, then
    `u`, then `v`; shared patch edges are not merged) and int32 faces `(2 P r^2, 3)`.
    Each triangle winds counter-clockwise about `dS/du x dS/dv`.

    **Raises:** `ValueError` for a bad shape, a non-finite net or a resolution out of
    range; `TypeError` for a resolution that is not a whole number or a `None` net.
    """
    nets = as_float(control_nets, "control_nets")
    if nets.ndim == 3:
        nets = nets[None]
    if nets.ndim != 4 or nets.shape[-1] != 3:
        raise ValueError(
            f"`control_nets` must have shape (P, m+1, n+1, 3) or (m+1, n+1, 3), got "
            f"{tuple(jnp.shape(control_nets))}"
        )
    nets = _require(nets, "`control_nets` must be finite (no NaN or inf)", _not_finite)
    r = static_int(resolution, "resolution", minimum=1, maximum=MAX_RESOLUTION)
    if max(nets.shape[-3], nets.shape[-2]) > MAX_DEGREE + 1:
        raise ValueError(
            f"`control_nets` must have at most MAX_DEGREE + 1 = {MAX_DEGREE + 1} points per "
            f"side, got shape {tuple(nets.shape)}"
        )
    return Mesh(_patch_vertices(nets, r), _grid_faces(nets.shape[0], r))


@functools.partial(jax.jit, static_argnums=1)
def _patch_vertices(nets: jax.Array, r: int) -> jax.Array:
    """The `(P (r+1)^2, 3)` vertices of the patches on the `(r+1)^2` parameter grid."""
    grid = jnp.linspace(0, 1, r + 1, dtype=nets.dtype)
    return _patch_kernel(nets, grid, grid).reshape(-1, 3)


@functools.lru_cache(maxsize=16)
def _grid_faces(num_patches: int, r: int) -> np.ndarray:
    """The int32 faces of `num_patches` grids of `(r+1)^2` vertices, `(2 P r^2, 3)`."""
    i, j = np.meshgrid(np.arange(r), np.arange(r), indexing="ij")
    a = (i * (r + 1) + j).ravel()  # (u_i, v_j)
    b, d = a + 1, a + (r + 1)  # (u_i, v_j+1), (u_i+1, v_j)
    c = d + 1
    cell = np.concatenate([np.stack([a, d, c], -1), np.stack([a, c, b], -1)])
    base = (np.arange(num_patches) * (r + 1) ** 2)[:, None, None]
    faces = (cell[None] + base).reshape(-1, 3).astype(np.int32)
    faces.setflags(write=False)
    return faces


@functools.lru_cache(maxsize=1)
def _teapot_data() -> tuple[np.ndarray, np.ndarray]:
    path = data_file("teapot", "teapot.txt")
    rows = []
    for line in path.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            rows.append(line.split())
    num_patches = int(rows[0][1])
    patches = np.array(rows[1 : 1 + num_patches], dtype=np.int64)
    num_vertices = int(rows[1 + num_patches][1])
    start = 2 + num_patches
    vertices = np.array(rows[start : start + num_vertices], dtype=np.float64)
    if patches.shape != (num_patches, 16) or vertices.shape != (num_vertices, 3):
        raise ValueError(f"{path} is malformed")  # pragma: no cover - shipped data
    patches.setflags(write=False)
    vertices.setflags(write=False)
    return patches, vertices


def teapot_patches(*, dtype=None) -> Float[Array, "32 4 4 3"]:
    """The Utah teapot's 32 bicubic control nets (Newell 1975), from `data/teapot/`.

    z is up; the teapot stands on z = 0 and is about 6.5 wide and 3.15 tall.

    **Arguments:**

    - `dtype`: a floating dtype (default: JAX's default float).

    **Returns:** `(32, 4, 4, 3)` control points.
    """
    patches, vertices = _teapot_data()
    return jnp.asarray(vertices[patches].reshape(-1, 4, 4, 3), dtype=_float_dtype(dtype))


def teapot(resolution: int = 8, *, dtype=None) -> Mesh:
    """The Utah teapot as a triangle mesh: `patch_mesh(teapot_patches(), resolution)`
    with the winding flipped so that faces wind counter-clockwise seen from outside.

    **Arguments:**

    - `resolution`: grid cells per patch side, a static int in `[1, MAX_RESOLUTION]`.
    - `dtype`: a floating dtype of the vertices.

    **Returns:** a `gfxlab.mesh.Mesh`: vertices `(32 (r+1)^2, 3)`, int32 faces
    `(64 r^2, 3)`.
    """
    r = static_int(resolution, "resolution", minimum=1, maximum=MAX_RESOLUTION)
    nets = teapot_patches(dtype=dtype)
    return Mesh(_patch_vertices(nets, r), _grid_faces(nets.shape[0], r)[:, ::-1])
