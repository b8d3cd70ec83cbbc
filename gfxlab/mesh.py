"""Triangle meshes: a `Mesh` pytree, procedural shapes, normals and Wavefront OBJ files.

Faces are triangles given as vertex indices, ordered counter-clockwise when seen from
outside, so `face_normals` point outwards. Procedural meshes are built with NumPy (their
sizes are static) and returned as JAX arrays, so a `Mesh` can be transformed, rendered
and fitted like any other pytree.

The model shipped in `data/meshes/` (a chess pawn, a surface of revolution) is written
by `write_shipped_models`, so the file is reproducible from this code.
"""

from __future__ import annotations

import os
import pathlib

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from . import transforms as tf
from ._checks import as_float, check_shape, safe_norm, static_int, value_error_if

__all__ = [
    "Mesh",
    "cube",
    "icosphere",
    "cylinder",
    "torus",
    "revolve",
    "pawn",
    "face_normals",
    "vertex_normals",
    "read_obj",
    "write_obj",
    "obj_text",
    "SHIPPED_MODELS",
    "DATA_DIR",
    "shipped_model_path",
    "write_shipped_models",
]

#: `data/meshes/` of the repository.
DATA_DIR = pathlib.Path(__file__).resolve().parent.parent / "data" / "meshes"


class Mesh(eqx.Module):
    """A triangle mesh.

    **Fields:**

    - `vertices`: `(V, 3)` positions (floating; fitted by `gfxlab.fit`).
    - `faces`: `(F, 3)` integer vertex indices, counter-clockwise seen from outside
      (integer, so held fixed by `gfxlab.fit`).
    - `colors`: optional `(V, C)` per-vertex colours in [0, 1] (usually `C = 3`).
    """

    vertices: Float[Array, "V 3"]
    faces: Int[Array, "F 3"]
    colors: Float[Array, "V C"] | None = None

    def __init__(self, vertices, faces, colors=None):
        vertices = as_float(vertices, "vertices")
        check_shape(vertices, "vertices", (None, 3))
        faces = jnp.asarray(faces)
        if not jnp.issubdtype(faces.dtype, jnp.integer):
            raise TypeError(f"`faces` must hold integer vertex indices, got dtype {faces.dtype}")
        check_shape(faces, "faces", (None, 3))
        faces = value_error_if(
            faces,
            (faces < 0) | (faces >= vertices.shape[0]),
            f"`faces` must index the {vertices.shape[0]} vertices (0 <= index < "
            f"{vertices.shape[0]})",
        )
        if colors is not None:
            colors = as_float(colors, "colors").astype(vertices.dtype)
            if colors.ndim != 2 or colors.shape[0] != vertices.shape[0]:
                raise ValueError(
                    f"`colors` must have shape ({vertices.shape[0]}, C) (one colour per "
                    f"vertex), got shape {tuple(colors.shape)}"
                )
        self.vertices, self.faces, self.colors = vertices, faces, colors

    @property
    def num_vertices(self) -> int:
        return self.vertices.shape[0]

    @property
    def num_faces(self) -> int:
        return self.faces.shape[0]

    def triangles(self) -> Float[Array, "F 3 3"]:
        """The `(F, 3, 3)` corner positions of every face."""
        return self.vertices[self.faces]

    def transform(self, matrix: Float[Array, "4 4"]) -> Mesh:
        """The mesh with `matrix` (homogeneous 4x4, column vectors) applied to its vertices."""
        return Mesh(tf.apply(matrix, self.vertices), self.faces, self.colors)

    def with_colors(self, colors) -> Mesh:
        """The mesh with per-vertex `colors`; a single colour `(C,)` is used for every vertex."""
        colors = as_float(colors, "colors")
        if colors.ndim == 1:
            colors = jnp.broadcast_to(colors, (self.num_vertices, colors.shape[0]))
        return Mesh(self.vertices, self.faces, colors)

    def face_normals(self) -> Float[Array, "F 3"]:
        return face_normals(self.vertices, self.faces)

    def vertex_normals(self) -> Float[Array, "V 3"]:
        return vertex_normals(self.vertices, self.faces)


def face_normals(vertices: Float[Array, "V 3"], faces: Int[Array, "F 3"]) -> Float[Array, "F 3"]:
    """Unit outward normals of the faces (zero for degenerate faces, with finite gradients)."""
    tri = as_float(vertices, "vertices")[jnp.asarray(faces)]
    n = jnp.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = safe_norm(n, keepdims=True)
    return n / jnp.where(length > 0, length, 1.0)


def vertex_normals(vertices: Float[Array, "V 3"], faces: Int[Array, "F 3"]) -> Float[Array, "V 3"]:
    """Unit vertex normals: the area-weighted mean of the normals of the faces around each."""
    vertices = as_float(vertices, "vertices")
    faces = jnp.asarray(faces)
    tri = vertices[faces]
    area_normal = jnp.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # 2 x area x n
    summed = jax.ops.segment_sum(
        jnp.repeat(area_normal, 3, axis=0), faces.reshape(-1), num_segments=vertices.shape[0]
    )
    length = safe_norm(summed, keepdims=True)
    return summed / jnp.where(length > 0, length, 1.0)


# ---------------------------------------------------------------------------------------
# Procedural meshes (NumPy: static sizes)


def _mesh(vertices: np.ndarray, faces: np.ndarray) -> Mesh:
    return Mesh(jnp.asarray(vertices, dtype=jnp.result_type(float)), jnp.asarray(faces, jnp.int32))


def cube(size: float = 1.0) -> Mesh:
    """An axis-aligned cube of edge `size` centred at the origin (8 vertices, 12 faces)."""
    corners = np.array(
        [[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    ) * float(size)
    # index = 4 * (x > 0) + 2 * (y > 0) + (z > 0); quads counter-clockwise from outside
    quads = np.array(
        [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    )
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return _mesh(corners, faces)


def icosphere(subdivisions: int = 2, radius: float = 1.0) -> Mesh:
    """A sphere made by subdividing an icosahedron: `20 * 4**subdivisions` faces."""
    subdivisions = static_int(subdivisions, "subdivisions", minimum=0)
    t = (1 + 5**0.5) / 2
    v = np.array(
        [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float
    )
    f = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    )
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(np.stack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]], 1), axis=-1)
        unique, inverse = np.unique(edges.reshape(-1, 2), axis=0, return_inverse=True)
        mid = v[unique].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = inverse.reshape(-1, 3) + len(v)  # midpoints of edges (01, 12, 20)
        f = np.concatenate([
            np.stack([f[:, 0], m[:, 0], m[:, 2]], 1),
            np.stack([f[:, 1], m[:, 1], m[:, 0]], 1),
            np.stack([f[:, 2], m[:, 2], m[:, 1]], 1),
            m,
        ])
        v = np.concatenate([v, mid])
    return _mesh(v * float(radius), f)


def revolve(profile, segments: int = 24) -> Mesh:
    """A surface of revolution about the y axis.

    **Arguments:**

    - `profile`: `(N, 2)` points `(radius, height)` from bottom to top. A point with
      radius 0 becomes a single pole vertex (use one at each end for a closed solid).
    - `segments`: number of steps around the axis (static).

    **Returns:** a `Mesh`, faces counter-clockwise seen from outside when the profile
    runs upwards.
    """
    segments = static_int(segments, "segments", minimum=3)
    profile = np.asarray(profile, float)
    if profile.ndim != 2 or profile.shape[1] != 2 or len(profile) < 2:
        raise ValueError(f"`profile` must have shape (N >= 2, 2), got {profile.shape}")
    if np.any(profile[:, 0] < 0):
        raise ValueError("`profile` radii must be >= 0")
    angle = 2 * np.pi * np.arange(segments) / segments
    pole = profile[:, 0] == 0
    # vertex index of (profile point i, segment j): poles have one vertex
    counts = np.where(pole, 1, segments)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    ring = np.stack([
        profile[:, :1] * np.sin(angle), np.broadcast_to(profile[:, 1:], (len(profile), segments)),
        profile[:, :1] * np.cos(angle)
    ], -1)  # (N, segments, 3)
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
    """A closed cylinder about the y axis, centred at the origin."""
    h = float(height) / 2
    r = float(radius)
    return revolve([[0, -h], [r, -h], [r, h], [0, h]], segments)


def torus(major_radius: float = 1.0, minor_radius: float = 0.35, major_segments: int = 32,
          minor_segments: int = 16) -> Mesh:
    """A torus about the y axis: a tube of `minor_radius` around a circle of `major_radius`."""
    nu = static_int(major_segments, "major_segments", minimum=3)
    nv = static_int(minor_segments, "minor_segments", minimum=3)
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
    """
    body = [
        (0.0, 0.0), (0.80, 0.0), (0.82, 0.06), (0.80, 0.13), (0.70, 0.18), (0.66, 0.24),
        (0.56, 0.30), (0.44, 0.36), (0.38, 0.46), (0.33, 0.62), (0.29, 0.82), (0.26, 1.02),
        (0.25, 1.12), (0.44, 1.16), (0.46, 1.21), (0.42, 1.26), (0.27, 1.30),
    ]
    # the head: a sphere of radius 0.34 centred at height 1.56, from its lower neck up
    angles = np.linspace(-0.30 * np.pi, 0.5 * np.pi, 10)
    head = [(0.34 * np.cos(a), 1.56 + 0.34 * np.sin(a)) for a in angles]
    head[-1] = (0.0, head[-1][1])
    return revolve(np.array(body + head), segments)


#: Models shipped in `data/meshes/`: file name -> function making the mesh.
SHIPPED_MODELS = {"pawn.obj": pawn}


def shipped_model_path(name: str = "pawn.obj") -> pathlib.Path:
    """Path of a shipped model file in `data/meshes/`."""
    if name not in SHIPPED_MODELS:
        raise ValueError(f"`name` must be one of {sorted(SHIPPED_MODELS)}, got {name!r}")
    return DATA_DIR / name


def write_shipped_models(directory: str | os.PathLike | None = None) -> list[pathlib.Path]:
    """(Re)write every model of `SHIPPED_MODELS` as OBJ into `directory` (default `DATA_DIR`)."""
    directory = pathlib.Path(directory) if directory is not None else DATA_DIR
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in SHIPPED_MODELS.items():
        comment = f"{name}: made by gfxlab.mesh.{make.__name__}(); redistributable with gfxlab"
        write_obj(directory / name, make(), comment=comment)
        paths.append(directory / name)
    return paths


# ---------------------------------------------------------------------------------------
# Wavefront OBJ


def obj_text(mesh: Mesh, *, comment: str | None = None, precision: int = 6) -> str:
    """The Wavefront OBJ text of `mesh` (`v x y z [r g b]` and 1-based `f i j k` lines)."""
    precision = static_int(precision, "precision", minimum=1)
    v = np.asarray(mesh.vertices, float)
    if mesh.colors is not None:
        v = np.concatenate([v, np.asarray(mesh.colors, float)[:, :3]], axis=1)
    v = np.round(v, precision) + 0.0  # no "-0.000000"
    fmt = " ".join([f"%.{precision}f"] * v.shape[1])
    lines = [f"# {line}" for line in (comment or "").splitlines()]
    lines += ["v " + fmt % tuple(row) for row in v]
    lines += [f"f {a} {b} {c}" for a, b, c in np.asarray(mesh.faces) + 1]
    return "\n".join(lines) + "\n"


def write_obj(path: str | os.PathLike, mesh: Mesh, *, comment: str | None = None) -> None:
    """Write `mesh` to a Wavefront OBJ file (vertex colours as `v x y z r g b`)."""
    if not isinstance(mesh, Mesh):
        raise TypeError(f"`mesh` must be a gfxlab.mesh.Mesh, got {type(mesh).__name__}")
    pathlib.Path(path).write_text(obj_text(mesh, comment=comment))


def read_obj(path: str | os.PathLike) -> Mesh:
    """Read a Wavefront OBJ file into a `Mesh`.

    Reads `v` lines (with optional `r g b` colours) and `f` lines (`i`, `i/t`, `i/t/n`,
    `i//n`, negative indices; polygons are split into triangle fans). Other statements
    (normals, texture coordinates, groups, materials) are ignored.
    """
    vertices, colors, faces = [], [], []
    for number, raw in enumerate(pathlib.Path(path).read_text().splitlines(), start=1):
        parts = raw.split("#", 1)[0].split()
        if not parts:
            continue
        try:
            if parts[0] == "v":
                values = [float(p) for p in parts[1:]]
                if len(values) not in (3, 4, 6, 7):
                    raise ValueError("expected `v x y z [w]` or `v x y z r g b`")
                vertices.append(values[:3])
                if len(values) >= 6:
                    colors.append(values[-3:])
            elif parts[0] == "f":
                idx = [int(p.split("/")[0]) for p in parts[1:]]
                if len(idx) < 3:
                    raise ValueError("a face needs at least 3 vertices")
                idx = [i - 1 if i > 0 else len(vertices) + i for i in idx]
                faces.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
        except ValueError as err:
            raise ValueError(f"{path}: line {number}: cannot read {raw!r}: {err}") from None
    if not vertices or not faces:
        raise ValueError(f"{path}: no vertices or no faces found")
    if colors and len(colors) != len(vertices):
        raise ValueError(f"{path}: some vertices have colours and others do not")
    faces = np.asarray(faces)
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise ValueError(f"{path}: a face refers to a vertex that does not exist")
    return Mesh(
        jnp.asarray(vertices, dtype=jnp.result_type(float)),
        jnp.asarray(faces, jnp.int32),
        jnp.asarray(colors, dtype=jnp.result_type(float)) if colors else None,
    )
