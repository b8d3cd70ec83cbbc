"""JPEG, stage by stage and exactly.

- `gfxlab.jpeg.stages`: the textbook stages in floating point (differentiable):
  colour conversion, chroma subsampling, 8 x 8 blocks, level shift, DCT, IJG
  quantization tables, quantization, zig-zag, run-length and Huffman coding.
- `encode` / `decode`: real baseline JFIF files, bit-exact with libjpeg-turbo
  (Pillow): same coefficients, same bytes, same decoded pixels.
- `compress`: a differentiable round trip whose forward pass is libjpeg's.

All names are re-exported here: `from gfxlab.jpeg import dct2, encode, compress`.

Examples:
    >>> import numpy as np
    >>> from gfxlab import jpeg
    >>> ramp = np.linspace(0, 1, 16 * 16 * 3).reshape(16, 16, 3)
    >>> data = jpeg.encode(ramp, quality=90)  # the bytes of a baseline JFIF file
    >>> data[:2] == bytes([0xFF, 0xD8]), jpeg.decode(data).shape  # SOI marker; uint8 pixels
    (True, (16, 16, 3))
    >>> round(float(jpeg.psnr(jpeg.compress(ramp, quality=90.0), ramp)))  # dB, differentiable
    51
"""

from gfxlab.jpeg._tables import (
    AC_CHROMINANCE,
    AC_LUMINANCE,
    CHROMINANCE_TABLE,
    DC_CHROMINANCE,
    DC_LUMINANCE,
    LUMINANCE_TABLE,
    SUBSAMPLING,
    ZIGZAG,
    huffman_codes,
)
from gfxlab.jpeg.codec import MAX_PIXELS, JPEGError, coefficients, decode, encode
from gfxlab.jpeg.compress import compress, exact_tables, psnr
from gfxlab.jpeg.stages import (
    DCT_MATRIX,
    blocks,
    category,
    dct2,
    dequantize,
    huffman_code_block,
    idct2,
    level_shift,
    quant_tables,
    quant_tables_continuous,
    quantize,
    rgb_to_ycbcr,
    run_length,
    subsample,
    unblocks,
    unzigzag,
    upsample,
    ycbcr_to_rgb,
    zigzag,
)

__all__ = [
    "AC_CHROMINANCE",
    "AC_LUMINANCE",
    "CHROMINANCE_TABLE",
    "DCT_MATRIX",
    "DC_CHROMINANCE",
    "DC_LUMINANCE",
    "JPEGError",
    "LUMINANCE_TABLE",
    "MAX_PIXELS",
    "SUBSAMPLING",
    "ZIGZAG",
    "blocks",
    "category",
    "coefficients",
    "compress",
    "dct2",
    "decode",
    "dequantize",
    "encode",
    "exact_tables",
    "huffman_code_block",
    "huffman_codes",
    "idct2",
    "level_shift",
    "psnr",
    "quant_tables",
    "quant_tables_continuous",
    "quantize",
    "rgb_to_ycbcr",
    "run_length",
    "subsample",
    "unblocks",
    "unzigzag",
    "upsample",
    "ycbcr_to_rgb",
    "zigzag",
]
