"""Regenerate the colour tables in this folder from colour-science.

Run from the repository root: `python data/color/make_tables.py`. Writes

- `cie_observer.csv`: wavelength (nm, 360..830 step 1), the CIE 1931 2-degree
  colour-matching functions xbar, ybar, zbar and the CIE 1924 photopic luminous
  efficiency function V(lambda);
- `cie_d65.csv`: the CIE standard illuminant D65 relative spectral power
  distribution (nm, 300..780 step 5), as colour-science tabulates it.

Values are written with `repr`, so reading them back gives colour-science's float64
numbers exactly. `gfxlab.color` reads these files and falls back to colour-science
when they are missing.
"""

from __future__ import annotations

import pathlib

import colour
import numpy as np
from colour.colorimetry import SDS_LEFS_PHOTOPIC

HERE = pathlib.Path(__file__).resolve().parent


def _write(path: pathlib.Path, header: str, columns: list[np.ndarray]) -> None:
    rows = [",".join(repr(float(v)) for v in row) for row in zip(*columns, strict=True)]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")


def main() -> None:
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    lef = SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    if not np.array_equal(cmfs.wavelengths, lef.wavelengths):
        raise RuntimeError("the CMF and V(lambda) tables no longer share a wavelength grid")
    _write(
        HERE / "cie_observer.csv",
        "wavelength_nm,xbar,ybar,zbar,V",
        [cmfs.wavelengths, *cmfs.values.T, lef.values],
    )
    d65 = colour.SDS_ILLUMINANTS["D65"]
    _write(HERE / "cie_d65.csv", "wavelength_nm,D65", [d65.wavelengths, d65.values])
    print(f"wrote tables to {HERE} (colour-science {colour.__version__})")


if __name__ == "__main__":
    main()
