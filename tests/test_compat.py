"""The private names fuzzynav takes from pymunk and numpy are there, and do what the
public API does (issue 36 item 5): an upgrade that moves one fails here, loudly,
instead of silently slowing down or changing a run."""

from __future__ import annotations

import numpy as np
import pymunk
import pytest

from fuzzynav.world import compat_numpy, compat_pymunk


def test_the_installed_pymunk_has_every_private_name_the_fast_path_uses():
    if compat_pymunk.installed_major() != compat_pymunk.SUPPORTED_MAJOR:
        pytest.fail(
            f"pymunk {pymunk.version}: world/compat_pymunk.py was written for "
            f"{compat_pymunk.SUPPORTED_MAJOR}.x; check its private names and update it"
        )
    assert compat_pymunk.FAST, "pymunk._chipmunk's cffi binding did not import"
    space = pymunk.Space()
    body = pymunk.Body(1.0, 1.0)
    missing = [name for name in compat_pymunk.SPACE_STEP_STATE if not hasattr(space, name)]
    assert not missing, f"pymunk {pymunk.version}: Space lacks {missing}"
    assert compat_pymunk.space_pointer(space) is not None
    assert compat_pymunk.body_pointer(body) is not None
    assert compat_pymunk.shape_count(space) == 0
    assert compat_pymunk.can_step_fast(space)


def _falling_ball(step):
    space = pymunk.Space()
    space.gravity = (0.0, -9.81)
    ball = pymunk.Body(1.0, 1.0)
    ball.position = (0.0, 1.0)
    ground = pymunk.Segment(space.static_body, (-5, 0), (5, 0), 0.01)
    shape = pymunk.Circle(ball, 0.2)
    touched = []
    space.add(ball, shape, ground)
    space.on_collision(begin=lambda arbiter, space, data: touched.append(len(touched)))
    for _ in range(200):
        step(space, 0.01)
    return tuple(ball.position), tuple(ball.velocity), len(touched)


def test_the_fast_space_step_is_space_step():
    public = _falling_ball(lambda space, dt: space.step(dt))
    fast = _falling_ball(
        lambda space, dt: compat_pymunk.step_space(space, compat_pymunk.space_pointer(space), dt)
    )
    assert fast == public
    assert public[2] >= 1  # the contact callback ran under both


def test_numpys_c_einsum_is_there_and_gives_np_einsums_bits():
    if np.__version__.split(".")[0] != compat_numpy.SUPPORTED_MAJOR:
        pytest.fail(
            f"numpy {np.__version__}: world/compat_numpy.py was written for "
            f"{compat_numpy.SUPPORTED_MAJOR}.x; check c_einsum and update it"
        )
    assert compat_numpy.FAST, "numpy._core._multiarray_umath.c_einsum is gone"
    rng = np.random.default_rng(3)
    z, m = rng.normal(size=(7, 8)), rng.normal(size=(12, 8))
    assert np.array_equal(compat_numpy.einsum("ij,kj->ik", z, m), np.einsum("ij,kj->ik", z, m))
