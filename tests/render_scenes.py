"""Small scenes shared by the renderer tests."""

import jax.numpy as jnp


def tiny_scene():
    """Two overlapping triangles with per-vertex colors: `(vertices, faces, colors)`."""
    vertices = jnp.array(
        [
            [-0.5, -0.4, 0.0],
            [0.6, -0.3, 0.1],
            [0.0, 0.6, -0.1],
            [-0.2, -0.1, 0.3],
            [0.5, 0.3, 0.4],
            [-0.3, 0.5, 0.2],
        ]
    )
    faces = jnp.array([[0, 1, 2], [3, 4, 5]])
    colors = jnp.array(
        [
            [1.0, 0.2, 0.1],
            [0.9, 0.8, 0.1],
            [0.1, 0.9, 0.5],
            [0.2, 0.3, 1.0],
            [0.5, 0.1, 0.9],
            [0.3, 0.7, 0.2],
        ]
    )
    return vertices, faces, colors
