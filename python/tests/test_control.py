"""The task stack from numpy, against the analytic answers."""

import numpy as np
import pytest

import skin


def test_one_task_exact_is_the_pseudo_inverse():
    rng = np.random.default_rng(1)
    j = rng.normal(size=(3, 7))
    r = rng.normal(size=3)
    q = skin.TaskStack(7, regularisation="exact").solve([(j, r, 1.0)])
    np.testing.assert_allclose(q, np.linalg.pinv(j) @ r, atol=1e-10)
    np.testing.assert_allclose(j @ q, r, atol=1e-10)


def test_a_lower_task_works_in_the_null_space_of_a_higher_one():
    rng = np.random.default_rng(2)
    j1, r1 = rng.normal(size=(2, 6)), rng.normal(size=2)
    j2, r2 = rng.normal(size=(3, 6)), rng.normal(size=3)
    q = skin.TaskStack(6, regularisation="exact").solve([(j1, r1, 1.0), (j2, r2, 1.0)])
    np.testing.assert_allclose(j1 @ q, r1, atol=1e-9)
    # The exact prioritised solution (Siciliano and Slotine).
    p1 = np.linalg.pinv(j1)
    n1 = np.eye(6) - p1 @ j1
    expected = p1 @ r1 + np.linalg.pinv(j2 @ n1) @ (r2 - j2 @ p1 @ r1)
    np.testing.assert_allclose(q, expected, atol=1e-8)


def test_an_inactive_task_does_nothing():
    j = np.eye(3)
    stack = skin.TaskStack(3)
    np.testing.assert_allclose(stack.solve([(j, np.ones(3), 0.0)]), 0.0, atol=1e-12)
    damped = stack.solve([(j, np.ones(3), 1.0)])
    assert np.all(damped > 0.9) and np.all(damped <= 1.0)


def test_bad_tasks_are_named():
    stack = skin.TaskStack(4)
    with pytest.raises(skin.ArrayError, match=r"tasks\[0\] jacobian: shape \(2, 3\)"):
        stack.solve([(np.zeros((2, 3)), np.zeros(2), 1.0)])
    with pytest.raises(skin.ArrayError, match=r"tasks\[1\] reference"):
        stack.solve([(np.zeros((2, 4)), np.zeros(2), 1.0), (np.zeros((2, 4)), np.zeros(3), 1.0)])
    with pytest.raises(skin.ArrayError, match="activation"):
        stack.solve([(np.zeros((2, 4)), np.zeros(2), 1.5)])
    with pytest.raises(skin.ControlError, match="empty"):
        stack.solve([])
    with pytest.raises(skin.ArrayError, match="regularisation"):
        skin.TaskStack(4, regularisation="magic")
