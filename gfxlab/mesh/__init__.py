"""Triangle meshes: a `Mesh` pytree, procedural shapes, normals, OBJ files and mesh losses.

Faces are triangles given as vertex indices, ordered counter-clockwise when seen from
outside, so `face_normals` point outwards. Procedural meshes are built with NumPy (their
sizes are static) and returned as JAX arrays, so a `Mesh` can be transformed, rendered
and fitted like any other pytree.

A `Mesh` may carry per-vertex colours, texture coordinates (`uvs` with their own
per-corner indices `uv_faces`, as OBJ `vt` and `f v/vt` give them), explicit normals
(`normals`, `normal_faces`, from OBJ `vn`) and a diffuse `texture` image. This module is
the one owner of face and colour validation (`check_faces`, `check_colors`); the
renderer calls it. The losses (`laplacian_loss`, `edge_length_loss`,
`normal_consistency_loss`) and `chamfer_distance` keep a fitted shape sane.

The model shipped in `data/meshes/` (a chess pawn, a surface of revolution) is written
by `write_shipped_models`, so the file is reproducible from this code.

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab.mesh import face_normals, icosphere
    >>> sphere = icosphere(1)
    >>> sphere.num_vertices, sphere.faces.shape
    (42, (80, 3))
    >>> centres = sphere.vertices[sphere.faces].mean(axis=1)
    >>> normals = face_normals(sphere.vertices, sphere.faces)
    >>> bool(jnp.all(jnp.sum(normals * centres, -1) > 0))  # facing outwards
    True
"""

from __future__ import annotations

import functools
import os
import pathlib
import re

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from .. import transforms as tf
from .._checks import (
    MAX_ELEMENTS,
    as_float,
    check_finite,
    check_range,
    check_shape,
    checked_jit,
    host_value,
    is_traced,
    safe_normalize,
    static_int,
    value_error_if,
)
from .._resources import data_folder

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
    "check_faces",
    "check_colors",
    "laplacian_loss",
    "edge_length_loss",
    "normal_consistency_loss",
    "chamfer_distance",
    "MAX_SUBDIVISIONS",
    "MAX_SEGMENTS",
]

#: Largest `icosphere` subdivision level (20 * 4**7 = 327,680 faces).
MAX_SUBDIVISIONS = 7

#: Most steps around an axis for `revolve`, `cylinder`, `torus` and `pawn`.
MAX_SEGMENTS = 1 << 16

#: `data/meshes/` of the repository.
DATA_DIR = data_folder("meshes")


def check_faces(faces, num_vertices: int, name: str = "faces") -> jax.Array:
    """`faces` as an integer `(F, 3)` array whose entries index `num_vertices` vertices.

    The one owner of face validation (the `Mesh` constructor, the normals and the
    renderer call it). Raises `TypeError` for non-integer faces and `ValueError` for a
    wrong shape or an index outside `0 <= index < num_vertices` (-1 too), eagerly and
    under `jax.jit` (`equinox.error_if`).
    """
    _check_label(name)
    num_vertices = static_int(num_vertices, "num_vertices", minimum=0, maximum=MAX_ELEMENTS)
    faces = _index_array(faces, name)
    host = host_value(faces)  # concrete indices: checked in NumPy, without a dispatch
    values = faces if host is None else host
    return value_error_if(
        faces,
        (values < 0) | (values >= num_vertices),
        f"`{name}` must index the {num_vertices} vertices (0 <= index < {num_vertices})",
    )


def _index_array(faces, name: str) -> jax.Array:
    """The static part of `check_faces`: an integer `(F, 3)` JAX array."""
    if faces is None or isinstance(faces, str | bytes):
        raise TypeError(f"`{name}` must be an (F, 3) array of vertex indices, got {faces!r:.40}")
    try:
        faces = jnp.asarray(faces)
    except (TypeError, ValueError) as err:
        raise TypeError(f"`{name}` must be an (F, 3) array of vertex indices ({err})") from None
    if not jnp.issubdtype(faces.dtype, jnp.integer):
        raise TypeError(f"`{name}` must hold integer vertex indices, got dtype {faces.dtype}")
    check_shape(faces, name, (None, 3))
    return faces


def check_colors(colors, count: int, name: str = "colors", per: str = "vertex", *, dtype=None):
    """`colors` as a float `(count, C)` array: one colour per vertex (or per face).

    The one owner of color validation (`Mesh` and the hidden-surface methods call it).
    `per` names what each row belongs to (`"vertex"`, `"face"` or `"triangle"`); NaN
    and inf are errors.
    """
    _check_label(name)
    count = static_int(count, "count", minimum=0, maximum=MAX_ELEMENTS)
    if not isinstance(per, str) or per not in _PER:
        raise ValueError(f"`per` must be one of {tuple(_PER)}, got {per!r:.40}")
    colors = as_float(colors, name)
    if dtype is not None:
        colors = colors.astype(dtype)
    _check_color_shape(colors, count, name, per)
    return check_finite(colors, name)


def _check_color_shape(colors: jax.Array, count: int, name: str, per: str) -> None:
    if colors.ndim != 2 or colors.shape[0] != count or not 1 <= colors.shape[1] <= 4:
        raise ValueError(
            f"`{name}` must have shape ({count}, C), C = 1 to 4 (one color per {per}, "
            f"{count} {_PER[per]}), got shape {tuple(colors.shape)}"
        )


_PER = {"vertex": "vertices", "face": "faces", "triangle": "triangles"}  # their plurals
_LABEL = re.compile(r"[A-Za-z_][\w.]*(\[\d+\])?")


def _check_label(name) -> None:
    """`name` labels an argument in messages: an identifier such as `uv_faces`."""
    if not isinstance(name, str):
        raise TypeError(f"`name` must be an argument name (str), got {name!r:.40}")
    if not _LABEL.fullmatch(name):
        raise ValueError(f"`name` must be an argument name such as 'faces', got {name!r:.40}")


# `Mesh` validates as every gfxlab Module does (docs/architecture.md, Conventions): each
# field's converter checks what that argument alone decides, `__check_init__` the
# relations between fields (concrete values; traced faces are checked by the functions
# that index with them, `check_faces`).


def _vertices_field(vertices) -> jax.Array:
    vertices = as_float(vertices, "vertices")
    check_shape(vertices, "vertices", (None, 3))
    return check_finite(vertices, "vertices")


def _optional_field(name: str, convert):
    """The converter of an optional field: `None` stays `None`, else `convert(value, name)`."""

    def optional(value):
        return None if value is None else convert(value, name)

    optional.__name__ = f"_as_{name}"
    return optional


def _table(values, name: str, *, width: int) -> jax.Array:
    values = as_float(values, name)
    check_shape(values, name, (None, width))
    return check_finite(values, name)


def _unit_values(values, name: str, *, rank: int) -> jax.Array:
    values = as_float(values, name)
    check_shape(values, name, (None,) * rank)
    return check_range(values, name, minimum=0, maximum=1, what="colour values")


def _check_indexed(mesh, name: str, index_name: str) -> None:
    """An optional per-corner table `name` and its `(F, 3)` indices `index_name`."""
    values, index = getattr(mesh, name), getattr(mesh, index_name)
    if values is None and index is None:
        return
    if values is None or index is None:
        raise ValueError(f"`{name}` and `{index_name}` must be given together")
    if index.shape != mesh.faces.shape:
        raise ValueError(
            f"`{index_name}` must have the shape of `faces` {mesh.faces.shape}, got {index.shape}"
        )
    _check_bounds(index, values.shape[0], index_name)


def _check_bounds(index: jax.Array, count: int, name: str) -> None:
    """`check_faces`'s index bound, for concrete indices (traced ones: where used)."""
    if not is_traced(index):
        check_faces(index, count, name)


class Mesh(eqx.Module):
    """A triangle mesh: vertex positions, triangles, and optional per-vertex colours,
    texture coordinates, normals and a texture.

    A pytree: its fields are the constructor's arguments, checked once at construction.
    As `params` of `gfxlab.fit`, every float field is fitted (vertices, colours, uvs,
    normals, texture) and only construction checks ranges: colours or a texture leave
    [0, 1] unless held (`fixed=`) or bounded (`bounds=`). To fit the shape alone, fit
    the vertices and pass them to `render(..., vertices=...)`.
    """

    vertices: Float[Array, "V 3"] = eqx.field(converter=_vertices_field)
    faces: Int[Array, "F 3"] = eqx.field(converter=functools.partial(_index_array, name="faces"))
    colors: Float[Array, "V C"] | None = eqx.field(
        default=None, converter=_optional_field("colors", functools.partial(_unit_values, rank=2))
    )
    uvs: Float[Array, "T 2"] | None = eqx.field(
        default=None, converter=_optional_field("uvs", functools.partial(_table, width=2))
    )
    uv_faces: Int[Array, "F 3"] | None = eqx.field(
        default=None, converter=_optional_field("uv_faces", _index_array)
    )
    normals: Float[Array, "N 3"] | None = eqx.field(
        default=None, converter=_optional_field("normals", functools.partial(_table, width=3))
    )
    normal_faces: Int[Array, "F 3"] | None = eqx.field(
        default=None, converter=_optional_field("normal_faces", _index_array)
    )
    texture: Float[Array, "Ht Wt C"] | None = eqx.field(
        default=None, converter=_optional_field("texture", functools.partial(_unit_values, rank=3))
    )

    def __init__(
        self,
        vertices,
        faces,
        colors=None,
        *,
        uvs=None,
        uv_faces=None,
        normals=None,
        normal_faces=None,
        texture=None,
    ):
        """**Arguments:**

        - `vertices`: `(V, 3)` positions (floating, finite; fitted by `gfxlab.fit`).
        - `faces`: `(F, 3)` integer vertex indices, counter-clockwise seen from outside
          (integer, so held fixed by `gfxlab.fit`); each must index `vertices`.
        - `colors`: optional `(V, C)` per-vertex colours in [0, 1] (usually `C = 3`,
          `C` from 1 to 4; finite), stored in the dtype of `vertices`.
        - `uvs`, `uv_faces`: optional texture coordinates `(T, 2)` (u right, v up, the
          texture's lower-left corner at (0, 0)) and their per-corner indices `(F, 3)`;
          given together or not at all.
        - `normals`, `normal_faces`: optional normals `(N, 3)` and per-corner indices
          `(F, 3)`, given together (the renderer otherwise uses `vertex_normals`).
        - `texture`: optional diffuse map `(Ht, Wt, C)` in [0, 1] (finite), row 0 at the top; needs
          `uvs` and `uv_faces`.

        Bad shapes, dtypes, indices or values (NaN, inf, colours outside [0, 1]) raise
        `TypeError`/`ValueError` naming the argument; the value checks also under
        `jax.jit` (`gfxlab._checks.value_error_if`), and traced indices where they are
        used (`check_faces`).
        """
        # Only the arguments are assigned here (the converters and `__check_init__` check
        # them); `colors` is the one field that depends on another argument's dtype.
        if colors is not None:
            colors = as_float(colors, "colors").astype(as_float(vertices, "vertices").dtype)
        self.vertices, self.faces, self.colors = vertices, faces, colors
        self.uvs, self.uv_faces = uvs, uv_faces
        self.normals, self.normal_faces = normals, normal_faces
        self.texture = texture

    def __check_init__(self):
        """Relations between fields: indices within their tables, one colour per vertex."""
        _check_bounds(self.faces, self.vertices.shape[0], "faces")
        if self.colors is not None:
            _check_color_shape(self.colors, self.vertices.shape[0], "colors", "vertex")
        _check_indexed(self, "uvs", "uv_faces")
        _check_indexed(self, "normals", "normal_faces")
        if self.texture is not None and self.uvs is None:
            raise ValueError("a `texture` needs texture coordinates `uvs` and `uv_faces`")
        if (
            self.texture is not None
            and self.colors is not None
            and self.texture.shape[-1] != self.colors.shape[-1]
        ):
            raise ValueError(
                f"`texture` has {self.texture.shape[-1]} colour channels and `colors` "
                f"{self.colors.shape[-1]}: the render multiplies them, so they need one count"
            )
        if self.texture is not None and 0 in self.texture.shape:
            raise ValueError(
                f"`texture` must hold at least one texel, got shape {self.texture.shape}"
            )

    @property
    def num_vertices(self) -> int:
        """The number of vertices `V`."""
        return self.vertices.shape[0]

    @property
    def num_faces(self) -> int:
        """The number of triangles `F`."""
        return self.faces.shape[0]

    def _with(self, **changes) -> Mesh:
        fields = {
            k: getattr(self, k)
            for k in ("colors", "uvs", "uv_faces", "normals", "normal_faces", "texture")
        }
        fields.update(changes)
        vertices = fields.pop("vertices", self.vertices)
        return Mesh(vertices, self.faces, **fields)

    def triangles(self) -> Float[Array, "F 3 3"]:
        """The `(F, 3, 3)` corner positions of every face (traced `faces` are checked
        to index `vertices`, as in `face_normals`)."""
        return self.vertices[check_faces(self.faces, self.num_vertices)]

    def transform(self, matrix: Float[Array, "4 4"]) -> Mesh:
        """The mesh with `matrix` (homogeneous 4x4, column vectors) applied to its vertices.

        Explicit `normals` are dropped (they would need the inverse transpose); the
        renderer then uses `vertex_normals`.
        """
        matrix = as_float(matrix, "matrix")
        check_shape(matrix, "matrix", (4, 4))
        return self._with(vertices=tf.apply(matrix, self.vertices), normals=None, normal_faces=None)

    def with_colors(self, colors) -> Mesh:
        """The mesh with per-vertex `colors`; a single colour `(C,)` is used for every vertex."""
        colors = as_float(colors, "colors")
        if colors.ndim == 1:
            colors = jnp.broadcast_to(colors, (self.num_vertices, colors.shape[0]))
        return self._with(colors=colors)

    def with_vertices(self, vertices) -> Mesh:
        """The mesh with new vertex positions (same connectivity and attributes: as many
        vertices as before)."""
        vertices = as_float(vertices, "vertices")
        check_shape(vertices, "vertices", (self.num_vertices, 3))
        return self._with(vertices=vertices)

    def face_normals(self) -> Float[Array, "F 3"]:
        """Unit normals of the faces (see the function `face_normals`)."""
        return face_normals(self.vertices, self.faces)

    def vertex_normals(self) -> Float[Array, "V 3"]:
        """Area-weighted unit normals at the vertices (see the function `vertex_normals`)."""
        return vertex_normals(self.vertices, self.faces)


def face_normals(vertices: Float[Array, "V 3"], faces: Int[Array, "F 3"]) -> Float[Array, "F 3"]:
    """Unit outward normals of the faces (zero for degenerate faces, with finite gradients).

    Out-of-range face indices (-1 too) and NaN/inf vertices are errors (see
    `check_faces`). Called eagerly it is one compiled call.
    """
    vertices = as_float(vertices, "vertices")
    check_shape(vertices, "vertices", (None, 3))
    return _face_normals_kernel(vertices, _static_faces(faces, vertices))


def _static_faces(faces, vertices):
    """The static part of `check_faces` (type and shape); the range is checked traced."""
    faces = _index_array(faces, "faces")
    if vertices.shape[0] == 0 and faces.shape[0] > 0:
        raise ValueError(f"`vertices` is empty, but `faces` {faces.shape} index vertices")
    return faces


def _checked(vertices, faces):
    vertices = check_finite(vertices, "vertices")
    return vertices, check_faces(faces, vertices.shape[0])


def _cross_normals(vertices, faces):
    tri = vertices[faces]
    return jnp.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])


@checked_jit
def _face_normals_kernel(vertices, faces):
    return safe_normalize(_cross_normals(*_checked(vertices, faces)))


def vertex_normals(vertices: Float[Array, "V 3"], faces: Int[Array, "F 3"]) -> Float[Array, "V 3"]:
    """Unit vertex normals: the area-weighted mean of the normals of the faces around each.

    Out-of-range face indices (-1 too) and NaN/inf vertices are errors (see
    `check_faces`). Called eagerly it is one compiled call.
    """
    vertices = as_float(vertices, "vertices")
    check_shape(vertices, "vertices", (None, 3))
    return _vertex_normals_kernel(vertices, _static_faces(faces, vertices))


@checked_jit
def _vertex_normals_kernel(vertices, faces):
    vertices, faces = _checked(vertices, faces)
    area_normal = _cross_normals(vertices, faces)  # 2 x area x n
    summed = jax.ops.segment_sum(
        jnp.repeat(area_normal, 3, axis=0), faces.reshape(-1), num_segments=vertices.shape[0]
    )
    return safe_normalize(summed)


# ---------------------------------------------------------------------------------------
# Procedural meshes (NumPy: static sizes), in `_shapes`; they build the `Mesh` above.
from ._shapes import cube, cylinder, icosphere, pawn, revolve, torus  # noqa: E402

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


from ._losses import (  # noqa: E402 - the losses and OBJ I/O use Mesh defined above
    chamfer_distance,
    edge_length_loss,
    laplacian_loss,
    normal_consistency_loss,
)
from ._obj import obj_text, read_obj, write_obj  # noqa: E402
