"""Tracks: key-framed channels (position, rotation, scale, color) sharing key times,
evaluated for any number of tracks at any number of times in one compiled call.
Re-exported by `gfxlab.animation.keyframes`."""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._checks import (
    as_float,
    check_finite,
    check_last_dim,
    check_shape,
    checked_jit,
    is_traced,
    value_error_if,
)
from .keyframes import _ROTATION_METHODS, EASINGS, METHODS, _cardinal_tangents, _interp, _rotations
from .quaternions import quat_to_matrix

__all__ = ["Track", "TrackSample"]

_CHANNELS = ("position", "rotation", "scale", "color")


class TrackSample(eqx.Module):
    """The channels of one or more tracks at some times; absent channels are `None`."""

    position: Float[Array, "*batch T d"] | None = None
    rotation: Float[Array, "*batch T 4"] | None = None
    scale: Float[Array, "*batch T d"] | None = None
    color: Float[Array, "*batch T c"] | None = None

    def matrix(self) -> Float[Array, "*batch T 4 4"]:
        """The 3D transforms `T(position) R(rotation) S(scale)` (scale first), 4x4."""
        present = [c for c in (self.position, self.rotation, self.scale) if c is not None]
        if not present:
            raise ValueError("the sample has no position, rotation or scale channel")
        if self.scale is not None:
            check_shape(self.scale, "scale", (..., 3))
        if self.position is not None:
            check_shape(self.position, "position", (..., 3))
        return _sample_matrix(self.position, self.rotation, self.scale, present[0])


@jax.jit
def _sample_matrix(position, rotation, scale, first):
    batch, dtype = first.shape[:-1], first.dtype
    linear = jnp.broadcast_to(jnp.eye(3, dtype=dtype), batch + (3, 3))
    if scale is not None:
        linear = linear * scale[..., None, :]
    if rotation is not None:
        linear = quat_to_matrix(rotation) @ linear
    offset = jnp.zeros(batch + (3,), dtype) if position is None else position
    top = jnp.concatenate([linear, offset[..., None]], axis=-1)
    bottom = jnp.broadcast_to(jnp.array([0.0, 0.0, 0.0, 1.0], dtype), batch + (1, 4))
    return jnp.concatenate([top, bottom], axis=-2)


def _field_converter(name: str):
    """A converter for a `Track` field: a float array (None kept for absent channels),
    with a `TypeError` naming the field for anything that is not numbers."""

    def convert(x):
        if x is None and name != "times":
            return None
        return x if is_traced(x) else as_float(x, name)

    return convert


def _check_track_values(track) -> None:
    """Shapes and values of a Track's fields, checked eagerly at construction."""
    times = track.times
    if times.ndim < 1:
        raise ValueError(f"`times` must be (*B, K) key times, got shape {times.shape}")
    for name in _CHANNELS:
        values = getattr(track, name)
        if values is None:
            continue
        if values.ndim != times.ndim + 1 or values.shape[:-1] != times.shape:
            raise ValueError(
                f"`{name}` must be (*B, K, c) matching `times` {times.shape}, "
                f"got shape {values.shape}"
            )
        if not is_traced(values):
            check_finite(values, name)
    for name, sizes in (("position", (1, 2, 3)), ("scale", (1, 2, 3)), ("color", (1, 2, 3, 4))):
        if getattr(track, name) is not None:
            check_last_dim(getattr(track, name), name, sizes)
    if track.rotation is not None:
        check_last_dim(track.rotation, "rotation", (4,), "quaternion keys (w, x, y, z)")
        if not is_traced(track.rotation):
            value_error_if(
                track.rotation,
                jnp.all(track.rotation == 0, axis=-1),
                "`rotation` keys must be non-zero quaternions",
            )
    if not is_traced(times):
        check_finite(times, "times")
        if times.shape[-1] > 1:
            value_error_if(
                times,
                jnp.diff(times, axis=-1) <= 0,
                "`times` must be strictly increasing key times",
            )


class Track(eqx.Module):
    """Key-framed channels sharing key times: position, rotation, scale and color.

    Fields may carry leading batch dimensions (the same for every field), one track per
    batch entry: `Track(times (B, K), position (B, K, 3), ...)` holds `B` tracks, and
    calling it evaluates all of them at all times in one vectorized, compiled call.

    **Fields:**

    - `times`: `(*B, K)` key times, strictly increasing per track.
    - `position`, `scale`: `(*B, K, d)` with d = 1, 2 or 3, or `None`.
    - `color`: `(*B, K, c)` with c = 1 to 4 (grey, grey + alpha, RGB, RGBA), or `None`.
    - `rotation`: `(*B, K, 4)` quaternion keys or `None`.
    - `method`: interpolation of position/scale/color (see `interpolate`).
    - `rotation_method`: `"step"`, `"slerp"` or `"squad"`.

    The fields are checked at construction (`TypeError`/`ValueError` naming the field).
    """

    times: Float[Array, "*B K"] = eqx.field(converter=_field_converter("times"))
    position: Float[Array, "*B K d"] | None = eqx.field(
        default=None, converter=_field_converter("position")
    )
    rotation: Float[Array, "*B K 4"] | None = eqx.field(
        default=None, converter=_field_converter("rotation")
    )
    scale: Float[Array, "*B K d"] | None = eqx.field(
        default=None, converter=_field_converter("scale")
    )
    color: Float[Array, "*B K c"] | None = eqx.field(
        default=None, converter=_field_converter("color")
    )
    method: str = eqx.field(default="linear", static=True)
    rotation_method: str = eqx.field(default="slerp", static=True)

    def __check_init__(self):
        _check_track_values(self)
        if not isinstance(self.method, str) or self.method not in METHODS[:3] + METHODS[4:]:
            raise ValueError(
                f"`method` of a Track must be one of "
                f"{tuple(m for m in METHODS if m != 'hermite')}, got {self.method!r}"
            )
        if (
            not isinstance(self.rotation_method, str)
            or self.rotation_method not in _ROTATION_METHODS
        ):
            raise ValueError(
                "`rotation_method` must be 'step', 'slerp' or 'squad', got "
                f"{self.rotation_method!r}"
            )
        if all(getattr(self, c) is None for c in _CHANNELS):
            raise ValueError(
                "a Track needs at least one channel (position, rotation, scale or color)"
            )

    def _single(self, t):
        control = None
        if self.method == "bezier":
            control = jnp.asarray(EASINGS["ease_in_out"], t.dtype)

        def channel(values):
            if values is None:
                return None
            m = None
            if self.method == "catmull_rom" and self.times.shape[-1] > 1:
                m = _cardinal_tangents(self.times, values, jnp.zeros((), values.dtype))
            return _interp(self.times, values, t, m, control, method=self.method)

        rotation = None
        if self.rotation is not None:
            rotation = _rotations(self.times, self.rotation, t, method=self.rotation_method)
        return TrackSample(
            channel(self.position), rotation, channel(self.scale), channel(self.color)
        )

    def __call__(self, t: Float[Array, " T"]) -> TrackSample:
        """Evaluate every track at times `t` `(T,)` (shared by all tracks).

        **Returns:** a `TrackSample` with channels `(*B, T, c)`.
        """
        return _track_kernel(self, as_float(t, "t"))


@checked_jit
def _track_kernel(track, t):
    # Checked at construction already, unless the track was built from traced values.
    times = check_finite(track.times, "times")
    times = value_error_if(
        times, jnp.diff(times, axis=-1) <= 0, "`times` must be strictly increasing key times"
    )
    changes = {
        c: check_finite(getattr(track, c), c) for c in _CHANNELS if getattr(track, c) is not None
    }
    track = dataclasses.replace(track, times=times, **changes)
    t = check_finite(t, "t").astype(times.dtype)
    fn = lambda tr: tr._single(t)  # noqa: E731
    for _ in range(track.times.ndim - 1):
        fn = jax.vmap(fn)
    return fn(track)
