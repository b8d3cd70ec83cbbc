"""Displays: a simulation of raster-scan and random-scan (vector) CRTs and of the
phosphor's persistence."""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from .._checks import check_range, check_shape, checked_jit, static_bool, static_int
from .._pixels import checked_shape, pixel_to_index, row_to_y
from ._args import array_arg, finite_arg, float_dtype, range_check

__all__ = ["MAX_BEAM_STEPS", "BeamPath", "raster_scan", "random_scan", "phosphor_frames"]

#: Largest number of time steps per retrace, per segment or per move (a documented
#: size limit), and of snapshots times beam steps in `phosphor_frames`.
MAX_BEAM_STEPS = 4096
_MAX_FRAME_WORK = 1 << 26

_INT = jnp.int32


def _positions(positions) -> jax.Array:
    positions = array_arg(positions, "positions", "beam positions (T, 2)")
    check_shape(positions, "positions", (None, 2))
    if positions.shape[0] < 1:
        raise ValueError("`positions` must hold at least one time step, got shape (0, 2)")
    return jnp.asarray(finite_arg(positions, "positions"))


def _intensity(intensity) -> jax.Array:
    intensity = finite_arg(array_arg(intensity, "intensity", "beam intensities (T,)"), "intensity")
    return jnp.asarray(range_check(intensity, "intensity", low=0, high=1, low_open=False))


def _on(on) -> jax.Array:
    on = array_arg(on, "on", "booleans (T,)")
    if on.dtype != np.bool_:
        raise TypeError(f"`on` must be booleans, got dtype {on.dtype}")
    return jnp.asarray(on)


class BeamPath(eqx.Module):
    """Where a CRT's electron beam is at each time step, and how bright it is.

    A pytree whose fields are the constructor's arguments, `BeamPath(positions,
    intensity, on)`:

    - `positions`: `(T, 2)` beam position in pixel coordinates `(x, y)`, y up (finite,
      `T >= 1`).
    - `intensity`: `(T,)` beam intensity in `[0, 1]` (0 while blanked).
    - `on`: `(T,)` booleans: whether the beam is switched on (off during retrace and
      moves).

    Shapes and dtypes raise `TypeError`/`ValueError` naming the argument; the value
    checks (finite, in range) go through `equinox.error_if` when traced.
    """

    positions: Float[Array, "T 2"] = eqx.field(converter=_positions)
    intensity: Float[Array, " T"] = eqx.field(converter=_intensity)
    on: Bool[Array, " T"] = eqx.field(converter=_on)

    def __check_init__(self):
        """One `intensity` and one `on` per time step of `positions`."""
        steps = self.positions.shape[0]
        for arr, name in ((self.intensity, "intensity"), (self.on, "on")):
            if tuple(arr.shape) != (steps,):
                raise ValueError(
                    f"`{name}` must have shape (T,) = ({steps},), one entry per time step of "
                    f"`positions`, got shape {tuple(arr.shape)}"
                )


def _blanked_move(start: np.ndarray, end: np.ndarray, steps: int) -> np.ndarray:
    t = (np.arange(steps) + 1.0) / (steps + 1)
    return start + t[:, None] * (end - start)


def raster_scan(
    frame_buffer: Float[Array, "H W"],
    *,
    interlaced: bool = False,
    h_retrace: int = 4,
    v_retrace: int = 12,
) -> BeamPath:
    """One refresh of a raster-scan display: the beam sweeps every scan line of the frame
    buffer left to right, top to bottom, and is blanked during the retraces.

    After each scan line the beam flies back to the start of the next one (horizontal
    retrace, `h_retrace` steps); after the last line of a field it flies back to the top
    (vertical retrace, `v_retrace` steps). With `interlaced=True` a refresh is two
    fields: the even rows (0, 2, 4, ... from the top), then the odd rows.

    **Arguments:**

    - `frame_buffer`: `(H, W)` intensities in `[0, 1]`; row 0 is the top scan line.
    - `interlaced`: scan even rows, then odd rows (static).
    - `h_retrace`, `v_retrace`: time steps of the horizontal and vertical retraces
      (static ints >= 1).

    **Returns:** a `BeamPath` with `T = H W + (H - F) h_retrace + F v_retrace` steps
    (`F` fields), one time step per pixel while the beam is on.
    """
    frame_buffer = finite_arg(array_arg(frame_buffer, "frame_buffer"), "frame_buffer")
    check_shape(frame_buffer, "frame_buffer", (None, None))
    frame_buffer = check_range(frame_buffer, "frame_buffer", minimum=0, maximum=1)
    checked_shape(frame_buffer.shape, "frame_buffer.shape")
    height, width = frame_buffer.shape
    h_retrace = static_int(h_retrace, "h_retrace", minimum=1, maximum=MAX_BEAM_STEPS)
    v_retrace = static_int(v_retrace, "v_retrace", minimum=1, maximum=MAX_BEAM_STEPS)
    positions, on, flat = _raster_layout(
        height, width, static_bool(interlaced, "interlaced"), h_retrace, v_retrace
    )
    return _raster_beam(frame_buffer, positions, on, flat)


@functools.lru_cache(maxsize=32)
def _raster_layout(height: int, width: int, interlaced: bool, h_retrace: int, v_retrace: int):
    """The beam's static path (positions, on, pixel index per step) in NumPy, cached."""
    if interlaced:
        fields = [np.arange(0, height, 2), np.arange(1, height, 2)]
    else:
        fields = [np.arange(height)]
    fields = [f for f in fields if f.size]
    rows_all, cols_all, pos_all, on_all = [], [], [], []
    xs = np.arange(width, dtype=float)
    for i, rows in enumerate(fields):  # one or two fields, not a loop over pixels
        n = rows.size
        y = row_to_y(rows, height).astype(float)
        line_pos = np.stack(np.broadcast_arrays(xs[None, :], y[:, None]), -1)  # (n, W, 2)
        line_end = np.stack([np.full(n, width - 1.0), y], -1)
        next_start = np.stack([np.zeros(n), np.roll(y, -1)], -1)
        t = (np.arange(h_retrace) + 1.0) / (h_retrace + 1)
        retrace = line_end[:, None] + t[None, :, None] * (next_start - line_end)[:, None]
        block = np.concatenate([line_pos, retrace], axis=1).reshape(-1, 2)[:-h_retrace]
        block_on = np.concatenate(
            [np.ones((n, width), bool), np.zeros((n, h_retrace), bool)], axis=1
        ).ravel()[:-h_retrace]
        block_rows = np.concatenate(
            [np.repeat(rows[:, None], width, 1), np.zeros((n, h_retrace), int)], axis=1
        ).ravel()[:-h_retrace]
        block_cols = np.concatenate(
            [np.repeat(np.arange(width)[None], n, 0), np.zeros((n, h_retrace), int)], axis=1
        ).ravel()[:-h_retrace]
        first_next = fields[(i + 1) % len(fields)][0]
        vertical = _blanked_move(
            np.array([width - 1.0, y[-1]]), np.array([0.0, height - 1.0 - first_next]), v_retrace
        )
        pos_all += [block, vertical]
        on_all += [block_on, np.zeros(v_retrace, bool)]
        rows_all += [block_rows, np.zeros(v_retrace, int)]
        cols_all += [block_cols, np.zeros(v_retrace, int)]
    on = np.concatenate(on_all)
    flat = np.concatenate(rows_all) * width + np.concatenate(cols_all)
    positions = np.concatenate(pos_all)
    for arr in (positions, on, flat):
        arr.flags.writeable = False
    return positions, on, flat


@checked_jit
def _raster_beam(frame_buffer, positions, on, flat):
    frame_buffer = frame_buffer.astype(float_dtype(frame_buffer))
    intensity = jnp.where(on, frame_buffer.ravel()[flat], 0.0)
    return BeamPath(positions.astype(frame_buffer.dtype), intensity, on)


def random_scan(
    display_list: Float[Array, "S 2 2"],
    *,
    intensity: Float[Array, " S"] | None = None,
    samples_per_segment: int = 16,
    move_samples: int = 4,
) -> BeamPath:
    """One refresh of a random-scan (vector) display: the beam draws each line segment of
    the display list in turn, blanked while it moves to the next segment's start; after
    the last segment it returns to the first, and the list is redrawn every refresh.

    **Arguments:**

    - `display_list`: `(S, 2, 2)` segments `((x0, y0), (x1, y1))` in pixel coordinates.
    - `intensity`: `(S,)` brightness of each segment in `[0, 1]` (default 1).
    - `samples_per_segment`: time steps spent drawing each segment (static int >= 2).
    - `move_samples`: time steps of each blanked move (static int >= 1).

    **Returns:** a `BeamPath` with `T = S (samples_per_segment + move_samples)` steps.
    """
    segments = finite_arg(array_arg(display_list, "display_list"), "display_list")
    check_shape(segments, "display_list", (None, 2, 2))
    if segments.shape[0] < 1:
        raise ValueError("`display_list` must hold at least one segment")
    samples = static_int(
        samples_per_segment, "samples_per_segment", minimum=2, maximum=MAX_BEAM_STEPS
    )
    moves = static_int(move_samples, "move_samples", minimum=1, maximum=MAX_BEAM_STEPS)
    count = segments.shape[0]
    if intensity is None:
        intensity = np.ones(count)
    intensity = finite_arg(array_arg(intensity, "intensity"), "intensity")
    check_shape(intensity, "intensity", (count,))
    intensity = check_range(intensity, "intensity", minimum=0, maximum=1)
    return _random_beam(segments, intensity, samples, moves)


@checked_jit(static_argnums=(2, 3))
def _random_beam(segments, intensity, samples, moves):
    segments = segments.astype(float_dtype(segments))
    intensity = intensity.astype(float_dtype(intensity))
    count = segments.shape[0]
    t = jnp.linspace(0.0, 1.0, samples, dtype=segments.dtype)
    p0, p1 = segments[:, 0], segments[:, 1]
    draw = p0[:, None] + t[None, :, None] * (p1 - p0)[:, None]  # (S, samples, 2)
    next_start = jnp.roll(p0, -1, axis=0)
    u = (jnp.arange(moves, dtype=segments.dtype) + 1.0) / (moves + 1)
    move = p1[:, None] + u[None, :, None] * (next_start - p1)[:, None]
    positions = jnp.concatenate([draw, move], axis=1).reshape(-1, 2)
    on = jnp.concatenate([jnp.ones((count, samples), bool), jnp.zeros((count, moves), bool)], 1)
    level = jnp.concatenate(
        [jnp.broadcast_to(intensity[:, None], (count, samples)), jnp.zeros((count, moves))], 1
    )
    return BeamPath(positions, level.ravel().astype(segments.dtype), on.ravel())


def phosphor_frames(
    beam: BeamPath,
    shape: tuple[int, int],
    *,
    num_frames: int = 8,
    decay: float = 0.98,
    refreshes: int = 1,
) -> Float[Array, "F H W"]:
    """What the screen shows over time: the beam excites the phosphor at its position,
    and the glow decays by `decay` per time step (persistence).

    **Arguments:**

    - `beam`: a `BeamPath` from `raster_scan` or `random_scan` (one refresh).
    - `shape`: the screen shape `(H, W)` (static).
    - `num_frames`: snapshots, evenly spaced over the whole run (static int >= 1).
    - `decay`: glow kept per time step, in `(0, 1]`.
    - `refreshes`: how many times the beam path repeats (static int >= 1).

    **Returns:** float `(num_frames, H, W)` screen images in `[0, 1]`, the last one at
    the end of the run.
    """
    if not isinstance(beam, BeamPath):
        raise TypeError(f"`beam` must be a BeamPath, got {type(beam).__name__}")
    height, width = checked_shape(shape)
    num_frames = static_int(num_frames, "num_frames", minimum=1, maximum=MAX_BEAM_STEPS)
    refreshes = static_int(refreshes, "refreshes", minimum=1, maximum=MAX_BEAM_STEPS)
    work = num_frames * refreshes * beam.positions.shape[0]
    if work > _MAX_FRAME_WORK:
        raise ValueError(
            f"`num_frames * refreshes * len(beam)` must be <= {_MAX_FRAME_WORK} (a documented "
            f"size limit), got {work}"
        )
    given = isinstance(decay, np.ndarray | np.generic | jax.Array)
    decay = finite_arg(array_arg(decay, "decay"), "decay")
    check_shape(decay, "decay", ())
    decay = range_check(decay, "decay", low=0, high=1)
    if not given:  # a Python number follows the beam's dtype (float32 stays so under x64)
        decay = np.asarray(decay, float_dtype(beam.intensity))
    return _phosphor_frames(beam, decay, (height, width), num_frames, refreshes)


@jax.jit(static_argnames=("shape", "num_frames", "refreshes"))
def _phosphor_frames(beam, decay, shape, num_frames, refreshes):
    height, width = shape
    decay = decay.astype(float_dtype(decay))
    positions = jnp.tile(beam.positions, (refreshes, 1))
    level = jnp.tile(jnp.where(beam.on, beam.intensity, 0.0), refreshes)
    steps = positions.shape[0]
    cells = pixel_to_index(jnp.round(positions).astype(_INT), (height, width))
    rows, cols = cells[:, 0], cells[:, 1]
    inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
    flat = jnp.where(inside, cells[:, 0] * width + cells[:, 1], height * width)
    times = jnp.arange(steps)
    snaps = jnp.round(jnp.linspace(steps / num_frames, steps, num_frames)).astype(_INT) - 1
    age = snaps[:, None] - times[None, :]
    weights = jnp.where(age >= 0, decay ** jnp.maximum(age, 0), 0.0) * level[None, :]

    def one_frame(w):
        image = jax.ops.segment_sum(w, flat, num_segments=height * width + 1)[:-1]
        return image.reshape(height, width)

    return jnp.clip(jax.vmap(one_frame)(weights), 0.0, 1.0)
