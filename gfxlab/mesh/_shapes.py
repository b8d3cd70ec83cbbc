"""Procedural meshes: cube, icosphere, surfaces of revolution (cylinder, pawn) and torus.

They are built with NumPy, their sizes being static: every size (edge, radius, height)
is a Python number, finite and > 0 (a negative radius would turn a sphere inside out, a
zero one collapse it), refused otherwise with a `ValueError` naming the argument.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from .._checks import as_float, check_allocation, check_finite, positive, static_int
from . import MAX_SEGMENTS, MAX_SUBDIVISIONS, Mesh


def _size(value, name: str) -> float:
    """A size of a procedural mesh: a static real number, finite and > 0."""
    if isinstance(value, jax.core.Tracer):
        raise TypeError(
            f"`{name}` must be a static Python number (procedural meshes are built with "
            "NumPy), not a traced value; scale the mesh with `Mesh.transform` instead"
        )
    if isinstance(value, bool | str | bytes) or value is None:
        raise TypeError(f"`{name}` must be a real number, got {value!r:.40}")
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be a real number, got {value!r:.40}") from None
    except OverflowError:
        raise ValueError(f"`{name}` must be finite and > 0, got {value!r:.40}") from None
    return float(positive(value, name))


def _mesh(vertices: np.ndarray, faces: np.ndarray) -> Mesh:
    return Mesh(jnp.asarray(vertices, dtype=jnp.result_type(float)), jnp.asarray(faces, jnp.int32))


def cube(size: float = 1.0) -> Mesh:
    """An axis-aligned cube of edge `size` (finite, > 0) centred at the origin (8
    vertices, 12 faces)."""
    corners = np.array(
        [[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    ) * _size(size, "size")
    # index = 4 * (x > 0) + 2 * (y > 0) + (z > 0); quads counter-clockwise from outside
    quads = np.array(
        [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    )
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return _mesh(corners, faces)


def icosphere(subdivisions: int = 2, radius: float = 1.0) -> Mesh:
    """A sphere of `radius` (finite, > 0) made by subdividing an icosahedron:
    `20 * 4**subdivisions` faces (`subdivisions` from 0 to `MAX_SUBDIVISIONS`)."""
    subdivisions = static_int(subdivisions, "subdivisions", minimum=0, maximum=MAX_SUBDIVISIONS)
    radius = _size(radius, "radius")
    t = (1 + 5**0.5) / 2
    v = np.array(
        [
            [-1, t, 0],
            [1, t, 0],
            [-1, -t, 0],
            [1, -t, 0],
            [0, -1, t],
            [0, 1, t],
            [0, -1, -t],
            [0, 1, -t],
            [t, 0, -1],
            [t, 0, 1],
            [-t, 0, -1],
            [-t, 0, 1],
        ],
        float,
    )
    f = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ]
    )
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(np.stack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]], 1), axis=-1)
        unique, inverse = np.unique(edges.reshape(-1, 2), axis=0, return_inverse=True)
        mid = v[unique].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = inverse.reshape(-1, 3) + len(v)  # midpoints of edges (01, 12, 20)
        f = np.concatenate(
            [
                np.stack([f[:, 0], m[:, 0], m[:, 2]], 1),
                np.stack([f[:, 1], m[:, 1], m[:, 0]], 1),
                np.stack([f[:, 2], m[:, 2], m[:, 1]], 1),
                m,
            ]
        )
        v = np.concatenate([v, mid])
    return _mesh(v * float(radius), f)


def revolve(profile, segments: int = 24) -> Mesh:
    """A surface of revolution about the y axis.

    **Arguments:**

    - `profile`: `(N, 2)` finite points `(radius, height)` from bottom to top, radii
      >= 0 and at least one > 0. A point with radius 0 becomes a single pole vertex (use
      one at each end for a closed solid).
    - `segments`: number of steps around the axis (static).

    **Returns:** a `Mesh`, faces counter-clockwise seen from outside when the profile
    runs upwards.
    """
    segments = static_int(segments, "segments", minimum=3, maximum=MAX_SEGMENTS)
    profile = as_float(profile, "profile")
    if profile.ndim != 2 or profile.shape[1] != 2 or len(profile) < 2:
        raise ValueError(f"`profile` must have shape (N >= 2, 2), got {profile.shape}")
    profile = np.asarray(check_finite(profile, "profile"), float)
    check_allocation(3 * segments * len(profile), "profile x segments")
    if np.any(profile[:, 0] < 0):
        raise ValueError("`profile` radii must be >= 0")
    if not np.any(profile[:, 0] > 0):
        raise ValueError("`profile` must have a point with radius > 0 (else no surface)")
    angle = 2 * np.pi * np.arange(segments) / segments
    pole = profile[:, 0] == 0
    # vertex index of (profile point i, segment j): poles have one vertex
    counts = np.where(pole, 1, segments)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    ring = np.stack(
        [
            profile[:, :1] * np.sin(angle),
            np.broadcast_to(profile[:, 1:], (len(profile), segments)),
            profile[:, :1] * np.cos(angle),
        ],
        -1,
    )  # (N, segments, 3)
    vertices = np.concatenate([ring[i, : counts[i]] for i in range(len(profile))])
    j = np.arange(segments)
    jn = (j + 1) % segments

    def index(i, jj):
        return start[i] + np.where(pole[i], 0, jj)

    faces = []
    for i in range(len(profile) - 1):  # static loop over profile segments, not over points
        a, b = index(i, j), index(i, jn)
        c, d = index(i + 1, j), index(i + 1, jn)
        if not pole[i]:
            faces.append(np.stack([a, b, c], 1))
        if not pole[i + 1]:
            faces.append(np.stack([b, d, c], 1))
    return _mesh(vertices, np.concatenate(faces))


def cylinder(radius: float = 1.0, height: float = 2.0, segments: int = 24) -> Mesh:
    """A closed cylinder about the y axis, centred at the origin: `radius` and `height`
    finite and > 0, `segments` from 3 to `MAX_SEGMENTS`."""
    segments = static_int(segments, "segments", minimum=3, maximum=MAX_SEGMENTS)
    h = _size(height, "height") / 2
    r = _size(radius, "radius")
    return revolve([[0, -h], [r, -h], [r, h], [0, h]], segments)


def torus(
    major_radius: float = 1.0,
    minor_radius: float = 0.35,
    major_segments: int = 32,
    minor_segments: int = 16,
) -> Mesh:
    """A torus about the y axis: a tube of `minor_radius` around a circle of `major_radius`.

    Both radii are finite and > 0, with `minor_radius < major_radius` (a ring torus).
    """
    major_radius = _size(major_radius, "major_radius")
    minor_radius = _size(minor_radius, "minor_radius")
    if minor_radius >= major_radius:
        raise ValueError(
            f"`minor_radius` must be < `major_radius` (a ring torus; a larger tube would "
            f"pass through the axis and turn inside out), got {minor_radius:g} >= "
            f"{major_radius:g}"
        )
    nu = static_int(major_segments, "major_segments", minimum=3, maximum=MAX_SEGMENTS)
    nv = static_int(minor_segments, "minor_segments", minimum=3, maximum=MAX_SEGMENTS)
    check_allocation(6 * nu * nv, "major_segments x minor_segments")
    u = 2 * np.pi * np.arange(nu)[:, None] / nu
    v = 2 * np.pi * np.arange(nv)[None, :] / nv
    r = np.broadcast_to(major_radius + minor_radius * np.cos(v), (nu, nv))
    vertices = np.stack(
        [r * np.sin(u), np.broadcast_to(minor_radius * np.sin(v), r.shape), r * np.cos(u)], -1
    ).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = i * nv + (j + 1) % nv
    d = ((i + 1) % nu) * nv + (j + 1) % nv
    faces = np.concatenate([np.stack([a, b, c], -1), np.stack([b, d, c], -1)]).reshape(-1, 3)
    return _mesh(vertices, faces)


def pawn(segments: int = 32) -> Mesh:
    """A chess pawn (about 2 units tall, base on y = 0), a surface of revolution.

    Our own model: base, collar and a round head, free to redistribute with gfxlab.
    `segments` is at most `MAX_SEGMENTS`.
    """
    segments = static_int(segments, "segments", minimum=3, maximum=MAX_SEGMENTS)
    body = [
        (0.0, 0.0),
        (0.80, 0.0),
        (0.82, 0.06),
        (0.80, 0.13),
        (0.70, 0.18),
        (0.66, 0.24),
        (0.56, 0.30),
        (0.44, 0.36),
        (0.38, 0.46),
        (0.33, 0.62),
        (0.29, 0.82),
        (0.26, 1.02),
        (0.25, 1.12),
        (0.44, 1.16),
        (0.46, 1.21),
        (0.42, 1.26),
        (0.27, 1.30),
    ]
    # the head: a sphere of radius 0.34 centred at height 1.56, from its lower neck up
    angles = np.linspace(-0.30 * np.pi, 0.5 * np.pi, 10)
    head = [(0.34 * np.cos(a), 1.56 + 0.34 * np.sin(a)) for a in angles]
    head[-1] = (0.0, head[-1][1])
    return revolve(np.array(body + head), segments)
