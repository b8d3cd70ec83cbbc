"""Benchmarks for gfxlab.animation: skinning and track evaluation at scale.

- Linear blend skinning of 100,000 vertices with 50 bones (3D), ours (jit) against the
  same algorithm in NumPy.
- Evaluating 1,000 tracks (position + rotation channels, 16 keys each) at 10,000 times,
  ours (jit, vectorized over tracks and times) against NumPy (`np.interp` per track and
  channel for positions, vectorized NumPy slerp for rotations).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from harness import Table, timeit

from gfxlab import animation as A
from gfxlab import transforms as tf


def _numpy_skin(vertices, weights, mats):
    blended = np.einsum("nb,bij->nij", weights, mats[:, :3, :])
    return np.einsum("nij,nj->ni", blended[..., :3], vertices) + blended[..., 3]


def _numpy_slerp(q0, q1, u):
    dot = np.sum(q0 * q1, -1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.clip(np.abs(dot), -1, 1)
    omega = np.arccos(dot)
    s = np.sin(omega)
    near = s < 1e-6
    s = np.where(near, 1.0, s)
    a = np.where(near, 1 - u, np.sin((1 - u) * omega) / s)
    b = np.where(near, u, np.sin(u * omega) / s)
    return a * q0 + b * q1


def _numpy_tracks(times, pos, quats, t):
    b, _ = times.shape
    out_p = np.empty((b, t.shape[0], 3), np.float32)
    out_q = np.empty((b, t.shape[0], 4), np.float32)
    for i in range(b):
        for c in range(3):
            out_p[i, :, c] = np.interp(t, times[i], pos[i, :, c])
        j = np.clip(np.searchsorted(times[i], t, side="right") - 1, 0, times.shape[1] - 2)
        u = np.clip((t - times[i, j]) / (times[i, j + 1] - times[i, j]), 0, 1)[:, None]
        out_q[i] = _numpy_slerp(quats[i, j], quats[i, j + 1], u)
    return out_p, out_q


def main() -> None:
    rng = np.random.default_rng(0)
    table = Table("gfxlab.animation (float32, CPU unless JAX has a GPU)", "NumPy")

    n, b = 100_000, 50
    verts = rng.normal(size=(n, 3)).astype(np.float32)
    weights = rng.dirichlet(np.ones(4), size=n).astype(np.float32)
    full = np.zeros((n, b), np.float32)
    cols = np.stack([rng.choice(b, 4, replace=False) for _ in range(n)])
    np.put_along_axis(full, cols, weights, axis=1)
    mats = np.asarray(
        tf.compose(
            tf.rotate_axis(rng.normal(size=(b, 3)), rng.normal(size=b)),
            tf.translate(rng.normal(size=(b, 3))),
        )
    ).astype(np.float32)
    skin = jax.jit(A.skin)
    args = (jnp.asarray(verts), jnp.asarray(full), jnp.asarray(mats))
    ours = timeit(lambda: skin(*args), repeat=5, warmup=1)
    ref = timeit(lambda: _numpy_skin(verts, full, mats), repeat=3, warmup=0)
    err = np.abs(np.asarray(skin(*args)) - _numpy_skin(verts, full, mats)).max()
    table.add(f"skin {n:,} vertices x {b} bones", ours, ref, f"max |diff| {err:.1e}")

    tracks, keys, samples = 1_000, 16, 10_000
    times = np.sort(rng.uniform(0, 10, (tracks, keys)), axis=-1).astype(np.float32)
    times[:, 0], times[:, -1] = 0.0, 10.0
    pos = rng.normal(size=(tracks, keys, 3)).astype(np.float32)
    quats = rng.normal(size=(tracks, keys, 4)).astype(np.float32)
    quats /= np.linalg.norm(quats, axis=-1, keepdims=True)
    t = np.linspace(0, 10, samples).astype(np.float32)
    track = A.Track(
        times=jnp.asarray(times),
        position=jnp.asarray(pos),
        rotation=jnp.asarray(quats),
        method="linear",
        rotation_method="slerp",
    )
    evaluate = jax.jit(lambda tr, s: tr(s))
    tj = jnp.asarray(t)
    ours = timeit(lambda: evaluate(track, tj), repeat=3, warmup=1)
    ref = timeit(lambda: _numpy_tracks(times, pos, quats, t), repeat=1, warmup=0)
    sample = evaluate(track, tj)
    ref_p, ref_q = _numpy_tracks(times, pos, quats, t)
    err_p = np.abs(np.asarray(sample.position) - ref_p).max()
    # quaternion sign: the NumPy slerp does not align key signs; compare rotations
    err_q = np.abs(np.abs(np.sum(np.asarray(sample.rotation) * ref_q, -1)) - 1).max()
    table.add(
        f"{tracks:,} tracks x {samples:,} times, linear pos + slerp rot",
        ours,
        ref,
        f"pos |diff| {err_p:.1e}, rot 1-|dot| {err_q:.1e}",
    )

    cr = A.Track(times=jnp.asarray(times), position=jnp.asarray(pos), method="catmull_rom")
    ours = timeit(lambda: evaluate(cr, tj), repeat=3, warmup=1)
    table.add(f"{tracks:,} tracks x {samples:,} times, Catmull-Rom pos", ours, None, "")
    table.print()


if __name__ == "__main__":
    main()
