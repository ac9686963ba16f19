"""fabhal.optimize against known optima and against scipy.optimize (the reference
the solver used before; scipy stays installed, through trimesh and for these tests).

Tolerances: the problems are well conditioned, so optima agree to 1e-6 in x
(the methods stop on relative decreases of 1e-12 or gradients of 1e-10)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import lsq_linear

from fabhal.optimize import (
    LAPACK_UNKNOWNS,
    Linear,
    constrained_step,
    least_squares_objective,
    minimize,
    tangent_curvature,
)

FREE = (np.full(2, -np.inf), np.full(2, np.inf))


def rosenbrock_residual(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]]), np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])


def rosenbrock(x: np.ndarray) -> tuple[float, np.ndarray, None]:
    r, jacobian = rosenbrock_residual(x)
    return 0.5 * float(r @ r), jacobian.T @ r, None


def x_plus_y(x: np.ndarray) -> tuple[float, np.ndarray, None]:
    return float(x.sum()), np.ones(2), None


def on_circle(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x^2 + y^2 = 2, and the same equation again: dependent rows must not matter."""
    return np.array([x @ x - 2.0, x @ x - 2.0]), np.vstack([2 * x, 2 * x])


def test_gauss_newton_finds_the_rosenbrock_valley_floor() -> None:
    result = minimize(least_squares_objective(rosenbrock_residual), np.array([-1.2, 1.0]), *FREE, ftol=1e-14)
    assert result.converged
    assert np.allclose(result.x, [1.0, 1.0], atol=1e-8)


def test_a_bound_stops_the_fit_where_scipy_does() -> None:
    low, high = np.array([-2.0, -2.0]), np.array([0.5, 2.0])
    result = minimize(
        least_squares_objective(rosenbrock_residual), np.array([-1.2, 1.0]), low, high, ftol=1e-14
    )
    # on x0 = 0.5 the best x1 is 0.25 (residual 10 (x1 - x0^2) = 0)
    assert np.allclose(result.x, [0.5, 0.25], atol=1e-8)


def test_bfgs_minimises_a_function_without_a_hessian() -> None:
    result = minimize(rosenbrock, np.array([-1.2, 1.0]), *FREE, gtol=1e-10, max_iterations=500)
    assert result.converged and result.stationarity <= 1e-8  # or a step under xtol ends it first
    assert np.allclose(result.x, [1.0, 1.0], atol=1e-6)


def test_every_iterate_stays_on_the_equality_constraints() -> None:
    visited: list[np.ndarray] = []

    def recorded(x: np.ndarray) -> tuple[float, np.ndarray, None]:
        visited.append(x.copy())
        return x_plus_y(x)

    result = minimize(recorded, np.array([np.sqrt(2.0), 0.0]), *FREE, equality=on_circle, gtol=1e-10)
    assert np.allclose(result.x, [-1.0, -1.0], atol=1e-8)
    assert all(abs(float(x @ x) - 2.0) < 1e-9 for x in visited)


def test_a_bound_on_the_circle() -> None:
    low, high = np.array([-0.5, -5.0]), np.full(2, np.inf)
    result = minimize(x_plus_y, np.array([np.sqrt(2.0), 0.0]), low, high, equality=on_circle, gtol=1e-10)
    assert np.allclose(result.x, [-0.5, -np.sqrt(1.75)], atol=1e-8)


def test_a_linear_inequality_on_the_circle() -> None:
    # x - y >= 0.5 cuts off (-1, -1); the optimum is where the line meets the circle
    spacing = Linear(np.array([[1.0, -1.0]]), np.array([-0.5]))
    result = minimize(
        x_plus_y, np.array([np.sqrt(2.0), 0.0]), *FREE, equality=on_circle, linear=spacing, gtol=1e-10
    )
    y = (-1.0 - np.sqrt(15.0)) / 4.0
    assert np.allclose(result.x, [y + 0.5, y], atol=1e-8)


def test_a_start_far_from_the_constraints_is_brought_onto_them() -> None:
    result = minimize(x_plus_y, np.array([5.0, 3.0]), *FREE, equality=on_circle, gtol=1e-10)
    assert result.feasible
    assert np.allclose(result.x, [-1.0, -1.0], atol=1e-8)


def test_scaling_does_not_change_the_optimum() -> None:
    low, high = np.array([-2.0, -2.0]), np.array([0.5, 2.0])
    result = minimize(
        least_squares_objective(rosenbrock_residual),
        np.array([-1.2, 1.0]),
        low,
        high,
        scale=np.array([300.0, 0.01]),
        ftol=1e-14,
    )
    assert np.allclose(result.x, [0.5, 0.25], atol=1e-7)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_bounded_linear_least_squares_agree_with_scipy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 8))
    a = rng.normal(size=(n + 3, n))
    b = rng.normal(size=n + 3) * 3.0
    low, high = -rng.uniform(0.1, 1.0, n), rng.uniform(0.1, 1.0, n)
    result = minimize(
        least_squares_objective(lambda x: (a @ x - b, a)),
        np.zeros(n),
        low,
        high,
        ftol=1e-15,
        max_iterations=500,
    )
    reference = lsq_linear(a, b, bounds=(low, high), tol=1e-14).x
    cost = float(np.sum((a @ result.x - b) ** 2))
    assert cost <= float(np.sum((a @ reference - b) ** 2)) + 1e-9
    assert np.allclose(result.x, reference, atol=1e-6)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_constrained_step_solves_the_kkt_system(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(3, 9)), int(rng.integers(1, 3))
    basis = rng.normal(size=(n, n))
    hessian = basis @ basis.T + np.eye(n)
    gradient = rng.normal(size=n)
    independent = rng.normal(size=(m, n))
    rows = np.vstack([independent, independent[:1] * 2.0])  # a repeated equation
    rhs = rows @ rng.normal(size=n)  # consistent
    solved = constrained_step(hessian, gradient, rows, rhs)
    assert solved is not None
    step, multipliers, _ = solved
    assert np.allclose(rows @ step, rhs, atol=1e-9)
    assert np.allclose(gradient + hessian @ step, rows.T @ multipliers, atol=1e-8)


def test_constrained_step_refuses_a_model_that_is_not_convex() -> None:
    assert constrained_step(-np.eye(3), np.ones(3), np.zeros((0, 3)), np.zeros(0)) is None


@pytest.mark.parametrize("n", [20, LAPACK_UNKNOWNS + 50])
def test_large_and_small_systems_solve_alike(n: int) -> None:
    """Below LAPACK_UNKNOWNS numpy solves the model's system, from it LAPACK's
    Cholesky solve: both give H d = -g to 1e-9 relative (a condition number of
    ~1e3 here, times rounding 1e-16), and both refuse an indefinite model."""
    rng = np.random.default_rng(n)
    basis = rng.normal(size=(n, n))
    hessian = basis @ basis.T + n * np.eye(n)
    gradient = rng.normal(size=n)
    solved = constrained_step(hessian, gradient, np.zeros((0, n)), np.zeros(0))
    assert solved is not None
    np.testing.assert_allclose(hessian @ solved[0], -gradient, atol=1e-9 * np.abs(gradient).max())
    saddle = hessian.copy()
    saddle[n // 2, n // 2] = -1e6
    assert constrained_step(saddle, gradient, np.zeros((0, n)), np.zeros(0)) is None


@pytest.mark.parametrize("stop", [1e-3, 1e-6])
def test_stop_below_ends_the_search_early(stop: float) -> None:
    result = minimize(
        least_squares_objective(rosenbrock_residual), np.array([-1.2, 1.0]), *FREE, stop_below=stop
    )
    assert result.converged and result.value <= stop


def test_no_step_is_longer_than_the_trust_radius() -> None:
    visited: list[np.ndarray] = []

    def recorded(x: np.ndarray) -> tuple[float, np.ndarray, None]:
        visited.append(x.copy())
        return rosenbrock(x)

    result = minimize(recorded, np.array([-1.2, 1.0]), *FREE, gtol=1e-8, max_iterations=2000, max_step=0.1)
    assert np.allclose(result.x, [1.0, 1.0], atol=1e-5)
    # every point tried is within 0.1 (per variable) of a point tried before it
    for k in range(1, len(visited)):
        nearest = min(float(np.abs(visited[k] - earlier).max()) for earlier in visited[:k])
        assert nearest <= 0.1 + 1e-12


def test_a_known_hessian_starts_bfgs_at_newton() -> None:
    """On a quadratic, BFGS started from the exact Hessian takes the Newton step."""
    matrix = np.array([[4.0, 1.0], [1.0, 3.0]])
    target = np.array([0.5, -2.0])

    def quadratic(x: np.ndarray) -> tuple[float, np.ndarray, None]:
        d = x - target
        return 0.5 * float(d @ matrix @ d), matrix @ d, None

    result = minimize(quadratic, np.zeros(2), *FREE, gtol=1e-12, curvature=matrix)
    assert result.iterations <= 2 and np.allclose(result.x, target, atol=1e-10)


def test_a_closed_form_hessian_replaces_the_measurement() -> None:
    """Given the Lagrangian's Hessian in closed form, BFGS starts from it (the
    Newton step on a quadratic) and the curvature is read from it: one
    evaluation each, not one more per variable; with an equality constraint
    it is given the constraint's multipliers."""
    matrix = np.array([[4.0, 1.0], [1.0, 3.0]])
    target = np.array([0.5, -2.0])
    calls = []

    def quadratic(x: np.ndarray) -> tuple[float, np.ndarray, None]:
        calls.append(x)
        d = x - target
        return 0.5 * float(d @ matrix @ d), matrix @ d, None

    result = minimize(
        quadratic, np.zeros(2), *FREE, gtol=1e-12, measure_curvature=True, exact_hessian=lambda x, m: matrix
    )
    assert result.iterations <= 2 and np.allclose(result.x, target, atol=1e-10)
    calls.clear()
    values, _ = tangent_curvature(quadratic, np.zeros(2), *FREE, exact_hessian=lambda x, m: matrix)
    assert len(calls) == 1
    assert values == pytest.approx(np.linalg.eigvalsh(matrix), abs=1e-12)
    # height on the unit circle, at the top: f = y, c = x.x - 1, grad f = lambda grad c gives
    # lambda = 1/2, and the Lagrangian's Hessian 0 - lambda 2 I = -I: -1 along the circle
    calls.clear()
    circle, _ = tangent_curvature(
        lambda x: (calls.append(x), height(x))[1],
        np.array([0.0, 1.0]),
        *FREE,
        equality=unit_circle,
        exact_hessian=lambda x, multipliers: -2.0 * multipliers[0] * np.eye(2),
    )
    assert circle == pytest.approx([-1.0], abs=1e-12) and len(calls) == 1


def test_stalled_ends_the_search() -> None:
    result = minimize(
        least_squares_objective(rosenbrock_residual),
        np.array([-1.2, 1.0]),
        *FREE,
        stalled=lambda costs: len(costs) > 3,
    )
    assert not result.converged and result.iterations == 3


def height(x: np.ndarray) -> tuple[float, np.ndarray, None]:
    return float(x[1]), np.array([0.0, 1.0]), None


def unit_circle(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.array([x @ x - 1.0]), 2 * x[None, :]


@pytest.mark.parametrize(("point", "curvature"), [((0.0, 1.0), -1.0), ((0.0, -1.0), 1.0)])
def test_curvature_along_the_constraints_tells_a_balance_on_top_from_one_below(
    point: tuple[float, float], curvature: float
) -> None:
    """Height on the unit circle: at the top the Lagrangian's Hessian along the
    circle is -1 (unstable; the way down is sideways), at the bottom +1.
    1e-4: forward differences with a 0.01 step."""
    values, directions = tangent_curvature(height, np.array(point), *FREE, equality=unit_circle)
    assert values == pytest.approx([curvature], abs=1e-4)
    assert abs(directions[0, 0]) == pytest.approx(1.0) and abs(directions[1, 0]) < 1e-6


def test_a_bound_with_no_force_on_it_does_not_hide_the_way_down() -> None:
    """On top of the circle with x >= 0 exactly at its bound: nothing presses x
    against it, so moving inwards (x > 0) is still a way down."""
    low = np.array([0.0, -np.inf])
    values, _ = tangent_curvature(height, np.array([0.0, 1.0]), low, FREE[1], equality=unit_circle)
    assert values[0] == pytest.approx(-1.0, abs=1e-4)


# ---------------------------------------------------------------- failures are failures (issue 19)


def test_a_nan_constraint_is_a_failure_not_a_result() -> None:
    def broken(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.array([np.nan]), np.array([[np.nan, np.nan]])

    result = minimize(x_plus_y, np.array([1.0, 1.0]), np.full(2, -5.0), np.full(2, 5.0), equality=broken)
    assert not result.converged and not result.feasible


def test_an_unsatisfiable_constraint_is_a_failure_not_a_bound_corner() -> None:
    """x^2 + y^2 = -1 has no solution: the closest the search gets (the origin) is
    not a result."""

    def impossible(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.array([x @ x + 1.0]), np.array([2 * x])

    result = minimize(x_plus_y, np.array([1.0, 1.0]), np.full(2, -5.0), np.full(2, 5.0), equality=impossible)
    assert not result.converged and not result.feasible


def test_a_nan_objective_is_a_failure() -> None:
    def nan_objective(x: np.ndarray) -> tuple[float, np.ndarray, None]:
        return float("nan"), np.full(2, np.nan), None

    result = minimize(nan_objective, np.array([1.0, 1.0]), *FREE)
    assert not result.converged


def test_a_nan_met_on_the_way_is_stepped_back_from() -> None:
    """f = x^2 + y^2 where x <= 3, undefined (NaN) beyond: from (2, 2) the first full
    step of BFGS may land beyond 3; the search must still end at the origin."""

    def partial(x: np.ndarray) -> tuple[float, np.ndarray, None]:
        if x[0] > 3.0:
            return float("nan"), np.full(2, np.nan), None
        return float(x @ x), 2 * x, None

    result = minimize(partial, np.array([2.0, 2.0]), *FREE, gtol=1e-10)
    assert result.converged and np.allclose(result.x, 0.0, atol=1e-6)


def test_a_large_residual_valley_is_not_left_early() -> None:
    """Least squares with a residual that cannot vanish (r = (10 (y - x^2), 1 - x, 5)):
    the minimum is Rosenbrock's (1, 1) with |r|^2 / 2 = 12.5. A search that damped
    itself after every shortened step stopped short of it and called that
    converged; a converged result must have a vanishing projected gradient."""

    def residual(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r, jacobian = rosenbrock_residual(x)
        return np.append(r, 5.0), np.vstack([jacobian, np.zeros(2)])

    result = minimize(least_squares_objective(residual), np.array([-1.2, 1.0]), *FREE, ftol=1e-12, xtol=1e-12)
    assert result.converged
    assert result.stationarity <= 1e-6 * 5.0  # STATIONARY x |r|
    assert np.allclose(result.x, [1.0, 1.0], atol=1e-5)
