"""Properties of a BRDF (reciprocity, directional albedo), a sphere shader, and
Rusinkiewicz's half/difference angles."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import (
    as_float,
    check_finite,
    check_key,
    check_last_dim,
    checked_filter_jit,
    checked_jit,
    safe_normalize,
    static_bool,
    static_int,
    static_shape,
    value_error_if,
)
from .._pixels import pixel_centers
from ._common import (
    BRDF,
    MAX_PIXELS,
    MAX_QUADRATURE,
    MAX_SAMPLES,
    _batch,
    _dot,
    _reflect,
    _unit_vectors,
    check_brdf,
)


def _frame(axis: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Two unit vectors completing the unit `axis` to a right-handed orthonormal frame."""
    helper = jnp.where(
        (jnp.abs(axis[..., 2]) < 0.9)[..., None],
        jnp.array([0.0, 0.0, 1.0], axis.dtype),
        jnp.array([1.0, 0.0, 0.0], axis.dtype),
    )
    tangent = safe_normalize(jnp.cross(helper, axis))
    return tangent, jnp.cross(axis, tangent)


def _hemisphere_samples(key, count: int, n: jax.Array, dtype) -> jax.Array:
    """`count` directions uniform on the hemisphere around each normal `n`."""
    u = jax.random.uniform(key, (count, 2), dtype=dtype)
    cos_t = u[:, 0]
    sin_t = jnp.sqrt(jnp.maximum(1.0 - cos_t * cos_t, 0.0))
    phi = 2.0 * jnp.pi * u[:, 1]
    t, b = _frame(n)
    local = jnp.stack([sin_t * jnp.cos(phi), sin_t * jnp.sin(phi), cos_t], axis=-1)
    return safe_normalize(local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * n)


def reciprocity_error(
    brdf: BRDF,
    wi: Float[Array, "*batch 3"] | None = None,
    wo: Float[Array, "*batch 3"] | None = None,
    n: Float[Array, "*batch 3"] | None = None,
    *,
    num_samples: int = 512,
    key: jax.Array | None = None,
) -> Float[Array, ""]:
    """The largest relative asymmetry `|f(wi, wo) - f(wo, wi)| / max(f(wi, wo), f(wo, wi))`.

    0 (to rounding) for a reciprocal BRDF.

    **Arguments:**

    - `brdf`: a callable `brdf(wi, wo, n)`, e.g. a `CookTorrance` module or
      `functools.partial(phong, normalized=False)`.
    - `wi`, `wo`, `n`: directions to test; without `wi` or `wo`, `num_samples`
      random directions uniform on the upper hemisphere about `n` (default
      `(0, 0, 1)`) take their place.
    - `num_samples`: the random directions' count (static, at most `MAX_SAMPLES`).
    - `key`: the `jax.random` key that draws them (e.g. `jax.random.key(0)`); needed
      unless both `wi` and `wo` are given.

    **Returns:** a scalar in [0, 1] (0/0 counts as 0).

    Examples:
        >>> import jax
        >>> from gfxlab import brdf
        >>> error = brdf.reciprocity_error(brdf.CookTorrance(0.3), key=jax.random.key(0))
        >>> bool(error < 1e-4)  # reciprocal, to rounding
        True
    """
    check_brdf(brdf)
    num_samples = static_int(num_samples, "num_samples", minimum=1, maximum=MAX_SAMPLES)
    n = jnp.array([0.0, 0.0, 1.0], jnp.result_type(float)) if n is None else as_float(n, "n")
    check_last_dim(n, "n", (3,), "3D unit normals")
    given = {}
    for name, value in (("wi", wi), ("wo", wo)):
        if value is not None:
            given[name] = as_float(value, name)
            check_last_dim(given[name], name, (3,), "3D unit directions")
    key = check_key(key, needed=wi is None or wo is None)
    return _reciprocity(brdf, given.get("wi"), given.get("wo"), n, key, num_samples)


@checked_filter_jit
def _reciprocity(brdf, wi, wo, n, key, num_samples):
    # Compiled once per BRDF structure; the default pairs are drawn inside.
    n = check_finite(n, "n")
    if key is not None:
        key_i, key_o = jax.random.split(key)
        wi = _hemisphere_samples(key_i, num_samples, n, n.dtype) if wi is None else wi
        wo = _hemisphere_samples(key_o, num_samples, n, n.dtype) if wo is None else wo
    wi, wo = check_finite(wi, "wi"), check_finite(wo, "wo")
    forward = brdf(wi, wo, n)
    backward = brdf(wo, wi, n)
    scale = jnp.maximum(jnp.abs(forward), jnp.abs(backward))
    positive = scale > 0
    rel = jnp.where(positive, jnp.abs(forward - backward) / jnp.where(positive, scale, 1.0), 0.0)
    return jnp.max(rel)


def _albedo_grid(num_theta: int, num_phi: int, dtype) -> tuple[np.ndarray, ...]:
    """Quadrature on the sphere around a pole: Gauss-Legendre in `u` with
    `theta = pi u^2` (nodes crowd towards the pole, where the lobes peak) and the
    midpoint rule in `phi` (exact for trigonometric polynomials)."""
    x, w = np.polynomial.legendre.leggauss(num_theta)
    u, wu = 0.5 * (x + 1.0), 0.5 * w
    theta = np.pi * u * u
    weight_theta = wu * 2.0 * np.pi * u * np.sin(theta)  # d(theta)/du * sin(theta)
    phi = 2.0 * np.pi * (np.arange(num_phi) + 0.5) / num_phi
    weights = weight_theta[:, None] * np.full(num_phi, 2.0 * np.pi / num_phi)[None, :]
    local = np.stack(
        [
            np.sin(theta)[:, None] * np.cos(phi)[None, :],
            np.sin(theta)[:, None] * np.sin(phi)[None, :],
            np.broadcast_to(np.cos(theta)[:, None], (num_theta, num_phi)),
        ],
        axis=-1,
    )
    return local.reshape(-1, 3).astype(dtype), weights.reshape(-1).astype(dtype)


def directional_albedo(
    brdf: BRDF,
    wo: Float[Array, "*batch 3"],
    n: Float[Array, "*batch 3"] | None = None,
    *,
    num_theta: int = 256,
    num_phi: int = 128,
) -> Float[Array, "*batch"]:
    """Directional albedo `rho(wo) = integral over wi of f(wi, wo, n) cos(theta_i)`.

    The fraction of light arriving uniformly from all directions that leaves towards
    `wo` (the white-furnace test: a surface in a uniformly white environment looks
    exactly `rho` bright). Energy conservation requires `rho <= 1` for every `wo`.

    Deterministic quadrature over the whole sphere centred on the mirror direction of
    `wo`, where specular lobes peak (`num_theta * num_phi` BRDF evaluations per `wo`,
    one `wo` at a time). The default 256 x 128 is accurate to about 1e-4 for
    Lambert, and to 1e-3 for lobes down to GGX roughness 0.2 or Phong shininess 1000;
    sharper lobes at grazing angles need more points.

    **Arguments:**

    - `brdf`: a callable `brdf(wi, wo, n)` (whose parameters broadcast with the
      directions' batch shape; for a batch of parameters, `jax.vmap` over them).
    - `wo`: `(..., 3)` unit view directions.
    - `n`: `(..., 3)` unit normals (default `(0, 0, 1)`).
    - `num_theta`, `num_phi`: quadrature points (static, each at most
      `MAX_QUADRATURE`).

    **Returns:** `(...)` albedo values.
    """
    check_brdf(brdf)
    num_theta = static_int(num_theta, "num_theta", minimum=2, maximum=MAX_QUADRATURE)
    num_phi = static_int(num_phi, "num_phi", minimum=2, maximum=MAX_QUADRATURE)
    wo = as_float(wo, "wo")
    n = jnp.array([0.0, 0.0, 1.0], wo.dtype) if n is None else as_float(n, "n")
    for v, name in ((wo, "wo"), (n, "n")):
        check_last_dim(v, name, (3,), "3D direction vectors")
    dtype = jnp.result_type(wo, n)
    batch = _batch({"wo": wo, "n": n}, {"wo": 1, "n": 1})
    local, weights = _quadrature_or_up((num_theta, num_phi), dtype)
    return _albedo_quadrature(brdf, wo.astype(dtype), n.astype(dtype), local, weights, batch)


@functools.cache
def _quadrature_or_up(which, dtype):
    """Constant arrays, made once per dtype: the quadrature grid `(num_theta, num_phi)`
    of `directional_albedo`, or "up", the view direction of `shade_sphere`."""
    with jax.ensure_compile_time_eval():  # concrete arrays, even when called under jit
        if which == "up":
            return jnp.array([0.0, 0.0, 1.0], dtype)
        local, weights = _albedo_grid(*which, np.dtype(dtype))
        return jnp.asarray(local), jnp.asarray(weights)


@checked_filter_jit
def _albedo_quadrature(brdf, wo, n, local, weights, batch):
    # Compiled once per BRDF structure (a model's parameters are traced leaves), and
    # mapped over the view directions to keep memory at one quadrature grid.
    wo, n = _unit_vectors(wo, "wo"), _unit_vectors(n, "n")
    wo_flat = jnp.broadcast_to(wo, batch + (3,)).reshape(-1, 3)
    n_flat = jnp.broadcast_to(n, batch + (3,)).reshape(-1, 3)

    def one(pair):
        w_o, normal = pair
        axis = safe_normalize(_reflect(w_o, normal))
        t, b = _frame(axis)
        wi = safe_normalize(local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * axis)
        cos_i = jnp.maximum(wi @ normal, 0.0)
        values = brdf(wi, jnp.broadcast_to(w_o, wi.shape), jnp.broadcast_to(normal, wi.shape))
        return jnp.sum(values * cos_i * weights)

    return jax.lax.map(one, (wo_flat, n_flat)).reshape(batch)


# --------------------------------------------------------------------------- rendering


def shade_sphere(
    brdf: BRDF,
    shape: tuple[int, int],
    *,
    light: Float[Array, "3"] = (1.0, 1.0, 1.0),
    point_light: bool = False,
    intensity=1.0,
    radius: float = 0.9,
    background=0.0,
) -> Float[Array, "H W"]:
    """Render a unit sphere with any BRDF under one light, seen orthographically.

    The viewer looks down the -z axis (`wo = (0, 0, 1)` at every pixel); x points
    right and y up, following the pixel convention (pixel `(row, col)` has its centre
    at `(col, H - 1 - row)`). Each pixel gets the outgoing radiance
    `L = f(wi, wo, n) * E * max(n . wi, 0)`, no shadows or ambient term.

    **Arguments:**

    - `brdf`: a callable `brdf(wi, wo, n)` on `(H, W, 3)` arrays (for colour, vmap
      over a model with per-channel parameters).
    - `shape`: image shape `(H, W)` (static, at most `MAX_PIXELS` pixels).
    - `light`: a direction towards the light (normalised here), or with
      `point_light=True` the light's position, in units of the sphere radius with the
      sphere centred at the origin.
    - `point_light`: use a point light (inverse-square falloff) instead of a
      directional one.
    - `intensity`: the directional light's irradiance (normal to the light), or the
      point light's intensity (power per steradian).
    - `radius`: the sphere's radius as a fraction of half the smaller image side.
    - `background`: value of pixels that miss the sphere.

    **Returns:** `(H, W)` linear radiance (not clipped; highlights may exceed 1).
    """
    check_brdf(brdf)
    height, width = static_shape(shape)
    static_int(height * width, "shape[0] * shape[1]", maximum=MAX_PIXELS)
    light = as_float(light, "light")
    check_last_dim(light, "light", (3,), "a 3D direction or position")
    if light.ndim != 1:
        raise ValueError(f"`light` must be a single 3-vector, got shape {tuple(light.shape)}")
    if isinstance(radius, bool) or not isinstance(radius, int | float | np.integer | np.floating):
        raise TypeError(f"`radius` must be a positive number, got {radius!r}")
    radius = float(radius)
    if not (0 < radius < np.inf):
        raise ValueError(f"`radius` must be positive and finite, got {radius}")
    static_bool(point_light, "point_light")
    dtype = jnp.result_type(light.dtype, float)
    intensity = as_float(intensity, "intensity").astype(dtype)
    background = as_float(background, "background").astype(dtype)
    for value, name in ((intensity, "intensity"), (background, "background")):
        if value.ndim:
            raise ValueError(f"`{name}` must be a scalar, got shape {tuple(value.shape)}")
    # The radius and the view direction go in as arrays: as constants, XLA would fold
    # the whole image (and the checks on it) at compile time, which takes seconds.
    # (JAX arrays: `equinox.filter_jit` is slow to take NumPy arrays.)
    frame = (jnp.asarray(radius, dtype), _quadrature_or_up("up", dtype))
    shading = (height, width, bool(point_light))
    return _shade(brdf, light.astype(dtype), intensity, background, frame, shading)


@checked_filter_jit
def _shade(brdf, light, intensity, background, frame, shading):
    # Compiled once per BRDF structure, image size and kind of light.
    radius, up = frame
    height, width, point_light = shading
    light = check_finite(light, "light")
    light = value_error_if(light, jnp.all(light == 0), "`light` must not be the zero vector")
    intensity = check_finite(intensity, "intensity")
    background = check_finite(background, "background")
    # The pixel grid (y up) of gfxlab._pixels, centred on the image and scaled so that
    # the sphere's radius is `radius` times half the smaller side.
    dtype = light.dtype
    centre = jnp.array([(width - 1) / 2, (height - 1) / 2], dtype)
    xy = (pixel_centers((height, width), dtype=dtype) - centre) / (
        radius * 0.5 * min(height, width)
    )
    x, y = xy[..., 0], xy[..., 1]
    r2 = x * x + y * y
    inside = r2 < 1.0
    z = jnp.sqrt(jnp.where(inside, 1.0 - r2, 1.0))
    normal = jnp.where(inside[..., None], jnp.stack([x, y, z], axis=-1), up)
    normal = safe_normalize(normal)
    wo = jnp.broadcast_to(up, normal.shape)
    if point_light:
        to_light = light - normal
        dist2 = jnp.sum(to_light * to_light, axis=-1)
        wi = safe_normalize(to_light)
        irradiance = intensity / jnp.where(dist2 > 0, dist2, 1.0)
    else:
        wi = jnp.broadcast_to(safe_normalize(light), normal.shape)
        irradiance = intensity
    cos_i = jnp.maximum(_dot(normal, wi), 0.0)
    radiance = brdf(wi, wo, normal) * irradiance * cos_i
    return jnp.where(inside, radiance, background)


def half_diff_to_directions(
    theta_h: Float[Array, "..."],
    theta_d: Float[Array, "..."],
    phi_d: Float[Array, "..."],
    phi_h=0.0,
) -> tuple[Float[Array, "... 3"], Float[Array, "... 3"]]:
    """Directions `(wi, wo)` from Rusinkiewicz's half/difference angles (n = +z).

    Measured-BRDF datasets (e.g. MERL) tabulate isotropic BRDFs over
    `(theta_h, theta_d, phi_d)`: the half vector's polar angle, and the incoming
    direction's polar and azimuth angles in a frame whose pole is the half vector.

    **Returns:** `wi`, `wo` as `(..., 3)` unit vectors (possibly below the horizon).
    """
    names = ("theta_h", "theta_d", "phi_d", "phi_h")
    arrays = {
        name: as_float(a, name)
        for a, name in zip((theta_h, theta_d, phi_d, phi_h), names, strict=True)
    }
    _batch(arrays, {})
    dtype = jnp.result_type(*arrays.values())
    return _half_diff(*(a.astype(dtype) for a in arrays.values()))


@checked_jit
def _half_diff(th, td, pd, ph):
    th, td, pd, ph = (
        check_finite(a, name)
        for a, name in zip((th, td, pd, ph), ("theta_h", "theta_d", "phi_d", "phi_h"), strict=True)
    )
    th, td, pd, ph = jnp.broadcast_arrays(th, td, pd, ph)
    d = jnp.stack([jnp.sin(td) * jnp.cos(pd), jnp.sin(td) * jnp.sin(pd), jnp.cos(td)], axis=-1)
    d_mirror = d * jnp.array([-1.0, -1.0, 1.0], d.dtype)

    def to_world(v):
        # rotate about y by theta_h, then about z by phi_h
        x1 = jnp.cos(th) * v[..., 0] + jnp.sin(th) * v[..., 2]
        z1 = -jnp.sin(th) * v[..., 0] + jnp.cos(th) * v[..., 2]
        y1 = v[..., 1]
        return jnp.stack(
            [jnp.cos(ph) * x1 - jnp.sin(ph) * y1, jnp.sin(ph) * x1 + jnp.cos(ph) * y1, z1], axis=-1
        )

    return to_world(d), to_world(d_mirror)
