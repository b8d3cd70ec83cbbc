"""Losses that keep a fitted mesh sane, and the chamfer distance between point sets."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._checks import as_float, check_finite, check_shape, safe_norm, value_error_if
from . import Mesh, check_faces, face_normals


def _mesh_arrays(mesh, faces):
    if isinstance(mesh, Mesh):
        return mesh.vertices, mesh.faces
    if mesh is None:
        raise TypeError("`mesh` must be a Mesh or (V, 3) vertices with `faces`, got None")
    vertices = as_float(mesh, "mesh")
    check_shape(vertices, "mesh", (None, 3))
    if faces is None:
        raise TypeError("`faces` (F, 3) are required when `mesh` is a (V, 3) vertex array")
    return check_finite(vertices, "mesh"), check_faces(faces, vertices.shape[0])


def _half_edges(faces):
    return jnp.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])


def laplacian_loss(mesh: Mesh | Float[Array, "V 3"], faces=None) -> Float[Array, ""]:
    """Uniform Laplacian smoothness: mean over vertices of `|v - mean(neighbours)|^2`.

    Neighbours are weighted by the number of faces sharing the edge. **Arguments:**
    a `Mesh`, or `(vertices (V, 3), faces (F, 3))`. **Returns:** a scalar.
    """
    vertices, faces = _mesh_arrays(mesh, faces)
    edges = _half_edges(faces)
    src = jnp.concatenate([edges[:, 0], edges[:, 1]])
    dst = jnp.concatenate([edges[:, 1], edges[:, 0]])
    count = jax.ops.segment_sum(jnp.ones_like(src, vertices.dtype), src, vertices.shape[0])
    total = jax.ops.segment_sum(vertices[dst], src, vertices.shape[0])
    mean = total / jnp.maximum(count, 1.0)[:, None]
    delta = jnp.where((count > 0)[:, None], vertices - mean, 0.0)
    return jnp.mean(jnp.sum(delta * delta, -1))


def edge_length_loss(mesh: Mesh | Float[Array, "V 3"], faces=None, *, target=None):
    """Mean squared edge length, or mean `(|e| - target)^2` with a `target` length.

    Every face edge counts once per face. **Returns:** a scalar.
    """
    vertices, faces = _mesh_arrays(mesh, faces)
    edges = _half_edges(faces)
    vec = vertices[edges[:, 1]] - vertices[edges[:, 0]]
    if target is None:
        return jnp.mean(jnp.sum(vec * vec, -1))
    target = as_float(target, "target")
    target = value_error_if(target, ~(target >= 0), "`target` must be a length >= 0")
    return jnp.mean((safe_norm(vec) - target) ** 2)


def normal_consistency_loss(mesh: Mesh | Float[Array, "V 3"], faces=None) -> Float[Array, ""]:
    """Mean `1 - n_i . n_j` over pairs of faces sharing an edge (0 for a flat sheet).

    Works under `jax.jit` (pairs are found by sorting edge keys). **Returns:** a scalar.
    """
    vertices, faces = _mesh_arrays(mesh, faces)
    normals = face_normals(vertices, faces)
    edges = jnp.sort(_half_edges(faces), axis=-1)
    key = edges[:, 0].astype(jnp.int64 if jax.config.jax_enable_x64 else jnp.int32)
    key = key * vertices.shape[0] + edges[:, 1]
    owner = jnp.tile(jnp.arange(faces.shape[0]), 3)
    order = jnp.argsort(key)
    key, owner = key[order], owner[order]
    pair = key[1:] == key[:-1]
    cos = jnp.sum(normals[owner[1:]] * normals[owner[:-1]], -1)
    return jnp.sum(jnp.where(pair, 1.0 - cos, 0.0)) / jnp.maximum(jnp.sum(pair), 1)


def chamfer_distance(a: Float[Array, "N d"], b: Float[Array, "M d"]) -> Float[Array, ""]:
    """Symmetric chamfer distance: mean squared distance from each point to the nearest
    point of the other set, summed over both directions.

    **Arguments:** `a (N, d)`, `b (M, d)` point sets (N, M >= 1). **Returns:** a scalar.
    """
    a, b = as_float(a, "a"), as_float(b, "b")
    for name, x in (("a", a), ("b", b)):
        if x.ndim != 2 or x.shape[0] == 0:
            raise ValueError(f"`{name}` must be a non-empty (N, d) point set, got {x.shape}")
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"`a` and `b` must have the same dimension, got {a.shape} {b.shape}")
    a, b = check_finite(a, "a"), check_finite(b, "b")
    d2 = jnp.sum((a[:, None] - b[None]) ** 2, -1)
    return jnp.mean(jnp.min(d2, 1)) + jnp.mean(jnp.min(d2, 0))
