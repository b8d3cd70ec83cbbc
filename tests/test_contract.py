"""The bad-input contract over the whole public API (issue 17).

Every public function and class of every `gfxlab.<module>` (its `__all__`) is called
with a battery of bad inputs suited to each parameter (`None`, NaN, inf, a wrong shape,
a wrong dtype, an empty array; `None`, a huge value, a float, a string for an int; an
unknown choice for a string), the other arguments valid. Each case has an expected
outcome (`EXPECTED`): a `TypeError`/`ValueError` (or a documented subclass) whose message
names the argument. Outcomes:

- `clear`: the expected error, naming the argument;
- `unclear`: another exception, or one that does not name the argument;
- `silent-nan`: returned a result holding NaN/inf;
- `silent`: returned a finite result where an error was expected;
- `hang`: ran past `CALL_SECONDS` of CPU time (a signal timer stops it);
- `crash`: the interpreter died (an abort in XLA, or memory exhausted);
- `ok`: returned a finite result where that is acceptable (an empty input).

The sweep runs eagerly in a subprocess whose address space is capped (`MEMORY_LIMIT`),
so a huge allocation ends in `MemoryError` (counted unclear) instead of exhausting the
machine; a sample of the cases that fail clearly is rerun under `jax.jit`, where the
error must carry the same message (`gfxlab.check_message`).

Failures of other modules that are known are listed in `contract_known_failures.txt`
(one `module.function parameter case` per line); any other failure fails the test.

Summary (counts per module), from the repository root:

    python tests/test_contract.py            # print the table (every case)
    python tests/test_contract.py --quick    # the quick subset that pytest runs
    python tests/test_contract.py --known    # print the allow-list for the current tree
    python tests/test_contract.py --quick --modules mesh,color --details  # one module's gaps

Under pytest the sweep runs the quick subset of cases (`QUICK_CASES`: None, NaN, a wrong
shape, a huge size, an unknown choice, an empty array and a string for an array, for every
parameter of every function; inf, a float or a string for an int are left to the full sweep);
`CONTRACT_FULL=1 pytest tests/test_contract.py` runs them all.
"""

from __future__ import annotations

import faulthandler
import importlib
import inspect
import json
import math
import os
import pathlib
import re
import signal
import subprocess
import sys
from collections import Counter, defaultdict

import pytest

HERE = pathlib.Path(__file__).resolve().parent
KNOWN_FILE = HERE / "contract_known_failures.txt"
MODULES = (
    "transforms", "viewing", "clipping", "fit", "raster", "mesh", "curves", "brdf",
    "color", "image", "jpeg", "render", "animation", "exam", "grading",
)  # fmt: skip
CALL_SECONDS = 10  # CPU seconds per call (a whole fit's compile takes ~5)
WATCHDOG_SECONDS = 120  # wall seconds per call before the interpreter is ended
MEMORY_LIMIT = 6 * 2**30  # bytes of address space for the sweep
HUGE = 10**12
SKIP = {  # not functions of data: files, processes, CLIs and teaching drivers
    "grading.*", "exam.*", "fit.FitResult", "image.read_image", "image.write_image",
    "image.image_info", "mesh.read_obj", "mesh.write_obj", "animation.write_video",
    "animation.read_video", "animation.container_info", "jpeg.read_jpeg", "jpeg.write_jpeg",
    "animation.save_animation",  # writes files
    "animation.ContainerInfo", "animation.Node",  # result records, like fit.FitResult
}  # fmt: skip

# Valid values for parameters the guesses below get wrong, per `module.function`.
BASELINES = {
    "transforms.rotate_axis": {"axis": [0.0, 0.0, 1.0], "angle": 0.5},
    "transforms.scale": {"factors": [2.0, 3.0]},
    "transforms.reflection": {"normal": [0.0, 1.0]},
    "transforms.linear": {"matrix": [[1.0, 2.0], [0.0, 1.0]]},
    "transforms.compose": {"matrices": [[1.0, 0, 0], [0, 1, 0], [0, 0, 1]]},
    "transforms.apply": {"matrix": [[1.0, 0, 1], [0, 1, 0], [0, 0, 1]], "points": [[1.0, 2.0]]},
    "transforms.to_homogeneous": {"points": [[1.0, 2.0]]},
    "transforms.from_homogeneous": {"points": [[1.0, 2.0, 1.0]]},
    "transforms.window_to_viewport": {"window": [0.0, 0, 1, 1], "viewport": [0.0, 0, 4, 2]},
    "transforms.rotation_from_quaternion": {"q": [1.0, 0.1, 0, 0]},
    "transforms.rotation_from_6d": {"r6": [1.0, 0, 0, 0, 1, 0]},
    "transforms.rotation_matrix": {"values": [0.1, 0.2, 0.3]},
    "transforms.rotation": {"values": [0.1, 0.2, 0.3]},
    "transforms.rotation_to_quaternion": {"matrix": [[1.0, 0, 0], [0, 1, 0], [0, 0, 1]]},
    "transforms.rotation_to_axis_angle": {"matrix": [[1.0, 0, 0], [0, 1, 0], [0, 0, 1]]},
    "transforms.rotation_to_6d": {"matrix": [[1.0, 0, 0], [0, 1, 0], [0, 0, 1]]},
    "viewing.look_at": {"eye": [0.0, 0, 5], "target": [0.0, 0, 0], "up": [0.0, 1, 0]},
    "viewing.orthographic": dict(left=-1.0, right=1.0, bottom=-1.0, top=1.0, near=0.1, far=10.0),
    "viewing.frustum": dict(left=-1.0, right=1.0, bottom=-1.0, top=1.0, near=0.1, far=10.0),
    "viewing.perspective": dict(fov_y=1.0, aspect=1.5, near=0.1, far=10.0),
    "viewing.project": {
        "matrix": [[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
        "points": [[0.1, 0.2, 0.3]],
    },  # fmt: skip
    "viewing.plane_projection": {"axis": "z"},
    "viewing.orthographic_view": {"name": "front"},
    "viewing.Camera": {"eye": [0.0, 0, 5], "rotation": None},
    "viewing.in_view_volume": {"ndc_points": [[0.1, 0.2, 0.3]]},
    "viewing.ndc_to_pixels": {"ndc_points": [[0.1, 0.2, 0.3]]},
    "clipping.outcode": {"points": [[0.5, 0.5], [3.0, 0.5]]},
    "clipping.cohen_sutherland_trace": {"segment": [[-1.0, 0.5], [2.0, 0.5]]},
    "clipping.sutherland_hodgman": {"vertices": [[-1.0, -1.0], [2.0, 0.0], [0.5, 2.0]]},
    "clipping.polygon_area": {"vertices": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]},
    "fit.fit": {"fn": "<fit-fn>", "params": [0.0, 0.0], "max_steps": 3},
}
for _name in ("cohen_sutherland", "cohen_sutherland_steps", "liang_barsky"):
    BASELINES[f"clipping.{_name}"] = {"segments": [[[-1.0, 0.5], [2.0, 0.5]]]}
# Baselines of the other modules: each module's entries go in its own block below.
# -- animation, mesh


class _Made:
    """A baseline that is an object (a Skeleton, a Mesh...): built when the sweep asks
    for it, after gfxlab and JAX are set up (`make` takes no arguments)."""

    def __init__(self, make):
        self.make = make


class _Built(dict):
    """A function's baselines where `_Made` entries are built on `get`."""

    def get(self, key, default=None):
        value = super().get(key, default)
        return value.make() if isinstance(value, _Made) else value


def _gfx(module: str):
    return importlib.import_module(f"gfxlab.{module}")


_CHAIN = _Made(lambda: _gfx("animation").chain([1.0, 1.0]))
_CUBE = _Made(lambda: _gfx("mesh").cube())
_EYE3 = [[[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]]
_TIMES5 = [0.1, 0.3, 0.5, 0.7, 0.9]  # any shape is valid: 5 entries get no "shape" case
_NOISE_X = {"x": [[0.1, 0.2], [0.3, 0.4]]}
_TETRA = {
    "vertices": [[0.0, 0, 0], [1.0, 0, 0], [0.0, 1, 0], [0.0, 0, 1]],
    "faces": [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
}


def _ik_result():
    animation = _gfx("animation")
    result = animation.solve_ik(animation.chain([1.0, 1.0]), [1.0, 1.0], max_steps=2)
    return result


BASELINES |= {
    "animation.skin": {
        "vertices": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]],
        "weights": [[0.25] * 4] * 4,
        "bone_transforms": _EYE3 * 4,
    },
    "animation.skinning_matrices": _Built(skeleton=_CHAIN),
    "animation.bezier_path": {"control_points": [[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]]},
    "animation.curve_deform": _Built(
        path=_Made(lambda: _gfx("animation").bezier_path([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]])),
        vertices=[[0.0, 0.0], [1.0, 0.1], [2.0, 0.0]],
    ),
    "animation.cubic_bezier_easing": {"u": _TIMES5},
    "animation.ease_in": {"u": _TIMES5},
    "animation.ease_out": {"u": _TIMES5},
    "animation.ease_in_out": {"u": _TIMES5},
    "animation.interpolate": {"t": _TIMES5},
    "animation.interpolate_rotations": {"t": _TIMES5},
    "animation.Track": {"times": [0.0, 1.0, 2.0, 3.0], "position": [[0.0, 1.0, 2.0]] * 4},
    "animation.simulate_particles": _Built(
        particles=_Made(
            lambda: _gfx("animation").emit(
                __import__("jax").random.key(0), 4, origin=[0.0, 0.0], direction=[1.0, 0.0]
            )
        )
    ),
    "animation.damped_spring": {"steps": 3},
    "animation.slerp": {"u": _TIMES5},  # u broadcasts against the keys' batch
    "animation.squad": {"u": _TIMES5},
    "animation.Particles": {
        "position": [[0.0, 0.0], [1.0, 0.0]],
        "velocity": [[0.0, 1.0], [1.0, 1.0]],
        "birth": [0.0, 0.5],
    },
    "animation.value_noise": _NOISE_X,
    "animation.gradient_noise": _NOISE_X,
    "animation.fractal_noise": _NOISE_X,
    "animation.chain": {"lengths": [1.0] * 5},
    "animation.pose_2d": {"angles": _TIMES5},
    "animation.Skeleton": {"parents": (-1, 0, 1), "rest": _EYE3 * 3},
    "animation.forward_kinematics": _Built(skeleton=_CHAIN),
    "animation.forward_kinematics_loop": _Built(skeleton=_CHAIN),
    "animation.joint_positions": _Built(skeleton=_CHAIN),
    "animation.limit_angles": {"raw": _TIMES5},
    "animation.solve_ik": _Built(skeleton=_CHAIN, target=[1.0, 1.0], max_steps=2),
    "animation.IKResult": _Built(
        angles=[0.0, 0.0, 0.0],
        globals=_EYE3 * 3,
        effector=[2.0, 0.0],
        fit=_Made(lambda: _ik_result().fit),
    ),
    "animation.save_animation": {
        "quality": None,  # the default: the codec's own
        "frames": [[[[0.5] * 3] * 4] * 4] * 2,
        "path": "/tmp/gfxlab_contract_animation.gif",
    },
    "animation.format_tree": _Built(
        nodes=_Made(lambda: (_gfx("animation").Node("RIFF", 0, 12),)), max_children=4
    ),
    "mesh.Mesh": _TETRA,
    "mesh.revolve": {"profile": [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]},
    "mesh.obj_text": _Built(mesh=_CUBE),
    "mesh.check_faces": {"faces": [[0, 1, 2]], "num_vertices": 4},
    "mesh.check_colors": {"colors": [[0.5, 0.5, 0.5]] * 4, "count": 4},
    "mesh.laplacian_loss": _Built(mesh=_CUBE),
    "mesh.edge_length_loss": _Built(mesh=_CUBE),
    "mesh.normal_consistency_loss": _Built(mesh=_CUBE),
}
# -- render
_RENDER_TRIANGLE = [[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.0, 0.5, 0.0]]


class _RenderBaseline(dict):
    """A render baseline whose mesh and camera are built on first use (after the sweep
    has configured JAX): a triangle in front of a camera (`batch` views if given)."""

    def __init__(self, batch=None, **values):
        super().__init__(values)
        self.batch = batch

    def get(self, key, default=None):
        import jax.numpy as jnp

        from gfxlab.mesh import Mesh
        from gfxlab.viewing import Camera

        if key == "mesh":
            return Mesh(jnp.array(_RENDER_TRIANGLE), jnp.array([[0, 1, 2]]))
        if key == "camera":
            eye = jnp.array([0.0, 0.0, 3.0])
            return Camera(eye if self.batch is None else jnp.tile(eye, (self.batch, 1)))
        return super().get(key, default)


BASELINES |= {
    "render.render": _RenderBaseline(),
    "render.soft_rasterize": _RenderBaseline(gamma=0.1),
    "render.soft_rasterize_dense": _RenderBaseline(gamma=0.1),
    "render.render_dense": _RenderBaseline(),
    "render.tile_capacity": _RenderBaseline(),
    "render.shard_cameras": _RenderBaseline(batch=2),
    "render.interpolate": {"attributes": [[0.1, 0.2, 0.3, 0.4, 0.5]] * 4},
    "render.antialias": {"image": [[[0.5] * 5] * 8] * 8},
    "render.Rendering": {"color": [[[0.5] * 5] * 8] * 8, "attributes": [[[0.5] * 5] * 8] * 8},
}
_R, _mesh, _view = (importlib.import_module(f"gfxlab.{_m}") for _m in ("render", "mesh", "viewing"))
BASELINES |= {  # the hidden-surface methods and shading
    "render.shade": {"lights": _R.PointLight([0.0, 0.0, 5.0])},
    "render.PointLight": {"position": [0.0, 0.0, 5.0]},
    "render.DirectionalLight": {"direction": [0.0, 0.0, 1.0]},
    "render.screen_scene": {"mesh": _mesh.cube(), "camera": _view.Camera([2.0, 1.5, 3.0])},
    "render.VisibilityResult": {"counters": {}, "depth": None},  # None: no depth buffer
    "render.quadtree_cells": {"quadtree": ([[5]], [[1, 1], [1, 1]])},
}  # fmt: skip
# -- curves
_CUBIC_KNOTS = [0.0, 0, 0, 0, 1 / 3, 2 / 3, 1, 1, 1, 1]  # clamped_knots(6, 3)
_SPLINE_POINTS = [[0.0, 0], [1, 2], [2, -1], [3, 3], [4, 0], [5, 1]]
_ON_ELLIPSE = [[2.0, 0], [1.4, 0.7], [0, 1], [-1.4, 0.7], [-2, 0], [-1.4, -0.7], [0, -1]]
BASELINES |= {
    "curves.split": {"t": 0.5},
    "curves.bspline_basis": {"knots": _CUBIC_KNOTS, "degree": 3},
    "curves.bspline": {"control_points": _SPLINE_POINTS, "degree": 3},
    "curves.nurbs": {
        "control_points": _SPLINE_POINTS,
        "weights": [1.0, 2, 1, 1, 0.5, 1],
        "degree": 3,
    },
    "curves.BSpline": {"control_points": _SPLINE_POINTS, "degree": 3},
    "curves.NURBS": {
        "control_points": _SPLINE_POINTS,
        "weights": [1.0, 2, 1, 1, 0.5, 1],
        "degree": 3,
    },
    "curves.Ellipse": {"center": [1.0, 2.0], "radii": [2.0, 1.0], "angle": 0.3},
    "curves.fit_bezier": {"points": _SPLINE_POINTS, "degree": 2, "max_steps": 5},
    "curves.fit_bspline": {
        "points": _SPLINE_POINTS,
        "degree": 2,
        "num_control_points": 4,
        "max_steps": 5,
    },
    "curves.fit_ellipse": {"points": _ON_ELLIPSE, "max_steps": 5},
}
# -- brdf, color


def _lambert_brdf(wi, wo, n):
    """A valid BRDF argument (a plain function) for the functions that take one."""
    from gfxlab import brdf

    return brdf.lambert(wi, wo, n)


_UP = [0.0, 0.0, 1.0]  # BRDF directions must be unit vectors
BASELINES |= {
    f"brdf.{name}": {"wi": _UP, "wo": _UP, "n": _UP}
    for name in ("lambert", "phong", "blinn_phong", "cook_torrance")
}
BASELINES |= {
    f"brdf.{name}": {"brdf": _lambert_brdf}
    for name in ("reciprocity_error", "directional_albedo", "shade_sphere")
}
BASELINES["brdf.directional_albedo"]["wo"] = _UP
# -- image, jpeg, raster
_gi, _gr = (importlib.import_module(f"gfxlab.{_m}") for _m in ("image", "raster"))
_triangle = [[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]]
BASELINES |= {
    "image.Polygon": {"vertices": _triangle, "fill": None},
    "image.Polyline": {"vertices": _triangle},
    "image.Circle": {"center": [2.0, 2.0], "radius": 1.5, "fill": None},
    "image.write_svg": {"path": "/tmp/gfxlab-contract.svg", "shapes": (_gi.Polygon(_triangle),),
                        "background": None},
    "image.rasterize_shapes": {"shapes": (_gi.Polygon(_triangle),)},
    "image.selection_network": {"ranks": (1, 2)},
    "image.median": {"values": [[1.0, 5.0, 2.0, 4.0, 3.0]]},
    "image.median_of_sum": {"x": [1.0, 5.0, 2.0], "y": [4.0, 0.0, 0.0]},
    "image.value_noise": {"x": [[0.5, 0.25]]},
    "image.gradient_noise": {"x": [[0.5, 0.25]]},
    "image.fractal_noise": {"x": [[0.5, 0.25]]},
    "raster.supersample": {"fn": lambda p: p[..., 0] > 1.0},
    "raster.BeamPath": {"positions": [[0.0, 0.0], [1.0, 0.0]], "intensity": [0.5, 1.0],
                        "on": [True, True]},
    "raster.phosphor_frames": {"beam": _gr.BeamPath([[0.0, 0.0]], [1.0], [True])},
    # jpeg: an 8 x 8 RGB image in [0, 1], an 8 x 8 block and table, and the smallest
    # valid baseline JPEG (8 x 8 grey, one-code Huffman tables, all zero).
    "jpeg.coefficients": {"image": (_JPEG_RGB := [
        [[((r + 2 * c + 3 * k) % 9) / 8 for k in range(3)] for c in range(8)] for r in range(8)
    ])},
    "jpeg.encode": {"image": _JPEG_RGB},
    "jpeg.decode": {"data": (  # max_pixels None: no limit (valid)
        b"\xff\xd8"
        + b"\xff\xdb\x00\x43\x00" + bytes([1] * 64)  # DQT
        + b"\xff\xc0\x00\x0b\x08\x00\x08\x00\x08\x01\x01\x11\x00"  # SOF0 8 x 8 grey
        + b"\xff\xc4\x00\x14\x00\x01" + bytes(15) + b"\x00"  # DHT DC: '0' -> category 0
        + b"\xff\xc4\x00\x14\x10\x01" + bytes(15) + b"\x00"  # DHT AC: '0' -> EOB
        + b"\xff\xda\x00\x08\x01\x01\x00\x00\x3f\x00"  # SOS
        + b"\x3f\xff\xd9"  # DC 0, EOB, 1-bit padding; EOI
    ), "max_pixels": None},
    "jpeg.dequantize": {
        "quantized": (_JPEG_BLOCK := [[float((3 * r - 5 * c) % 11 - 5) for c in range(8)]
                                      for r in range(8)]),
        "table": (_JPEG_TABLE := [[float(1 + r + c) for c in range(8)] for r in range(8)]),
    },
    "jpeg.quantize": {"coefficients": _JPEG_BLOCK, "table": _JPEG_TABLE},
    "jpeg.huffman_code_block": {"coefficients": [3, -2, 1] + [0] * 61},
    "jpeg.huffman_codes": {"spec": ([0, 1, 5, 1, 1, 1, 1, 1, 1] + [0] * 7, list(range(12)))},
    "jpeg.level_shift": {"samples": _JPEG_BLOCK},
    "jpeg.psnr": {"a": _JPEG_BLOCK, "b": _JPEG_TABLE},
    "jpeg.run_length": {"ac": [0, 0, 5, -1] + [0] * 59},
    "jpeg.unzigzag": {"sequence": [float(k % 7) for k in range(64)]},
    "jpeg.zigzag": {"block": _JPEG_BLOCK},
    # real-valued qualities (2.5 is valid): the bad values are None, NaN, inf, a string
    "jpeg.compress": {"quality": 50.0},
    "jpeg.exact_tables": {"quality": 50.0},
    "jpeg.quant_tables_continuous": {"quality": 50.0},
}  # fmt: skip
# -- end of module blocks
NAMED = {  # guesses by parameter name
    "shape": (8, 8), "window": [0.0, 0.0, 1.0, 1.0], "viewport": [0.0, 0.0, 4.0, 4.0],
    "key": "<key>", "u": [0.25, 0.5], "t": [0.25, 0.5], "quality": 50, "sigma": 1.0,
}  # fmt: skip
DIMS = {"H": 8, "W": 8, "C": 3, "d": 2, "d+1": 3, "dim": 3, "n+1": 4, "m+1": 4, "T": 4}

# What each case must end in: "error" (clear error naming the argument), or also "ok".
EXPECTED = {
    "none": {"clear"}, "nan": {"clear"}, "inf": {"clear"}, "shape": {"clear"},
    "dtype": {"clear"}, "empty": {"clear", "ok"}, "huge": {"clear"}, "float": {"clear"},
    "string": {"clear"}, "choice": {"clear"},
}  # fmt: skip


# ----------------------------------------------------------------------- the sweep


def _shape_from_annotation(text: str):
    match = re.search(r"\[\s*Array(?:Like)?\s*,\s*['\"]([^'\"]*)['\"]", text)
    if not match:
        return None
    dims = []
    for token in match.group(1).split():
        if token.startswith(("*", "#")) or token == "...":
            continue
        dims.append(int(token) if token.isdigit() else DIMS.get(token, 4))
    return tuple(dims)


def _guess(module: str, fn_name: str, param: inspect.Parameter):
    """A valid-looking value for `param`, or `inspect.Parameter.empty`."""
    import jax
    import jax.numpy as jnp

    table = BASELINES.get(f"{module}.{fn_name}", {})
    value = table.get(param.name, NAMED.get(param.name, inspect.Parameter.empty))
    if value is inspect.Parameter.empty and param.default is not inspect.Parameter.empty:
        return param.default
    if value is inspect.Parameter.empty:
        text = str(param.annotation)
        shape = _shape_from_annotation(text)
        if shape is not None:
            if text.startswith("Int"):
                return jnp.zeros(shape, jnp.int32)
            if text.startswith("Bool"):
                return jnp.ones(shape, bool)
            return jnp.linspace(0.1, 0.9, math.prod(shape)).reshape(shape)
        guesses = {"int": 4, "float": 0.5, "tuple[int, int]": (8, 8), "bool": False}
        value = guesses.get(text.split(" |")[0], inspect.Parameter.empty)
    if value == "<key>":
        return jax.random.key(0)
    if value == "<fit-fn>":
        return lambda p: p - 1.0
    if isinstance(value, list):
        return jnp.asarray(value)
    return value


def _bad_values(value):
    """(case, bad value) pairs suited to a parameter whose valid value is `value`."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    if isinstance(value, bool) or value is None or callable(value):
        return [("none", None)] if callable(value) else []
    if isinstance(value, int):
        return [("none", None), ("huge", HUGE), ("float", 2.5), ("string", "abc")]
    if isinstance(value, str):
        return [("none", None), ("string", 12345), ("choice", "no-such-choice")]
    if isinstance(value, tuple) and value and all(isinstance(v, int) for v in value):
        return [("none", None), ("huge", (HUGE,) * len(value)), ("string", "abc")]
    if isinstance(value, float) or (
        isinstance(value, jax.Array | np.ndarray) and jnp.issubdtype(value.dtype, jnp.floating)
    ):
        arr = jnp.asarray(value)
        cases = [("none", None), ("nan", jnp.full(arr.shape, jnp.nan)),
                 ("inf", jnp.full(arr.shape, jnp.inf)), ("dtype", "abc")]  # fmt: skip
        if arr.ndim >= 1 and arr.shape[-1] <= 4:
            cases.append(("shape", jnp.zeros(arr.shape[:-1] + (7,))))
        if arr.ndim >= 2:
            cases.append(("empty", jnp.zeros((0,) + arr.shape[1:])))
        return cases
    if isinstance(value, jax.Array | np.ndarray):
        return [("none", None), ("dtype", "abc")]
    return [("none", None)]


class _Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise _Timeout


def _finite_result(result) -> bool:
    import jax
    import numpy as np

    for leaf in jax.tree_util.tree_leaves(result):
        try:
            arr = np.asarray(leaf)
        except Exception:  # noqa: BLE001 - keys, objects: not numbers
            continue
        if arr.dtype.kind in "fc" and not np.all(np.isfinite(arr)):
            return False
    return True


def _names(message: str, name: str) -> bool:
    return re.search(rf"(?<![\w]){re.escape(name)}(?![\w])", message) is not None


def _classify(call, name: str, case: str):
    """(outcome, detail) of one call."""
    from gfxlab import check_message

    # CPU time, not wall time: the machine may be busy; a wall-clock bound backs it up.
    signal.setitimer(signal.ITIMER_PROF, CALL_SECONDS)
    signal.alarm(10 * CALL_SECONDS)
    try:
        result = call()
        ok = _finite_result(result)
    except _Timeout:
        return "hang", f"over {CALL_SECONDS} s"
    except (TypeError, ValueError) as err:
        message = check_message(err) or str(err)
        clear = _names(message, name) and type(err).__name__ != "JaxRuntimeError"
        return ("clear" if clear else "unclear"), f"{type(err).__name__}: {message[:160]}"
    except Exception as err:  # noqa: BLE001 - any other exception is unclear by definition
        message = check_message(err)
        if message is not None and _names(message, name):
            return "clear", f"{type(err).__name__}: {message[:160]}"
        return (
            "unclear",
            f"{type(err).__name__}: {str(err).splitlines()[0][:160] if str(err) else ''}",
        )
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.alarm(0)
    if not ok:
        return "silent-nan", "returned NaN/inf"
    return ("ok" if case == "empty" else "silent"), "returned a finite result"


def _public(module_name: str):
    module = importlib.import_module(f"gfxlab.{module_name}")
    for name in getattr(module, "__all__", ()):
        obj = getattr(module, name)
        key = f"{module_name}.{name}"
        if key in SKIP or f"{module_name}.*" in SKIP or not callable(obj):
            continue
        if inspect.isclass(obj) and issubclass(obj, BaseException):
            continue
        try:
            signature = inspect.signature(obj)
        except (TypeError, ValueError):
            continue
        yield name, obj, signature


def _calls(module_name: str):
    """(function, parameter, case, bad value, make) for every case of one module, where
    `make(value)` is the call with `value` in place of the parameter."""
    for fn_name, fn, signature in _public(module_name):
        params = [
            p
            for p in signature.parameters.values()
            if p.kind is not p.VAR_KEYWORD and not p.name.startswith("_")
        ]
        values = {p.name: _guess(module_name, fn_name, p) for p in params}
        missing = [n for n, v in values.items() if v is inspect.Parameter.empty]
        if missing:
            yield fn_name, missing[0], "baseline", None, None
            continue
        for p in params:
            # None is a documented value where the annotation offers it
            optional = "None" in str(p.annotation).split("|")[-1]
            for case, bad in _bad_values(values[p.name]):
                if case == "none" and optional:
                    continue

                def make(value, p=p, fn=fn, values=values, params=params):
                    args, kwargs = [], {}
                    for q in params:
                        v = value if q is p else values[q.name]
                        if q.kind in (q.POSITIONAL_ONLY, q.VAR_POSITIONAL):
                            args.append(v)
                        else:
                            kwargs[q.name] = v
                    return lambda: fn(*args, **kwargs)

                yield fn_name, p.name, case, bad, make


#: The cases of the quick sweep (the default under pytest; `CONTRACT_FULL=1` for all).
#: "empty" and "dtype" mostly fail fast (no compile): with them the quick sweep has 2,097
#: cases instead of 1,520 in about the same time (two minutes of CPU, within the noise of
#: a shared machine); they catch what only the full sweep found (`render`'s empty
#: arrays and string dtypes).
QUICK_CASES = {"none", "nan", "huge", "choice", "shape", "empty", "dtype"}


def sweep(
    path: str, start: int = 0, modules=MODULES, jit_sample: int = 3, quick: bool = False
) -> None:
    """Run every case from number `start` on, appending one JSON line per case to `path`
    (a `{"begin": i}` line before case `i`, so a crash is attributed to its case).

    Per module, the first `jit_sample` NaN/inf cases that fail clearly eagerly are run
    again with the bad value traced under `jax.jit` (case name `nan-jit`/`inf-jit`).
    """
    import jax
    from jax_frame_filter import memoize_jax_frame_filter

    jax.config.update("jax_enable_x64", True)
    memoize_jax_frame_filter()  # a tenth of the sweep's time otherwise
    signal.signal(signal.SIGALRM, _alarm)
    signal.signal(signal.SIGPROF, _alarm)
    index = -1
    with open(path, "a") as out:

        def emit(line):
            out.write(json.dumps(line) + "\n")
            out.flush()

        for module_name in modules:
            jitted = 0
            for fn_name, param, case, bad, make in _calls(module_name):
                if quick and case not in QUICK_CASES and case != "baseline":
                    continue
                index += 1
                if index < start:
                    jitted += case in ("nan", "inf")  # keeps the jit sample the same
                    continue
                record = {"module": module_name, "function": fn_name, "param": param,
                          "case": case, "index": index}  # fmt: skip
                emit({"begin": index, **record})
                # A call stuck in compiled code cannot be interrupted by a signal: this
                # watchdog ends the interpreter, and the parent records a hang.
                faulthandler.dump_traceback_later(WATCHDOG_SECONDS, exit=True)
                if make is None:
                    emit({**record, "outcome": "unclear", "detail": "no valid baseline known"})
                    continue
                outcome, detail = _classify(make(bad), param, case)
                faulthandler.cancel_dump_traceback_later()
                emit({**record, "outcome": outcome, "detail": detail})
                driver = f"{module_name}.{fn_name}" in DRIVERS
                if (
                    outcome == "clear"
                    and case in ("nan", "inf")
                    and jitted < jit_sample
                    and not driver
                ):
                    jitted += 1
                    jit_call = lambda make=make, bad=bad: jax.jit(lambda v: make(v)())(bad)  # noqa: E731
                    faulthandler.dump_traceback_later(WATCHDOG_SECONDS, exit=True)
                    out_, det = _classify(jit_call, param, case)
                    faulthandler.cancel_dump_traceback_later()
                    emit({**record, "case": case + "-jit", "outcome": out_, "detail": det})


# ---------------------------------------------------------------------- reporting


KNOWN_HEADER = """\
# Known failures of the bad-input contract (tests/test_contract.py, issue 17).
# One "module.function parameter case" per line. Reviewed: each is a real gap in a
# module another engineer is refactoring, not an accepted behaviour (those are in
# ACCEPTED in the test). The test fails for any failure not listed here, so the list
# only shrinks. Regenerate after merging: python tests/test_contract.py --known
"""

# Reviewed cases where a finite result is the right answer (not failures).
ACCEPTED = {
    "transforms.to_homogeneous points shape",  # any dimension d -> d + 1
    "transforms.from_homogeneous points shape",  # any dimension d + 1 -> d
    "fit.fit params shape",  # any pytree of arrays is a valid start
    # curves work in any dimension d (the "shape" case makes points 7D) and take
    # parameters u, v, t of any shape
    "curves.bernstein u shape",
    "curves.bezier control_points shape",
    "curves.bezier u shape",
    "curves.de_casteljau control_points shape",
    "curves.de_casteljau u shape",
    "curves.split control_points shape",
    "curves.elevate_degree control_points shape",
    "curves.derivative control_points shape",
    "curves.bspline_basis u shape",
    "curves.bspline control_points shape",
    "curves.bspline u shape",
    "curves.nurbs control_points shape",
    "curves.nurbs u shape",
    "curves.ellipse t shape",
    "curves.circle t shape",
    "curves.bezier_patch control_net shape",
    "curves.bezier_patch u shape",
    "curves.bezier_patch v shape",
    "curves.Bezier control_points shape",
    "curves.BSpline control_points shape",
    "curves.NURBS control_points shape",
    "curves.chord_length_parameters points shape",
    "curves.fit_bezier points shape",
    "curves.fit_bspline points shape",
    "render.Rendering attributes none",  # no per-pixel attributes: a valid Rendering
}
# Documented drivers that run compiled steps in a Python loop: no jit sample.
DRIVERS = {"fit.fit"}


def _passes(record) -> bool:
    key = f"{record['module']}.{record['function']} {record['param']} {record['case']}"
    expected = EXPECTED.get(record["case"].removesuffix("-jit"), {"clear"})
    return record["outcome"] in expected or key in ACCEPTED


def failures(records) -> set[str]:
    return {
        f"{r['module']}.{r['function']} {r['param']} {r['case']}" for r in records if not _passes(r)
    }


def known_failures() -> set[str]:
    if not KNOWN_FILE.exists():
        return set()
    lines = KNOWN_FILE.read_text().splitlines()
    return {line.split("#")[0].strip() for line in lines if line.split("#")[0].strip()}


def summary(records) -> str:
    rows = defaultdict(Counter)
    for r in records:
        rows[r["module"]][r["outcome"]] += 1
        rows[r["module"]]["pass"] += _passes(r)
    cols = ["clear", "ok", "unclear", "silent-nan", "silent", "hang", "crash"]
    lines = [f"{'module':<11}{'cases':>7}" + "".join(f"{c:>11}" for c in cols) + f"{'pass %':>9}"]
    total = Counter()
    for module in MODULES:
        count = rows[module]
        n = sum(count[c] for c in cols)
        total.update(count)
        rate = 100 * count["pass"] / n if n else 100.0
        lines.append(
            f"{module:<11}{n:>7}" + "".join(f"{count[c]:>11}" for c in cols) + f"{rate:>9.1f}"
        )
    n = sum(total[c] for c in cols)
    lines.append(f"{'all':<11}{n:>7}" + "".join(f"{total[c]:>11}" for c in cols)
                 + f"{100 * total['pass'] / max(n, 1):>9.1f}")  # fmt: skip
    return "\n".join(lines)


def _limit_memory():
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def run_sweep_subprocess(
    timeout: float = 900, restarts: int = 30, quick: bool = False, modules=MODULES
) -> list[dict]:
    """The sweep in a fresh interpreter with capped memory; its records.

    If the interpreter dies (an abort inside XLA, memory exhausted), the case it was
    running is recorded as `crash` and the sweep resumes after it.
    """
    import tempfile

    env = dict(os.environ, JAX_PLATFORMS="cpu")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "records.jsonl")
        start = 0
        for _ in range(restarts):
            code = (
                f"import sys; sys.path.insert(0, {str(HERE)!r}); import test_contract as t; "
                f"t.sweep({path!r}, {start}, modules={tuple(modules)!r}, quick={quick})"
            )
            run = subprocess.run(
                [sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout,
                preexec_fn=_limit_memory, env=env, cwd=HERE.parent,
            )  # fmt: skip
            lines = [json.loads(x) for x in pathlib.Path(path).read_text().splitlines() if x]
            begun = [x for x in lines if "begin" in x]
            done = {x["index"] for x in lines if "outcome" in x}
            if run.returncode == 0 or not begun or begun[-1]["begin"] in done:
                if run.returncode != 0:
                    raise RuntimeError(f"the contract sweep failed:\n{run.stderr[-3000:]}")
                break
            crashed = {k: v for k, v in begun[-1].items() if k != "begin"}
            tail = (run.stderr.strip().splitlines()[-1:] or [""])[0][:160]
            hung = "Timeout (" in run.stderr
            outcome = {"outcome": "hang" if hung else "crash", "detail": tail}
            with open(path, "a") as out:
                out.write(json.dumps({**crashed, **outcome}))
                out.write("\n")
            start = crashed["index"] + 1
        lines = [json.loads(x) for x in pathlib.Path(path).read_text().splitlines() if x]
    return [x for x in lines if "outcome" in x]


# -------------------------------------------------------------------------- tests


# The modules in two sweeps of about equal time, one interpreter each, so the two test
# workers share them and pay JAX's import twice rather than once per module (modules
# skipped whole, the grader and the exam, are not functions of data).
SWEEP_GROUPS = (
    ("animation", "jpeg", "transforms", "fit", "clipping", "raster"),
    ("render", "curves", "color", "brdf", "image", "viewing", "mesh"),
)


def test_the_sweep_groups_cover_every_swept_module():
    swept = [m for m in MODULES if f"{m}.*" not in SKIP]
    assert sorted(m for group in SWEEP_GROUPS for m in group) == sorted(swept)


@pytest.mark.parametrize("modules", SWEEP_GROUPS, ids=lambda group: "+".join(group))
def test_no_new_contract_failures(modules):
    quick = os.environ.get("CONTRACT_FULL", "") != "1"
    mine = run_sweep_subprocess(quick=quick, modules=modules)
    silent = set(modules) - {r["module"] for r in mine}
    assert not silent, f"the sweep ran no case of {sorted(silent)}"
    new = sorted(f for f in failures(mine) - known_failures())
    details = {
        f"{r['module']}.{r['function']} {r['param']} {r['case']}": f"{r['outcome']}: {r['detail']}"
        for r in mine
    }
    assert not new, "new bad-input contract failures:\n" + "\n".join(
        f"{f}  ->  {details[f]}" for f in new
    )


def test_owned_modules_have_no_known_failures():
    owned = ("transforms.", "viewing.", "clipping.", "fit.")
    assert not [k for k in known_failures() if k.startswith(owned)]


def _main(argv) -> None:
    """`--quick`, `--known`, `--modules a,b` (a subset), `--details` (each failure's outcome)."""
    modules = MODULES
    if "--modules" in argv:
        modules = tuple(argv[argv.index("--modules") + 1].split(","))
    found = run_sweep_subprocess(quick="--quick" in argv, modules=modules)
    if "--known" in argv:
        print(KNOWN_HEADER + "\n".join(sorted(failures(found))))
        return
    print(summary(found))
    if "--details" in argv:
        for r in found:
            if not _passes(r):
                key = f"{r['module']}.{r['function']} {r['param']} {r['case']}"
                print(f"{key}  ->  {r['outcome']}: {r['detail']}")
    new = failures(found) - known_failures()
    print(f"\n{len(failures(found))} failing cases, {len(new)} not in {KNOWN_FILE.name}")


if __name__ == "__main__":
    _main(sys.argv)
