"""Wavefront OBJ reading and writing (`v`, `vt`, `vn`, `f`, `mtllib`/`map_Kd`)."""

from __future__ import annotations

import os
import pathlib

import jax
import jax.numpy as jnp
import numpy as np

from .._checks import static_int
from . import Mesh


def obj_text(mesh: Mesh, *, comment: str | None = None, precision: int = 6) -> str:
    """The Wavefront OBJ text of `mesh`.

    `v x y z [r g b]` lines, `vt u v` and `vn x y z` lines when the mesh has them, and
    1-based `f i j k` (or `f i/t/n ...`) lines. A texture image is not written.
    """
    if not isinstance(mesh, Mesh):
        raise TypeError(f"`mesh` must be a gfxlab.mesh.Mesh, got {type(mesh).__name__}")
    precision = static_int(precision, "precision", minimum=1, maximum=17)
    v = np.asarray(mesh.vertices, float)
    if mesh.colors is not None:
        v = np.concatenate([v, np.asarray(mesh.colors, float)[:, :3]], axis=1)

    def rows(tag, table):
        table = np.round(np.asarray(table, float), precision) + 0.0  # no "-0.000000"
        fmt = " ".join([f"%.{precision}f"] * table.shape[1])
        return [f"{tag} " + fmt % tuple(row) for row in table]

    lines = [f"# {line}" for line in (comment or "").splitlines()]
    lines += rows("v", v)
    corners = [np.asarray(mesh.faces) + 1]
    if mesh.uvs is not None:
        lines += rows("vt", mesh.uvs)
    if mesh.normals is not None:
        lines += rows("vn", mesh.normals)
    uv = np.asarray(mesh.uv_faces) + 1 if mesh.uvs is not None else None
    vn = np.asarray(mesh.normal_faces) + 1 if mesh.normals is not None else None
    for f, face in enumerate(corners[0]):
        parts = []
        for k in range(3):
            item = str(face[k])
            if uv is not None or vn is not None:
                item += "/" + (str(uv[f, k]) if uv is not None else "")
            if vn is not None:
                item += "/" + str(vn[f, k])
            parts.append(item)
        lines.append("f " + " ".join(parts))
    return "\n".join(lines) + "\n"


def write_obj(path: str | os.PathLike, mesh: Mesh, *, comment: str | None = None) -> None:
    """Write `mesh` to a Wavefront OBJ file (vertex colours as `v x y z r g b`)."""
    pathlib.Path(path).write_text(obj_text(mesh, comment=comment))


def _obj_index(text: str, count: int) -> int:
    i = int(text)
    return i - 1 if i > 0 else count + i


def _read_texture(path: pathlib.Path) -> jax.Array:
    """The diffuse map named by a material file, as floats in [0, 1] (Pillow, lazily)."""
    from PIL import Image  # noqa: PLC0415 - keep `import gfxlab` free of Pillow

    from .._pixels import to_float

    with Image.open(path) as image:
        return to_float(np.asarray(image.convert("RGB")), "texture")


def _material_maps(obj_path: pathlib.Path, library: str) -> dict[str, pathlib.Path]:
    """`newmtl` name -> `map_Kd` image path of a `.mtl` file beside the OBJ file."""
    maps, current = {}, None
    mtl = obj_path.parent / library
    for raw in _read_text(mtl, "material library").splitlines():
        parts = raw.split("#", 1)[0].split()
        if parts and parts[0] == "newmtl":
            current = " ".join(parts[1:])
        elif parts and parts[0] == "map_Kd" and current is not None:
            maps[current] = mtl.parent / parts[-1]
    return maps


def _read_text(path: pathlib.Path, what: str) -> str:
    try:
        return path.read_text()
    except UnicodeDecodeError:
        raise ValueError(
            f"`path` {str(path)!r} is not a text {what} (it holds bytes that are not UTF-8)"
        ) from None


def _parse_obj(path: pathlib.Path):
    tables = {"v": [], "vt": [], "vn": []}
    colors, corners, libraries, materials = [], [], [], []
    for number, raw in enumerate(_read_text(path, "OBJ file").splitlines(), start=1):
        parts = raw.split("#", 1)[0].split()
        if not parts:
            continue
        try:
            if parts[0] in tables:
                values = [float(p) for p in parts[1:]]
                allowed = {"v": (3, 4, 6, 7), "vt": (2, 3), "vn": (3,)}[parts[0]]
                if len(values) not in allowed:
                    raise ValueError(f"expected {allowed} numbers after `{parts[0]}`")
                tables[parts[0]].append(values[:2] if parts[0] == "vt" else values[:3])
                if parts[0] == "v" and len(values) >= 6:
                    colors.append(values[-3:])
            elif parts[0] == "f":
                fields = [(p.split("/") + ["", ""])[:3] for p in parts[1:]]
                if len(fields) < 3:
                    raise ValueError("a face needs at least 3 vertices")
                counts = [len(tables[k]) for k in ("v", "vt", "vn")]
                idx = [
                    [_obj_index(t, n) if t else -1 for t, n in zip(f, counts, strict=True)]
                    for f in fields
                ]
                for k in range(1, len(idx) - 1):
                    corners.append([idx[0], idx[k], idx[k + 1]])
            elif parts[0] == "mtllib":
                libraries.append(" ".join(parts[1:]))
            elif parts[0] == "usemtl":
                materials.append(" ".join(parts[1:]))
        except ValueError as err:
            raise ValueError(f"{path}: line {number}: cannot read {raw!r}: {err}") from None
    return (
        tables,
        colors,
        np.asarray(corners, dtype=np.int64).reshape(-1, 3, 3),
        libraries,
        (materials),
    )


def read_obj(path: str | os.PathLike) -> Mesh:
    """Read a Wavefront OBJ file into a `Mesh`.

    Reads `v` lines (with optional `r g b` colours), `vt` texture coordinates, `vn`
    normals and `f` lines (`i`, `i/t`, `i/t/n`, `i//n`, negative indices; polygons are
    split into triangle fans). With `mtllib`/`usemtl`, the first used material's `map_Kd`
    image becomes the mesh's `texture` (read with Pillow). `vt`/`vn` are kept only when
    every face corner refers to one. Groups and other statements
    are ignored. A file that is not text raises a `ValueError` naming it.
    """
    if path is None:
        raise TypeError("`path` must be a file path, got None")
    path = pathlib.Path(path)
    tables, colors, corners, libraries, materials = _parse_obj(path)
    vertices = tables["v"]
    if not vertices or not len(corners):
        raise ValueError(f"{path}: no vertices or no faces found")
    if colors and len(colors) != len(vertices):
        raise ValueError(f"{path}: some vertices have colours and others do not")
    extra = {}
    for column, (key, values, index) in enumerate(
        (("v", vertices, None), ("vt", tables["vt"], "uv"), ("vn", tables["vn"], "normal"))
    ):
        ids = corners[..., column]
        if index is not None and (not values or np.any(ids == -1)):
            continue  # texture coordinates / normals only when every corner has them
        if ids.min() < 0 or ids.max() >= len(values):
            raise ValueError(f"{path}: a face refers to a `{key}` entry that does not exist")
        if index is not None:
            extra[index + "s"] = jnp.asarray(values, dtype=jnp.result_type(float))
            extra[index + "_faces"] = jnp.asarray(ids, jnp.int32)
    if "uvs" in extra and libraries:
        maps = {}
        for library in libraries:
            maps.update(_material_maps(path, library))
        used = [m for m in materials if m in maps]
        if used:
            extra["texture"] = _read_texture(maps[used[0]])
    return Mesh(
        jnp.asarray(vertices, dtype=jnp.result_type(float)),
        jnp.asarray(corners[..., 0], jnp.int32),
        jnp.asarray(colors, dtype=jnp.result_type(float)) if colors else None,
        **extra,
    )
