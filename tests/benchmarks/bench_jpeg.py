"""Benchmarks for gfxlab.jpeg against Pillow (libjpeg-turbo).

- `encode` of a 512 x 512 RGB photograph-like image at quality 75 (the eager call a
  user makes), a batched `encode` of 32 such images against Pillow encoding them one
  by one, and the fraction of byte-identical files over a set of images, qualities
  and subsamplings;
- `decode` of Pillow files (512 x 512 RGB q75 4:2:0, and a 512 x 512 q95 4:4:4 photo
  with film grain, ~600 KB) against Pillow, and its peak memory above input + output;
- `compress` (differentiable round trip) against Pillow's real round trip: PSNR over
  q = 1..95 (identical outputs have infinite PSNR); against Kornia's
  `jpeg_codec_differentiable` when torch and kornia are installed (the `bench` extra);
- a long fuzz run of `decode` on mutated files (`BENCH_JPEG_FUZZ` cases, 10^5 by
  default): each must end in an image or `JPEGError`, in bounded memory.
"""

from __future__ import annotations

import io
import os
import sys
import time
import warnings
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from harness import Table, timeit, timeit_pair
from PIL import Image

from gfxlab import jpeg

SUBSAMPLING = {"4:4:4": 0, "4:2:2": 1, "4:2:0": 2}


def _scene(height: int, width: int, seed: int) -> np.ndarray:
    try:
        from gfxlab.image import synthetic_scene

        img = np.asarray(synthetic_scene((height, width), key=jax.random.key(seed)))
        return (
            np.clip(np.round(img * 255), 0, 255).astype(np.uint8) if img.dtype != np.uint8 else img
        )
    except Exception:  # fall back to a procedural image of our own
        rng = np.random.default_rng(seed)
        y, x = np.mgrid[:height, :width] / max(height, width)
        img = np.stack([0.5 + 0.4 * np.sin(9 * x + 3 * y), 0.5 + 0.3 * np.cos(13 * y), x * y], -1)
        img = img + 0.04 * rng.normal(size=img.shape)
        return (np.clip(img, 0, 1) * 255).astype(np.uint8)


def _pillow(img, quality, subsampling="4:2:0") -> bytes:
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, "JPEG", quality=quality, subsampling=SUBSAMPLING[subsampling])
    return buf.getvalue()


def _grain(height: int, width: int, seed: int) -> np.ndarray:
    """A photo-like image with strong film grain: large q95 files (~600 KB at 512^2)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[:height, :width]
    img = np.stack([128 + 100 * np.sin(x / 5 + y / 7), 128 + 80 * np.cos(x / 3), y / 2.0], -1)
    return np.clip(img + rng.normal(0, 60, img.shape), 0, 255).astype(np.uint8)


def _pillow_decode(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)))


def _decode_rows(table: Table, photo: np.ndarray) -> None:
    sys.path.insert(0, str(Path(__file__).parents[1]))
    from test_jpeg_fuzz import peak_bytes_of

    cases = [
        ("decode 512x512 RGB q=75 4:2:0 (Pillow file)", _pillow(photo, 75)),
        ("decode 512x512 grey q=75", _pillow(photo[..., 1].copy(), 75)),
        ("decode 512x512 RGB q=95 4:4:4 grain", _pillow(_grain(512, 512, 9), 95, "4:4:4")),
    ]
    for name, data in cases:
        start = time.perf_counter()
        decoded = jpeg.decode(data)
        first = time.perf_counter() - start
        same = np.array_equal(decoded, _pillow_decode(data))
        ours, theirs = timeit_pair(
            lambda d=data: jpeg.decode(d), lambda d=data: _pillow_decode(d), repeat=7, warmup=1
        )
        peak, out = peak_bytes_of(lambda d=data: jpeg.decode(d))
        extra = (peak - len(data) - out.nbytes) / 1e6
        table.add(
            name,
            ours,
            theirs,
            f"{len(data) // 1000} KB; pixels identical: {same}; peak memory above input + "
            f"output {extra:.1f} MB; first call {first:.2f} s",
        )


def _batch_row(table: Table, count: int = 32) -> None:
    """Batched `encode` of `count` 512 x 512 RGB images against Pillow encoding them one
    after the other (the ratio is the throughput ratio)."""
    stack = np.stack([_scene(512, 512, seed) for seed in range(count)])
    start = time.perf_counter()
    files = jpeg.encode(stack, quality=75)
    first = time.perf_counter() - start
    same = all(f == _pillow(img, 75) for f, img in zip(files, stack, strict=True))
    ours, theirs = timeit_pair(
        lambda: jpeg.encode(stack, quality=75),
        lambda: [_pillow(img, 75) for img in stack],
        repeat=5,
        warmup=1,
    )
    table.add(
        f"encode batch of {count} 512x512 RGB q=75 vs Pillow serial",
        ours,
        theirs,
        f"ratio = throughput ratio; {count / ours:.0f} images/s; every file byte-identical: "
        f"{same}; first call {first:.2f} s",
    )


def _kornia_row(table: Table, photo: np.ndarray) -> None:
    """`compress` against Kornia's differentiable JPEG (only with torch + kornia)."""
    try:
        import kornia
        import torch
    except ImportError:
        table.add("compress vs Kornia", 0.0, None, "skipped: torch/kornia not installed")
        return
    img = photo[:256, :256] / 255.0
    x = jnp.asarray(img)
    fwd = jax.jit(lambda x: jpeg.compress(x, quality=75.0))
    grad = jax.jit(jax.grad(lambda x: jnp.sum(jpeg.compress(x, quality=75.0))))
    t = torch.tensor(img.transpose(2, 0, 1)[None], dtype=torch.float32, requires_grad=True)
    q = torch.tensor([75.0])

    def kornia_grad():
        t.grad = None
        kornia.enhance.jpeg_codec_differentiable(t, q).sum().backward()

    table.add(
        "compress 256x256 q=75 forward vs Kornia",
        *timeit_pair(
            lambda: fwd(x), lambda: kornia.enhance.jpeg_codec_differentiable(t, q), repeat=7
        ),
    )
    table.add(
        "grad of compress 256x256 vs Kornia", *timeit_pair(lambda: grad(x), kornia_grad, repeat=5)
    )


def main() -> None:
    photo = _scene(512, 512, 0)
    table = Table("gfxlab.jpeg vs Pillow (libjpeg-turbo)", "Pillow")
    start = time.perf_counter()
    data = jpeg.encode(photo, quality=75)
    first = time.perf_counter() - start
    # Medians of many runs, ours and Pillow's alternating: single runs of ~1 ms are noisy.
    table.add(
        "encode 512x512 RGB q=75 4:2:0",
        *timeit_pair(lambda: jpeg.encode(photo, quality=75), lambda: _pillow(photo, 75)),
        f"byte-identical: {data == _pillow(photo, 75)}; first call (compiles) {first:.2f} s",
    )
    _batch_row(table)
    grey = photo[..., 1].copy()
    table.add(
        "encode 512x512 grey q=75",
        *timeit_pair(
            lambda: jpeg.encode(grey, quality=75, subsampling="4:4:4"),
            lambda: _pillow(grey, 75, "4:4:4"),
        ),
    )
    small = photo[:200, :200].copy()  # below the compile threshold: the NumPy path
    table.add(
        "encode 200x200 RGB q=75 (NumPy path)",
        timeit(lambda: jpeg.encode(small, quality=75), repeat=21),
        timeit(lambda: _pillow(small, 75), repeat=21),
    )
    _decode_rows(table, photo)

    # byte identity over a set of images
    same = total = 0
    rng = np.random.default_rng(1)
    for seed in range(8):
        h, w = (int(v) for v in rng.integers(8, 300, 2))
        img = _scene(h, w, seed)
        for quality in (1, 10, 30, 50, 75, 90, 95, 100):
            for sub in SUBSAMPLING:
                same += jpeg.encode(img, quality=quality, subsampling=sub) == _pillow(
                    img, quality, sub
                )
                total += 1
            same += jpeg.encode(img[..., 0], quality=quality) == _pillow(
                img[..., 0].copy(), quality
            )
            total += 1
    table.add("byte identity over a test set", 0.0, None, f"{same}/{total} files identical")

    # compress vs Pillow's round trip over q = 1..95
    x = jnp.asarray(photo / 255.0)
    fn = jax.jit(lambda x, q: jpeg.compress(x, quality=q))
    psnrs = []
    for quality in range(1, 96):
        ours = np.round(np.asarray(fn(x, float(quality))) * 255)
        theirs = np.asarray(Image.open(io.BytesIO(_pillow(photo, quality))), float)
        mse = np.mean((ours - theirs) ** 2)
        psnrs.append(np.inf if mse == 0 else 10 * np.log10(255**2 / mse))
    psnrs = np.array(psnrs)
    finite = psnrs[np.isfinite(psnrs)]
    note = f"PSNR vs Pillow round trip, q=1..95: {np.isinf(psnrs).sum()}/95 identical (inf dB)" + (
        f", others mean {finite.mean():.1f} dB" if finite.size else ""
    )
    table.add(
        "compress 512x512 q=75 (jit) vs Pillow save+open",
        timeit(lambda: fn(x, 75.0), repeat=5),
        timeit(lambda: np.asarray(Image.open(io.BytesIO(_pillow(photo, 75)))), repeat=5),
        note,
    )
    grad = jax.jit(jax.grad(lambda x, q: jnp.sum(jpeg.compress(x, quality=q) ** 2), (0, 1)))
    table.add("grad of compress 512x512 (jit)", timeit(lambda: grad(x, 75.0), repeat=3))
    _kornia_row(table, photo)

    # long fuzz run
    sys.path.insert(0, str(Path(__file__).parents[1]))
    from test_jpeg_fuzz import peak_bytes_of, run_fuzz

    n = int(os.environ.get("BENCH_JPEG_FUZZ", 100_000))
    run_fuzz(200, 1)  # compile what the decoded images need
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        peak, outcomes = peak_bytes_of(lambda: run_fuzz(n, 99))
    elapsed = time.perf_counter() - start
    table.add(
        f"fuzz decode, {n} mutated files",
        elapsed / n,
        None,
        f"{outcomes}, no other exception; peak memory {peak / 1e6:.1f} MB above the start",
    )
    table.print()


if __name__ == "__main__":
    main()
