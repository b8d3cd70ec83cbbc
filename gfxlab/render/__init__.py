"""Rendering triangle scenes: soft and hard differentiable rasterization, shading,
textures, and the classic hidden-surface algorithms.

- `render` (module `renderer`): a world-space `Mesh` and a `Camera` (batched views or
  vertices too) to colour, silhouette, depth, normal maps and per-pixel barycentrics,
  with the soft (SoftRas) or the hard (z-buffer, edge-antialiased) rasterizer;
  `interpolate`, `antialias`, `shard_cameras`.
- Shading (module `shading`): `shade` through any `gfxlab.brdf` model with
  `PointLight`/`DirectionalLight`, `sample_texture` (bilinear, differentiable).
- Soft rasterization building blocks (module `soft`): `soft_silhouette` of 2D
  triangles, the flat-shaded `soft_rasterize`, `tile_capacity` (and `TileCapacityError`,
  a `ValueError`, when a tile outgrows the capacity a compiled render was given).
- Dense references (`render_dense`, `soft_silhouette_dense`, `soft_rasterize_dense`):
  every pixel against every face with plain autodiff, O(pixels x faces), what the tiled
  functions are tested against.
- Hidden-surface removal (module `hsr`): `zbuffer`, `painter`, `warnock`, `scanline`, `raycast`
  on screen-space triangle scenes made by `screen_scene`.

All distances are in pixels with the project's pixel convention (see `gfxlab.raster`: y up,
pixel centres on integers); projection is the camera's (`Camera.to_pixels`).

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab import render
    >>> from gfxlab.mesh import icosphere
    >>> from gfxlab.viewing import Camera
    >>> ball = icosphere(1).with_colors(jnp.array([0.9, 0.6, 0.3]))
    >>> image = render.render(ball, Camera(jnp.array([0.0, 0.0, 5.0])), (16, 16), mode="hard")
    >>> image.color.shape, float(image.alpha[8, 8]), float(image.alpha[0, 0])  # centre, corner
    ((16, 16, 3), 1.0, 0.0)
    >>> triangle = jnp.array([[[1.0, 1.0, 0.5], [6.0, 1.0, 0.5], [1.0, 6.0, 0.5]]])  # x, y, depth
    >>> drawn = render.zbuffer(triangle, jnp.array([[1.0, 0.0, 0.0]]), (8, 8))
    >>> int(jnp.isfinite(drawn.depth).sum())  # pixel centres inside or on its edges
    21
"""

from ._tiles import TileCapacityError
from .hsr import (
    WARNOCK_CODES,
    VisibilityResult,
    painter,
    quadtree_cells,
    raycast,
    scanline,
    screen_scene,
    warnock,
    zbuffer,
)
from .renderer import Rendering, antialias, interpolate, render, render_dense, shard_cameras
from .shading import DirectionalLight, PointLight, sample_texture, shade
from .soft import (
    _color_core,
    _project_mesh,
    soft_rasterize,
    soft_rasterize_dense,
    soft_silhouette,
    soft_silhouette_dense,
    tile_capacity,
)

__all__ = [
    "render",
    "render_dense",
    "Rendering",
    "interpolate",
    "antialias",
    "shard_cameras",
    "shade",
    "sample_texture",
    "PointLight",
    "DirectionalLight",
    "soft_silhouette",
    "soft_silhouette_dense",
    "soft_rasterize",
    "soft_rasterize_dense",
    "tile_capacity",
    "TileCapacityError",
    "screen_scene",
    "VisibilityResult",
    "zbuffer",
    "painter",
    "warnock",
    "scanline",
    "raycast",
    "quadtree_cells",
    "WARNOCK_CODES",
]

# private helpers re-exported for the benchmark (tests/benchmarks/bench_render.py)
_ = (_color_core, _project_mesh)
