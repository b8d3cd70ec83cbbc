"""XLA compiler options for programs that run faster with XLA's legacy CPU emitters.

XLA's legacy CPU emitters run gfxlab's 32-bit integer JPEG kernels (colour conversion,
the islow DCTs, quantization, Huffman events and decoding) faster than its newer fusion
emitters, measured on 2 cores with jaxlib 0.10: the encoder's coefficient kernel of a
512 x 512 RGB image 2.6 -> 1.2 ms jitted, and end to end, in a loop of one call,
`encode` 5.2 -> 3.3 ms and `decode` 4.7 -> 3.6 ms. Float programs (the renderer) are
faster with the newer emitters, so the choice is made per program, through
`jax.jit(..., compiler_options=...)`, not for the process. The results are the same
bits: integer arithmetic does not depend on the emitter.

A user's own choice wins: when `$XLA_FLAGS` sets `--xla_cpu_use_fusion_emitters`, no
option is passed. So does the backend: on GPU and TPU, and with an XLA that does not
know the option, none is passed either.
"""

from __future__ import annotations

import functools
import os
import re

import numpy as np

_OPTION = "xla_cpu_use_fusion_emitters"
_USER_SETS_OPTION = re.compile(rf"(^|\s)--(no)?{_OPTION}(=|\s|$)")


@functools.cache
def legacy_cpu_emitters() -> dict[str, bool] | None:
    """`compiler_options` for `jax.jit` that select XLA's legacy CPU emitters, or
    `None` where they do not apply (not on CPU, the user set the flag, or this XLA
    does not know it; probed once per process with a one-line program)."""
    import jax

    if _USER_SETS_OPTION.search(os.environ.get("XLA_FLAGS", "")) or jax.default_backend() != "cpu":
        return None
    options = {_OPTION: False}
    try:
        jax.jit(lambda x: x + 1, compiler_options=options).lower(np.int32(0)).compile()
    except Exception:  # an XLA without the option: "No such compile option"
        return None
    return options
