"""Run the benchmarks: `make bench` (all) or `make bench BENCH="raster jpeg"`.

Each `bench_<name>.py` beside this file defines `main()`, which prints its tables.
"""

from __future__ import annotations

import importlib
import pathlib
import sys
import time

HERE = pathlib.Path(__file__).parent
sys.path.insert(0, str(HERE))


def main(names: list[str]) -> int:
    available = sorted(p.stem.removeprefix("bench_") for p in HERE.glob("bench_*.py"))
    chosen = names or available
    unknown = [n for n in chosen if n not in available]
    if unknown:
        print(f"unknown benchmark(s) {unknown}; available: {available}")
        return 2
    for name in chosen:
        start = time.perf_counter()
        print(f"\n# bench_{name}")
        importlib.import_module(f"bench_{name}").main()
        print(f"\n({name}: {time.perf_counter() - start:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
