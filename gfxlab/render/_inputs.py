"""The argument checks of the render entries (`render`'s inputs and options, the
`Rendering` buffers, `interpolate`, `antialias`, `soft_silhouette`), batched cameras, and
the static configuration `render` compiles with (its tile capacity measured from the
geometry)."""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import (
    as_float,
    as_int,
    check_finite,
    check_shape,
    is_traced,
    positive,
    static_bool,
    static_shape,
    value_error_if,
)
from ..mesh import check_faces
from ..viewing import Camera
from ._project import check_mesh_camera, measured_tile_count
from ._tiles import any_traced, check_options, resolve_capacity
from .shading import _check_lights, check_ambient, check_brdf


class RenderConfig(NamedTuple):
    """The static (hashable) part of a `render` call."""

    shape: tuple[int, int]
    soft: bool
    eps: float
    tile_size: int
    capacity: int
    tiles_per_step: int
    antialias: bool
    cull_backfaces: bool
    batched_vertices: bool
    batched_camera: bool
    reference: bool = False  # plain autodiff, every pixel against every face


_POSE_FIELDS, _LENS_FIELDS = ("eye", "target", "up"), ("fov_y", "aspect", "near", "far")


def camera_batch(camera: Camera) -> int | None:
    """The number of views of `camera` (None: one view). Each field is unbatched
    (`(3,)` for the pose, `()` for the lens) or has one leading batch axis, of one size
    across the fields; anything else is an error naming the field."""
    sizes = {}
    for name in _POSE_FIELDS + _LENS_FIELDS:
        shape = getattr(camera, name).shape
        core = (3,) if name in _POSE_FIELDS else ()
        if shape != core:
            if len(shape) != len(core) + 1 or shape[1:] != core:
                raise ValueError(
                    f"`camera.{name}` must have shape {core} or (B, *{core}) for a batch of "
                    f"B views, got {shape}"
                )
            sizes[name] = shape[0]
    if len(set(sizes.values())) > 1:
        listed = ", ".join(f"`camera.{n}` {b}" for n, b in sizes.items())
        raise ValueError(f"the camera's fields must batch one number of views, got {listed}")
    return next(iter(sizes.values()), None)


def _explicit_axes() -> tuple[str, ...]:
    """Names of the Explicit axes of the mesh set by `jax.set_mesh` (none where JAX lacks
    the API or no mesh is set)."""
    get = getattr(jax.sharding, "get_abstract_mesh", None)
    explicit = getattr(getattr(jax.sharding, "AxisType", None), "Explicit", None)
    mesh = get() if get is not None else None
    if mesh is None or explicit is None or getattr(mesh, "empty", True):
        return ()
    return tuple(n for n, t in zip(mesh.axis_names, mesh.axis_types, strict=True) if t == explicit)


def check_mesh_axes(name: str, **inputs) -> None:
    """Under a `jax.set_mesh` mesh with Explicit axes, refuse `name`: always when no
    `inputs` are given (`shard_cameras`), else when a concrete array of one of them
    lies on several devices (`render`, naming that input). The renderer shards views on
    Auto axes only, and JAX's own error there names no argument ("context mesh ...
    should match the aval mesh"); unsharded inputs render under any mesh."""
    explicit = _explicit_axes()
    if not explicit:
        return
    fix = (
        f"the mesh set by `jax.set_mesh` has Explicit axes {explicit}, and `{name}` shards "
        "views on Auto axes only: make the mesh with `axis_types=(jax.sharding.AxisType"
        ".Auto, ...)`, or shard and render outside `jax.set_mesh`"
    )
    if not inputs:
        raise ValueError(f"`{name}` cannot run here: {fix}")
    for argument, tree in inputs.items():
        for x in jax.tree_util.tree_leaves(tree):
            if isinstance(x, jax.Array) and not is_traced(x) and len(x.sharding.device_set) > 1:
                raise ValueError(
                    f"`{argument}` is sharded over {len(x.sharding.device_set)} devices, but {fix}"
                )


def batched_camera(camera: Camera, batch: int) -> Camera:
    """Every field of a camera (see `camera_batch`) with the leading batch axis."""
    fields = {}
    for name in _POSE_FIELDS + _LENS_FIELDS:
        core = (3,) if name in _POSE_FIELDS else ()
        fields[name] = jnp.broadcast_to(getattr(camera, name), (batch,) + core)
    eye = fields.pop("eye")
    return Camera(eye, fields.pop("target"), fields.pop("up"), **fields)


def check_render_inputs(mesh, camera, vertices, attributes):
    """`(mesh, vertices, camera, batched, attributes)` of a render, checked: the mesh's
    faces index its vertices (eagerly, or tied to the faces when traced: a `Mesh` built
    from concrete faces was checked, but not one changed by `eqx.tree_at` or traced)."""
    check_mesh_camera(mesh, camera)
    if mesh.num_faces == 0:
        raise ValueError("`mesh` has no faces: there is nothing to render")
    faces = check_faces(mesh.faces, mesh.num_vertices, "mesh.faces")
    if is_traced(mesh.faces):
        mesh = eqx.tree_at(lambda m: m.faces, mesh, faces)
    if vertices is None:
        vertices = mesh.vertices
    else:
        vertices = as_float(vertices, "vertices")
        check_shape(vertices, "vertices", (..., mesh.num_vertices, 3))
        if vertices.ndim not in (2, 3):
            raise ValueError(
                f"`vertices` must have shape (V, 3) or (B, V, 3), got {vertices.shape}"
            )
        vertices = check_finite(vertices, "vertices")
    views = camera_batch(camera)
    if views is not None and vertices.ndim == 3 and vertices.shape[0] != views:
        raise ValueError(
            f"`vertices` batches {vertices.shape[0]} meshes but `camera` {views} views: "
            "they must be equal (or one of them unbatched)"
        )
    batched = views is not None
    if batched:
        camera = batched_camera(camera, views)
    if attributes is not None:
        attributes = as_float(attributes, "attributes")
        check_shape(attributes, "attributes", (mesh.num_vertices, None))
        attributes = check_finite(attributes, "attributes")
    return mesh, vertices, camera, batched, attributes


def _float_option(x, name: str, dtype):
    """A float option as `dtype`: a Python number or NumPy value stays in NumPy (each
    eager JAX operation on a scalar costs tens of microseconds; the jitted call takes
    NumPy arguments as they are), anything else becomes a JAX array."""
    if isinstance(x, int | float | np.ndarray | np.generic) and not isinstance(x, bool):
        arr = np.asarray(x)
        if arr.dtype.kind in "iuf":
            return arr.astype(dtype)
    return jnp.asarray(as_float(x, name), dtype)


def render_options(mesh, dtype, sigma, gamma, ambient, background, eps, eps_background, sizes):
    """`render`'s checked numeric options: `(params, ambient, background, sizes)` with
    `params = (sigma, gamma, eps_background)` and `sizes = (tile_size, capacity,
    tiles_per_step)`."""
    sigma = _float_option(sigma, "sigma", dtype)
    gamma = _float_option(gamma, "gamma", dtype)
    check_shape(sigma, "sigma", ())
    check_shape(gamma, "gamma", ())
    sigma, *sizes = check_options(sigma, eps, *sizes)
    gamma = positive(gamma, "gamma")
    channels = (
        mesh.colors.shape[1]
        if mesh.colors is not None
        else (mesh.texture.shape[-1] if mesh.texture is not None else 3)
    )
    background = check_finite(_float_option(background, "background", dtype), "background")
    if background.ndim > 1 or background.size not in (1, channels):
        raise ValueError(
            f"`background` must be a scalar or a colour ({channels},), got shape {background.shape}"
        )
    xp = np if isinstance(background, np.ndarray) else jnp
    background = xp.broadcast_to(background, (channels,))
    # only a lit render uses `ambient` (an unlit one refuses any but a concrete 0:
    # `check_shading`), so its traced check is never dead code
    ambient = check_ambient(_float_option(ambient, "ambient", dtype), channels, dtype)
    eps_background = _float_option(eps_background, "eps_background", dtype)
    check_shape(eps_background, "eps_background", ())
    eps_background = positive(eps_background, "eps_background")
    return (sigma, gamma, eps_background), ambient, background, tuple(sizes)


def check_shading(lights, brdf, ambient, channels: int):
    """`render`'s shading options: `(lights, brdf)` checked (`lights=None`: unlit, which
    takes neither a `brdf` nor an `ambient` term; a concrete 0 is the default)."""
    lights = _check_lights(lights, channels)
    if lights is not None:
        brdf = check_brdf(brdf)
        for name in getattr(brdf, "_RANGES", ()):  # a gfxlab model: one surface
            if jnp.shape(getattr(brdf, name)) != ():
                raise ValueError(
                    f"`brdf.{name}` must be a scalar in `render` (one material for the "
                    "mesh; its colour comes from the mesh's colours or texture), got "
                    f"shape {jnp.shape(getattr(brdf, name))}"
                )
        return lights, brdf
    if brdf is not None:
        raise ValueError("`brdf` shades lit renders only: pass `lights=` as well")
    zero = not is_traced(ambient) and not np.any(np.asarray(ambient))
    if not zero:
        raise ValueError(
            "`ambient` shades lit renders only (an unlit render shows the albedo as it "
            "is): pass `lights=` (`()` for ambient light alone), or leave `ambient` at 0"
        )
    return None, None


def render_config(mesh, vertices, camera, batched, sigma, mode, shape, *, eps, sizes, flags):
    """The `RenderConfig` of a call, after checking `mode` and `shape`;
    `sizes = (tile_size, capacity, tiles_per_step)`, `flags = (antialias,
    cull_backfaces, reference)`."""
    if mode not in ("soft", "hard"):
        raise ValueError(f"`mode` must be 'soft' or 'hard', got {mode!r}")
    shape = static_shape(shape)
    tile_size, capacity, tiles_per_step = sizes
    antialias, cull_backfaces, reference = flags
    static_bool(antialias, "antialias")
    static_bool(cull_backfaces, "cull_backfaces")
    soft = mode == "soft"
    traced = any_traced(mesh, vertices, camera, sigma)
    needed = None
    if not traced and capacity is not None:
        # An explicit capacity is checked after the run (`render` grows it if a tile
        # overflowed): measuring first would cost an eager call a second compiled call.
        needed = 0
    elif not traced:  # measure the capacity from the projected geometry (one compiled call)
        axes = (0 if vertices.ndim == 3 else None, 0 if batched else None)
        # (inside a user's jit the geometry may still be concrete: compute it now)
        with jax.ensure_compile_time_eval():
            needed = measured_tile_count(
                vertices,
                mesh.faces,
                camera,
                sigma if soft else None,
                shape=shape,
                tile_size=tile_size,
                eps=float(eps),
                cull_backfaces=bool(cull_backfaces),
                axes=axes,
            )
            needed = int(needed)
    capacity = resolve_capacity(
        capacity, None, None, None, shape, tile_size, traced, mesh.num_faces, needed=needed
    )
    return RenderConfig(
        shape,
        soft,
        float(eps),
        tile_size,
        capacity,
        tiles_per_step,
        bool(antialias),
        bool(cull_backfaces),
        vertices.ndim == 3,
        batched,
        reference,
    )


# ------------------------------------------------ the checks of the other public entries


def faces_of(faces, vertices, vertices_name: str):
    """`faces` checked as indices into the rows of `vertices` (`check_faces`), after the
    one mismatch known from the shapes alone: faces that index an empty `vertices`."""
    faces = as_int(faces, "faces", "vertex indices")
    check_shape(faces, "faces", (None, 3))
    if vertices.shape[0] == 0 and faces.shape[0] > 0:
        raise ValueError(
            f"`faces` index vertices, but `{vertices_name}` has none (shape "
            f"{tuple(vertices.shape)}): {faces.shape[0]} faces need at least one vertex"
        )
    return check_faces(faces, vertices.shape[0])


def finite_rows(x, name: str, shape: tuple, what: str = "", dtype=None):
    """`x` as a finite float array of `shape` (`check_shape`'s pattern; `what` says where
    its sizes come from), cast to `dtype` if given."""
    x = as_float(x, name)
    if dtype is not None:
        x = x.astype(dtype)
    check_shape(x, name, shape, what)
    return check_finite(x, name)


def face_index_of(face_index, num_faces: int):
    """Per-pixel face indices: integers, each a face (`0 <= i < num_faces`) or -1 for
    the background."""
    face_index = as_int(face_index, "face_index", "face indices")
    bad = (face_index < -1) | (face_index >= num_faces)
    return value_error_if(
        face_index,
        bad,
        f"`face_index` must be -1 (background) or a face, 0 <= index < {num_faces}",
    )


def interpolate_inputs(attributes, faces, face_index, barycentrics):
    """`interpolate`'s arguments, checked: `(attributes, faces, face_index, barycentrics)`."""
    attributes = finite_rows(attributes, "attributes", (None, None))
    faces = faces_of(faces, attributes, "attributes")
    face_index = face_index_of(face_index, faces.shape[0])
    barycentrics = finite_rows(
        barycentrics,
        "barycentrics",
        tuple(face_index.shape) + (3,),
        "the shape of `face_index`, then 3",
        attributes.dtype,
    )
    return attributes, faces, face_index, barycentrics


def antialias_inputs(image, face_index, depth, triangles_2d, faces):
    """`antialias`'s arguments, checked: `(image, face_index, depth, triangles_2d,
    faces)`."""
    image = finite_rows(image, "image", (None, None, None))
    pixels = "the pixel shape (H, W) of `image`"
    check_shape(
        as_int(face_index, "face_index", "face indices"), "face_index", image.shape[:2], pixels
    )
    depth = finite_rows(depth, "depth", image.shape[:2], pixels, image.dtype)
    triangles_2d = finite_rows(triangles_2d, "triangles_2d", (None, 3, 2), dtype=image.dtype)
    faces = as_int(faces, "faces", "vertex indices")
    per_triangle = "one row per triangle of `triangles_2d`"
    check_shape(faces, "faces", (triangles_2d.shape[0], 3), per_triangle)
    face_index = face_index_of(face_index, triangles_2d.shape[0])
    faces = value_error_if(faces, faces < 0, "`faces` must be vertex indices >= 0")
    return image, face_index, depth, triangles_2d, faces


def silhouette_inputs(vertices_2d, faces, shape, sigma):
    """`soft_silhouette`'s arrays and shape, checked: `((H, W), vertices_2d, faces,
    sigma)` (`sigma` a scalar of the vertices' dtype, its range checked by
    `check_options`)."""
    shape = static_shape(shape)
    vertices_2d = finite_rows(vertices_2d, "vertices_2d", (None, 2))
    faces = faces_of(faces, vertices_2d, "vertices_2d")
    if faces.shape[0] == 0:
        raise ValueError("`faces` must hold at least one triangle, got shape (0, 3)")
    sigma = as_float(sigma, "sigma").astype(vertices_2d.dtype)
    check_shape(sigma, "sigma", ())
    return shape, vertices_2d, faces, sigma


_BUFFERS = ("color", "alpha", "depth", "normal", "position", "face_index", "barycentrics")


def check_rendering(rendering) -> None:
    """`Rendering.__check_init__`: every buffer an array with `color`'s pixel shape (and
    3 channels for `normal`, `position`, `barycentrics`), `face_index` integer, the
    floating buffers finite (checked when not traced)."""
    fields = {name: getattr(rendering, name) for name in _BUFFERS + ("attributes",)}
    for name, value in fields.items():
        if value is None and name == "attributes":
            continue
        kind = getattr(getattr(value, "dtype", None), "kind", None)
        if not hasattr(value, "shape") or kind not in tuple("biuf"):
            raise TypeError(f"`{name}` must be an array of numbers, got {value!r:.40}")
    color = fields["color"]
    if len(color.shape) < 3:
        raise ValueError(f"`color` must be an (H, W, C) array, got shape {tuple(color.shape)}")
    pixels = tuple(color.shape[:-1])
    expected = {"alpha": pixels, "depth": pixels, "face_index": pixels}
    expected |= {name: pixels + (3,) for name in ("normal", "position", "barycentrics")}
    if fields["attributes"] is not None:
        expected["attributes"] = pixels + tuple(fields["attributes"].shape[-1:])
    for name, shape in expected.items():
        check_shape(fields[name], name, shape, f"the pixel shape {pixels} of `color`")
    if not jnp.issubdtype(fields["face_index"].dtype, jnp.integer):
        raise TypeError(f"`face_index` must be integer, got dtype {fields['face_index'].dtype}")
    for name, value in fields.items():
        if name != "face_index" and value is not None and not is_traced(value):
            check_finite(value, name)
