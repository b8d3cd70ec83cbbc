"""Animation: key frames, procedural motion, skeletons, deformers and video files.

The submodules, all re-exported here:

- `keyframes`: `interpolate` (step, linear, Catmull-Rom, Hermite, Bezier easing), easing
  curves, `interpolate_rotations`, `Track`;
- `quaternions`: unit quaternions, `slerp`, `squad`;
- `procedural`: particle systems, damped springs, mass-spring chains, noise;
- `skeleton`: `Skeleton`, forward and inverse kinematics;
- `deform`: linear blend skinning and the curve deformer;
- `video`: `save_animation` and `container_info`.

Importing it loads neither matplotlib nor Pillow (GIF writing imports Pillow lazily).

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab.animation import interpolate
    >>> keys, values = jnp.array([0.0, 1.0, 2.0]), jnp.array([0.0, 10.0, 0.0])
    >>> interpolate(keys, values, jnp.array([0.5, 1.5])).tolist()
    [5.0, 5.0]
    >>> interpolate(keys, values, jnp.array([0.5, 1.5]), method="step").tolist()
    [0.0, 10.0]
"""

from __future__ import annotations

from . import deform, keyframes, procedural, quaternions, skeleton, video
from .deform import *  # noqa: F403
from .keyframes import *  # noqa: F403
from .procedural import *  # noqa: F403
from .quaternions import *  # noqa: F403
from .skeleton import *  # noqa: F403
from .video import *  # noqa: F403

__all__ = [
    *deform.__all__,
    *keyframes.__all__,
    *procedural.__all__,
    *quaternions.__all__,
    *skeleton.__all__,
    *video.__all__,
]
