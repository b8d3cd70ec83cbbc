"""Procedural animation: particles, springs and noise (gfxlab.animation)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gfxlab import animation as A


def test_particles_free_flight_matches_closed_form():
    # Semi-implicit Euler from p0, v0 under constant g: after n steps
    # v_n = v0 + n dt g and p_n = p0 + n dt v0 + dt^2 g n (n + 1) / 2.
    p0, v0 = jnp.array([[0.0, 1.0], [2.0, 3.0]]), jnp.array([[1.0, 2.0], [-1.0, 0.5]])
    g, dt, n = jnp.array([0.0, -9.81]), 0.01, 50
    ps, vs = A.simulate_particles(A.Particles(p0, v0, jnp.zeros(2)), steps=n, dt=dt, gravity=g)
    k = jnp.arange(n + 1.0)[:, None, None]
    np.testing.assert_allclose(vs, v0 + k * dt * g, atol=1e-12)
    np.testing.assert_allclose(ps, p0 + k * dt * v0 + dt**2 * g * k * (k + 1) / 2, atol=1e-12)


def test_particles_bounce_on_plane_and_drag():
    particles = A.emit(
        jax.random.key(0),
        64,
        origin=jnp.array([0.0, 1.0]),
        direction=jnp.array([1.0, 1.0]),
        speed=4.0,
        rate=200.0,
    )
    assert jnp.allclose(particles.birth[1] - particles.birth[0], 1 / 200)
    floor = (jnp.array([[0.0, 1.0]]), jnp.array([0.0]))
    ps, vs = A.simulate_particles(particles, steps=300, dt=0.01, planes=floor, restitution=0.6)
    assert ps[..., 1].min() >= -1e-12  # nobody falls through the floor
    energy = 0.5 * jnp.sum(vs**2, -1) + 9.81 * ps[..., 1]
    assert jnp.all(energy[-1] < energy[0] - 1.0)  # bounces lose energy
    # before its birth a particle waits at the emitter
    np.testing.assert_allclose(ps[:5, -1], jnp.broadcast_to(particles.position[-1], (5, 2)))
    # linear drag: the speed tends to the terminal velocity g / drag
    still = A.Particles(jnp.zeros((1, 2)), jnp.zeros((1, 2)), jnp.zeros(1))
    _, vs = A.simulate_particles(still, steps=2000, dt=0.01, drag=2.0)
    np.testing.assert_allclose(vs[-1, 0], [0.0, -9.81 / 2.0], atol=1e-6)


def test_damped_spring_matches_analytic_solution():
    k, c, dt, n = 40.0, 1.5, 1e-4, 20000
    xs = A.damped_spring(0.0, 0.0, 1.0, stiffness=k, damping=c, dt=dt, steps=n)
    t = dt * jnp.arange(1, n + 1)
    zeta_w, wd = c / 2, jnp.sqrt(k - c**2 / 4)
    exact = 1 - jnp.exp(-zeta_w * t) * (jnp.cos(wd * t) + zeta_w / wd * jnp.sin(wd * t))
    np.testing.assert_allclose(xs, exact, atol=2e-3)
    # a moving target: the spring lags behind it (secondary motion)
    target = jnp.sin(jnp.linspace(0, 6, 200))
    follow = A.damped_spring(0.0, 0.0, target, stiffness=k, damping=c, dt=0.03)
    assert follow.shape == (200,) and jnp.argmax(follow) > jnp.argmax(target)


def test_spring_pair_frequency_and_integrators_agree():
    # Two unit masses on a spring: the stretch oscillates at sqrt(2 k / m).
    k, dt, n = 25.0, 1e-3, 3000
    pos = jnp.array([[0.0, 0.0], [1.2, 0.0]])
    kw = dict(steps=n, dt=dt, stiffness=k, damping=0.0, rest_length=jnp.array([1.0]))
    for integrator in ("semi_implicit_euler", "verlet"):
        xs = A.simulate_springs(
            pos, jnp.zeros((2, 2)), A.chain_springs(2), integrator=integrator, **kw
        )
        stretch = xs[:, 1, 0] - xs[:, 0, 0] - 1.0
        exact = 0.2 * jnp.cos(jnp.sqrt(2 * k) * dt * jnp.arange(n + 1))
        np.testing.assert_allclose(stretch, exact, atol=5e-3)


def test_hanging_chain_pinned_and_settles():
    n = 6
    pos = jnp.stack([jnp.arange(n) * 0.5, jnp.zeros(n)], -1)
    pinned = jnp.arange(n) == 0
    xs = A.simulate_springs(
        pos,
        jnp.zeros_like(pos),
        A.chain_springs(n),
        steps=3000,
        dt=0.005,
        stiffness=400.0,
        damping=2.0,
        gravity=jnp.array([0.0, -9.81]),
        pinned=pinned,
        integrator="verlet",
    )
    np.testing.assert_allclose(xs[:, 0], jnp.zeros((3001, 2)), atol=1e-12)
    # at rest the chain hangs straight down below the pin
    np.testing.assert_allclose(xs[-1, :, 0], 0.0, atol=1e-2)
    assert jnp.all(jnp.diff(xs[-1, :, 1]) < 0)
    # Spring forces balance the weight below: the top spring holds 5 masses.
    np.testing.assert_allclose(-xs[-1, 1, 1] - 0.5, 5 * 9.81 / 400, rtol=1e-2)


def test_noise_properties():
    lattice = jnp.arange(-3.0, 4.0)[:, None]
    assert jnp.all(jnp.abs(A.gradient_noise(lattice)) < 1e-12)
    grid2 = jnp.stack(jnp.meshgrid(jnp.arange(3.0), jnp.arange(3.0)), -1).reshape(-1, 2)
    assert jnp.all(jnp.abs(A.gradient_noise(grid2, key=jax.random.key(3))) < 1e-12)
    x = jnp.linspace(-4, 4, 4001)[:, None]
    one, two = jax.random.key(1), jax.random.key(2)
    for fn in (A.value_noise, A.gradient_noise):
        noise = jax.jit(lambda x, key, fn=fn: fn(x, key=key))  # the key is traced
        y = noise(x, one)
        assert jnp.all(jnp.abs(y) <= 1.0) and y.std() > 0.05
        # smooth: differences shrink with the step (Lipschitz with a modest constant)
        assert jnp.max(jnp.abs(jnp.diff(y))) < 0.01
        assert not jnp.allclose(y, noise(x, two))
        grad = jax.grad(lambda s, key, fn=fn: fn(s[None], key=key))
        g = jax.jit(jax.vmap(grad, in_axes=(0, None)))(x[:, 0], one)
        assert jnp.all(jnp.isfinite(g))
    # value noise at lattice points is the lattice value, and between neighbours it stays
    # in their range (the fade blend is monotone)
    v = A.value_noise(jnp.array([[1.0], [1.5], [2.0]]))
    assert min(v[0], v[2]) <= v[1] <= max(v[0], v[2])
    f = A.fractal_noise(jnp.linspace(0, 5, 300)[:, None] + 0.37, octaves=5)
    assert f.shape == (300,) and jnp.all(jnp.abs(f) <= 1.0)


def test_procedural_bad_inputs():
    with pytest.raises(ValueError, match="dt"):
        A.simulate_particles(
            A.Particles(jnp.zeros((1, 2)), jnp.zeros((1, 2)), jnp.zeros(1)), steps=3, dt=-0.1
        )
    with pytest.raises(TypeError, match="steps"):
        A.simulate_particles(
            A.Particles(jnp.zeros((1, 2)), jnp.zeros((1, 2)), jnp.zeros(1)), steps=2.5, dt=0.1
        )
    with pytest.raises(ValueError, match="integrator"):
        A.simulate_springs(
            jnp.zeros((2, 2)),
            jnp.zeros((2, 2)),
            A.chain_springs(2),
            steps=2,
            dt=0.1,
            integrator="rk4",
        )
    with pytest.raises(ValueError, match="springs"):
        A.simulate_springs(
            jnp.zeros((2, 2)), jnp.zeros((2, 2)), jnp.array([[0, 5]]), steps=2, dt=0.1
        )
    with pytest.raises(ValueError, match="x"):
        A.value_noise(jnp.zeros((4, 3)))
    with pytest.raises(ValueError, match="kind"):
        A.fractal_noise(jnp.zeros((4, 1)), kind="pink")
    with pytest.raises(ValueError, match="target"):
        A.damped_spring(0.0, 0.0, 1.0, stiffness=1.0, damping=0.1, dt=0.1)
