"""Small dense optimisation in numpy (and LAPACK's Cholesky solve, from
scipy.linalg, for systems of LAPACK_UNKNOWNS and more): the one method behind
every solver step.

    minimise f(u)  subject to  c(u) = 0,  G u + h >= 0,  low <= u <= high

with c the loop-closure equations (nonlinear), G u + h >= 0 the spacing of
parts sharing a rod (linear) and the DoFs' ranges as bounds. The problems are
small (up to a few dozen DoFs), dense, and come with exact Jacobians, so one
feasible-point active-set method covers all of them:

- every iterate satisfies c(u) = 0: after each step a Newton projection
  (`restore`) brings the point back onto the loops, so the result is closed
  even when the iteration limit or the time limit stops it early
  (generalised reduced gradient);
- a bound or a spacing inequality joins the active set when a step reaches
  it, and leaves when its multiplier says the optimum lies inside;
- the step minimises a quadratic model on the tangent space of the active
  constraints: Gauss-Newton with Levenberg-Marquardt damping and NL2SOL's
  secant correction for least squares (`least_squares_objective`), damped
  BFGS (optionally from a measured Hessian) for other objectives; steps are
  backtracked along their projection onto the bounds, within a trust radius.

`tangent_curvature` measures the curvature along the active constraints at a
point: the solver's test for an unstable balance.

Why not scipy.optimize: importing it costs 0.4-0.8 s of every process, more
than a whole solve is allowed (bench/README.md); and SLSQP, which handled the
loops before, needed hundreds of iterations in the flat valleys of long loops
where this tangent-space Newton method needs tens.

Everything works in scaled variables u = x * scale (the solver passes
millimetres of motion per unit of each DoF), so a slide along a 500 mm rod and
the turn of a hook weigh alike in steps, tolerances and damping.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

Array = np.ndarray
# value, gradient, and the Hessian when the objective has a model of it (None: BFGS builds one)
Objective = Callable[[Array], tuple[float, Array, Array | None]]
Equality = Callable[[Array], tuple[Array, Array]]  # c(x), dc/dx

ARMIJO = 1e-4  # sufficient decrease, as a fraction of the model's first-order decrease
RESTORE_ITERATIONS = 12
RESTORED = 1e-10  # largest |c| accepted as on the constraints (the caller's units: mm)
# a scaled variable this close to a bound, or a spacing this close to 0, is on it: a
# nanometre (scaled variables are millimetres); closer, a step would stall on it
ACTIVE = 1e-6
MODEL_REPAIRS = 40  # Newton: damping 1e-6 x 10^40 is far past any curvature
RANK = 1e-9  # singular values below this fraction of the largest span no direction
# from this many unknowns a positive definite system is solved by LAPACK's Cholesky
# solve through scipy.linalg, whose import (0.3 s) then pays for itself: numpy's
# Cholesky test and LU solve take 0.47 ms at 200 unknowns against 0.17 ms, 4.4 ms
# at 400 against 0.95 ms (one BLAS thread); the gallery (up to 65 DoFs) never imports it
LAPACK_UNKNOWNS = 200
# A step or decrease test ends a least-squares search only while the model is
# trusted this much (Levenberg-Marquardt damping at most this multiple of the
# Gauss-Newton diagonal): a heavily damped step is short because of the damping,
# not because the bottom is near, and stopping there was a false convergence.
TRUSTED_DAMPING = 1.0
# a stop counts as converged when the projected gradient is at most this, times
# max(1, |r|) for least squares (f = |r|^2 / 2, so the gradient J^T r scales with |r|)
STATIONARY = 1e-6


# the Hessian of f - multipliers . c at x (unscaled), given the equality constraints'
# multipliers; None at an x where it has no closed form (it is measured there)
LagrangianHessian = Callable[[Array, Array], Array | None]


@dataclass(frozen=True)
class Linear:
    """Linear inequalities G x + h >= 0."""

    matrix: Array  # (m, n)
    offset: Array  # (m,)


@dataclass(frozen=True)
class Result:
    x: Array
    value: float
    stationarity: float  # largest projected gradient component at x (objective units per scaled unit)
    iterations: int
    evaluations: int
    converged: bool
    feasible: bool  # on the equality constraints (always true without them)
    curvature: Array | None  # the final BFGS matrix (scaled variables); None for least squares


def least_squares_objective(residual_and_jacobian: Callable[[Array], tuple[Array, Array]]) -> Objective:
    """f = |r|^2 / 2 with the Gauss-Newton Hessian J^T J."""

    def objective(x: Array) -> tuple[float, Array, Array | None]:
        r, jacobian = residual_and_jacobian(x)
        return 0.5 * float(r @ r), jacobian.T @ r, jacobian.T @ jacobian

    return objective


@dataclass
class _Scaled:
    """The problem in scaled variables u = x * scale."""

    objective: Objective
    equality: Equality | None
    linear: Linear | None
    scale: Array
    low: Array
    high: Array
    # the Lagrangian's Hessian in closed form (unscaled variables; given the equality
    # constraints' multipliers), if the objective and the constraints have one
    hessian: LagrangianHessian | None = None
    evaluations: int = 0

    @classmethod
    def of(
        cls,
        objective: Objective,
        low: Array,
        high: Array,
        equality: Equality | None,
        linear: Linear | None,
        scale: Array | None,
        hessian: LagrangianHessian | None = None,
    ) -> _Scaled:
        """The problem in scaled variables (scale None: unscaled)."""
        factors = np.ones(len(low)) if scale is None else np.asarray(scale, dtype=float)
        return cls(objective, equality, linear, factors, low * factors, high * factors, hessian)

    def evaluate(self, u: Array) -> tuple[float, Array, Array | None]:
        self.evaluations += 1
        value, gradient, hessian = self.objective(u / self.scale)
        gradient = gradient / self.scale
        if hessian is not None:
            hessian = hessian / np.outer(self.scale, self.scale)
        return value, gradient, hessian

    def constraints(self, u: Array) -> tuple[Array, Array]:
        if self.equality is None:
            return np.zeros(0), np.zeros((0, len(u)))
        c, jacobian = self.equality(u / self.scale)
        return c, jacobian / self.scale

    def linear_rows(self) -> tuple[Array, Array]:
        return self._linear_rows

    @cached_property
    def _linear_rows(self) -> tuple[Array, Array]:
        # scaled once: asked for at every step, trial and projection
        if self.linear is None:
            return np.zeros((0, len(self.scale))), np.zeros(0)
        return self.linear.matrix / self.scale, self.linear.offset

    def on_bounds(self, u: Array) -> tuple[Array, Array]:
        return u <= self.low + ACTIVE, u >= self.high - ACTIVE


def minimize(
    objective: Objective,
    start: Array,
    low: Array,
    high: Array,
    *,
    equality: Equality | None = None,
    linear: Linear | None = None,
    scale: Array | None = None,
    max_iterations: int = 200,
    max_evaluations: int | None = None,
    ftol: float = 0.0,
    gtol: float = 0.0,
    xtol: float = 1e-10,
    stop_below: float = -np.inf,
    deadline: float = np.inf,
    measure_curvature: bool = False,
    curvature: Array | None = None,
    stalled: Callable[[list[float]], bool] | None = None,
    max_step: float = np.inf,
    exact_hessian: LagrangianHessian | None = None,
) -> Result:
    """Minimise from `start` (clipped to the bounds, projected onto c = 0).

    Stops when the projected gradient is at most `gtol`, when an accepted step
    lowers f by at most `ftol` * |f| or moves no scaled variable more than
    `xtol`, when f <= `stop_below`, or at the limits. Bounds may be infinite.
    With `measure_curvature`, BFGS starts from the Hessian of the Lagrangian
    (`exact_hessian` in closed form, given x and the equality constraints'
    multipliers; else by finite differences, one gradient per variable)
    instead of a multiple of the identity: worth it where the
    curvature differs a lot between variables (a stiff friction term beside a
    slow swing) and iterations are dear; or
    from `curvature`, a previous result's matrix, when starting near where that
    one ended (it is measured again only if the line search fails).
    No step moves a scaled variable more than `max_step` (a trust radius: a
    nearly singular model proposes steps that take many halvings to shorten).
    `stalled` sees f after every accepted step and may end the search when
    the progress is no longer worth its cost (the caller's units and taste)."""
    problem = _Scaled.of(objective, low, high, equality, linear, scale, exact_hessian)
    u = np.clip(np.asarray(start, dtype=float) * problem.scale, problem.low, problem.high)
    if not np.all(np.isfinite(u)):
        return _failure(problem, u, np.nan, 0)
    u, c, a, feasible = restore(problem, u, np.zeros(len(u), dtype=bool))
    if not feasible:
        u, c, a, feasible = _close(problem, u)
        if not (np.all(np.isfinite(c)) and np.all(np.isfinite(a))):
            return _failure(problem, u, np.nan, 0)
    value, gradient, hessian = problem.evaluate(u)
    if not _finite(value, gradient, hessian):
        return _failure(problem, u, value, 0)
    state = _Iteration(problem, hessian is None)
    state.max_step = max_step
    if hessian is None:
        if measure_curvature:
            state.measure = lambda at, g, a_at: _lagrangian_hessian(problem, at, g, a_at, deadline=deadline)
        if curvature is not None:
            state.start_from(curvature)
        elif state.measure is not None:
            state.start_from(state.measure(u, gradient, a))  # None past the deadline: BFGS from 1
    stationarity, iterations = np.inf, 0
    history = [value]
    stationary = max(gtol, STATIONARY * (1.0 if state.bfgs else max(1.0, float(np.sqrt(2.0 * value)))))
    while iterations < max_iterations:
        iterations += 1
        step, stationarity = state.step(u, gradient, hessian, a, c)
        if not np.isfinite(stationarity):
            break
        tiny = float(np.abs(step).max(initial=0.0)) <= xtol and state.trusted()
        if stationarity <= gtol or value <= stop_below or tiny:
            break
        if (max_evaluations is not None and problem.evaluations >= max_evaluations) or (
            time.monotonic() > deadline
        ):
            break
        accepted = state.line_search(u, value, gradient, step)
        if accepted is None:
            if state.reset(u, gradient, a):  # the model was stale: try again with a fresh one
                continue
            break  # nothing lower along the step of a fresh model: converged only if stationary
        u_new, c, a_new, value_new, gradient_new, hessian, whole = accepted
        state.learn(u_new - u, gradient_new - gradient, a_new - a, hessian)
        lowered = value - value_new
        u, a, value, gradient, feasible = u_new, a_new, value_new, gradient_new, True
        history.append(value)
        # a step cut short by a bound or a spacing, or shortened by heavy damping,
        # says nothing about convergence
        if whole and lowered <= ftol * abs(value) and state.trusted():
            break
        if stalled is not None and stalled(history):
            break
    converged = feasible and (stationarity <= stationary or value <= stop_below)
    return Result(
        u / problem.scale,
        value,
        float(stationarity),
        iterations,
        problem.evaluations,
        converged,
        feasible,
        state.model if state.bfgs else None,
    )


def _finite(value: float, gradient: Array, hessian: Array | None) -> bool:
    return bool(
        np.isfinite(value) and np.isfinite(gradient).all() and (hessian is None or np.isfinite(hessian).all())
    )


def _failure(problem: _Scaled, u: Array, value: float, iterations: int) -> Result:
    """Where the objective or the constraints are not numbers: no result to trust."""
    return Result(
        u / problem.scale, float(value), np.inf, iterations, problem.evaluations, False, False, None
    )


class _Iteration:
    """The active set, the quadratic model and its damping between iterations.

    Least squares: the Gauss-Newton Hessian J^T J plus a secant correction S for
    what it leaves out (the residual's and the loops' curvature; Dennis, Gay &
    Welsch's NL2SOL update), damped Levenberg-Marquardt style. A target the
    chain cannot reach leaves a large residual, where plain Gauss-Newton crawls.
    Other objectives: damped BFGS (Powell) of the Lagrangian's Hessian."""

    def __init__(self, problem: _Scaled, bfgs: bool) -> None:
        self.problem = problem
        self.bfgs = bfgs
        n = len(problem.scale)
        self.model: Array | None = None  # BFGS matrix, or NL2SOL's correction S
        self.fresh = True  # the model has seen no curvature yet
        self.damping = 1e-3  # Levenberg-Marquardt, relative to the Gauss-Newton diagonal
        self.multipliers = np.zeros(0)  # of the equality constraints, for the secant updates
        self.fixed = np.zeros(n, dtype=bool)
        self.hessian = np.zeros((n, n))  # of the quadratic model of the last step
        self.max_step = np.inf  # longest move of a scaled variable in one step
        # least squares: how far the last steps showed the model to hold (twice the step
        # taken where one had to be shortened, doubled after a step it predicted well);
        # this, not more damping, keeps the next step from needing the same halvings
        self.radius = np.inf
        self.gauss_newton = np.zeros((n, n))  # J^T J at the last point (least squares)
        self.corrected = False  # least squares: whether the model includes S (NL2SOL's choice)
        # measures the Hessian of the Lagrangian at (u, gradient, dc/du), if BFGS should start from it
        self.measure: Callable[[Array, Array, Array], Array | None] | None = None

    def step(
        self, u: Array, gradient: Array, hessian: Array | None, a: Array, c: Array
    ) -> tuple[Array, float]:
        """The step of the quadratic model on the active set; the projected gradient.
        A model not convex on the tangent space is damped more (Newton) or, for
        BFGS (where rounding can leave a quasi-Newton update slightly
        indefinite), mirrored and floored, then started again; a model that no
        repair makes convex gives no step (stationarity inf: the search ends)."""
        for repair in range(MODEL_REPAIRS):
            self.hessian = self._model_hessian(gradient, hessian)
            found = self._active_step(u, gradient, a, c)
            if found is not None:
                return found
            if not self.bfgs:
                self.damping = max(self.damping, 1e-6) * 10.0
            elif repair == 0:
                self.start_from(self.model)
            else:
                self.model = None
        return np.zeros(len(u)), np.inf

    def _active_step(self, u: Array, gradient: Array, a: Array, c: Array) -> tuple[Array, float] | None:
        problem = self.problem
        at_low, at_high = problem.on_bounds(u)
        g_rows, h = problem.linear_rows()
        on_linear = g_rows @ u + h <= ACTIVE
        fixed = at_low | at_high
        threshold = 1e-12 + 1e-9 * float(np.abs(gradient).max(initial=0.0))
        while True:
            free = ~fixed
            active_rows = np.vstack([a, g_rows[on_linear]]) if on_linear.any() else a
            rhs = np.concatenate([-c, -(g_rows[on_linear] @ u + h[on_linear])]) if on_linear.any() else -c
            if free.all():  # no bound active: no copies of the model
                solved = constrained_step(self.hessian, gradient, active_rows, rhs)
            else:
                solved = constrained_step(
                    self.hessian[np.ix_(free, free)], gradient[free], active_rows[:, free], rhs
                )
            if solved is None:
                return None
            d_free, lam, projected = solved
            step = np.zeros(len(u))
            step[free] = d_free
            # multipliers of the active inequalities; a negative one is a constraint to leave
            push = gradient + self.hessian @ step - active_rows.T @ lam
            release = np.zeros(len(u))
            release[at_low & fixed] = -push[at_low & fixed]
            release[at_high & fixed] = push[at_high & fixed]
            linear_release = -lam[len(c) :]
            if len(linear_release) and linear_release.max() > max(release.max(initial=0.0), threshold):
                on_linear[np.flatnonzero(on_linear)[int(np.argmax(linear_release))]] = False
                continue
            if release.max(initial=0.0) > threshold:
                fixed[int(np.argmax(release))] = False
                continue
            self.fixed = fixed
            self.multipliers = lam[: len(c)]
            return step, projected

    def start_from(self, hessian: Array | None) -> None:
        """BFGS from a measured Hessian, made positive definite (eigenvalues
        mirrored and floored: a saddle's downhill direction keeps its scale);
        None (not measured: out of time) or a broken one leaves the model to its first steps."""
        if hessian is None or not np.all(np.isfinite(hessian)):
            return
        values, vectors = np.linalg.eigh(0.5 * (hessian + hessian.T))
        floor = 1e-6 * max(float(np.abs(values).max(initial=0.0)), 1e-12)
        self.model = (vectors * np.maximum(np.abs(values), floor)) @ vectors.T

    def _model_hessian(self, gradient: Array, hessian: Array | None) -> Array:
        n = len(gradient)
        if self.bfgs:
            if self.model is None:
                # until a step shows the curvature: a first step of about 1 scaled unit (1 mm)
                self.model = np.eye(n) * max(float(np.abs(gradient).max(initial=0.0)), 1e-12)
            return self.model
        assert hessian is not None
        if self.model is None:
            self.model = np.zeros((n, n))
        self.gauss_newton = hessian
        diagonal = np.diag(hessian)
        floor = 1e-9 * max(float(diagonal.max(initial=0.0)), 1e-12)
        corrected = hessian + self.model if self.corrected else hessian
        return corrected + self.damping * np.diag(diagonal + floor)

    def line_search(
        self, u: Array, value: float, gradient: Array, step: Array
    ) -> tuple[Array, Array, Array, float, Array, Array | None, bool] | None:
        """Backtracking along the step projected onto the bounds (several may
        become active at once), stopped at the first spacing it reaches, each trial
        projected back onto the loops: (point, c, dc/du, f, its gradient, its
        Hessian, whether the whole step was taken), or None when nothing is lower."""
        problem = self.problem
        length = max(float(np.abs(step).max()), 1e-300)
        first = alpha = min(1.0, _longest(problem, u, step), min(self.max_step, self.radius) / length)
        g_rows, h = problem.linear_rows()
        while alpha > 1e-10:
            clipped = (u + alpha * step).clip(problem.low, problem.high)
            moved = clipped - u
            slope = float(gradient @ moved)
            trial, c, a, feasible = (
                restore(problem, clipped, self.fixed | (clipped != u + alpha * step))
                if slope < 0.0  # else bent too far by the bounds: shorter, they bend it less
                else (clipped, np.zeros(0), np.zeros((0, 0)), False)
            )
            if feasible and (g_rows @ trial + h >= -ACTIVE).all():
                value_new, gradient_new, hessian = problem.evaluate(trial)
                if _finite(value_new, gradient_new, hessian) and value_new <= value + ARMIJO * slope:
                    if not self.bfgs:
                        predicted = -(slope + 0.5 * float(moved @ self.hessian @ moved))
                        ratio = (value - value_new) / max(predicted, 1e-300)
                        self._adapt(alpha == 1.0, ratio)
                        self._choose_model(moved, slope, value - value_new)
                        if alpha < first:
                            self.radius = 2.0 * float(np.abs(moved).max())
                        elif ratio > 0.75:
                            self.radius *= 2.0
                    return trial, c, a, value_new, gradient_new, hessian, alpha == 1.0
            alpha *= 0.5  # the damping stays: `_adapt` judges the step actually taken
        return None

    def _choose_model(self, moved: Array, slope: float, lowered: float) -> None:
        """NL2SOL's switch: next, use the model (Gauss-Newton, or with the correction S)
        that predicted this step's decrease better. Near a zero residual Gauss-Newton
        converges fast and S only shortens the steps; far from one S is the better model."""
        assert self.model is not None
        plain = -(slope + 0.5 * float(moved @ self.gauss_newton @ moved))
        corrected = plain - 0.5 * float(moved @ self.model @ moved)
        self.corrected = abs(corrected - lowered) < abs(plain - lowered)

    def _adapt(self, full_step: bool, ratio: float) -> None:
        """Levenberg-Marquardt: trust the quadratic model more where its whole step
        predicted well, less where it predicted badly (a shortened step limits the
        next one through `radius` instead)."""
        if full_step and ratio > 0.75:
            self.damping = max(self.damping / 3.0, 1e-12)
        elif ratio < 0.25:
            self.damping *= 2.0

    def trusted(self) -> bool:
        """Whether a short step or a small decrease can mean the bottom is near."""
        return self.bfgs or self.damping <= TRUSTED_DAMPING

    def reset(self, u: Array, gradient: Array, a: Array) -> bool:
        """After a failed line search: start the model again if that may help."""
        if not self.fresh:
            self.model = None
            if self.measure is not None:
                self.start_from(self.measure(u, gradient, a))
            self.fresh = True
            return True
        if not self.bfgs and self.damping < 1e8:
            self.damping = max(self.damping, 1.0) * 100.0
            return True
        return False

    def learn(self, s: Array, gradient_change: Array, jacobian_change: Array, hessian: Array | None) -> None:
        """Secant update of the model from a step s: the loops' curvature enters
        through the multipliers and the change of their Jacobian."""
        y = gradient_change - jacobian_change.T @ self.multipliers
        sy = float(s @ y)
        if self.model is None:
            return
        if self.bfgs:
            self._bfgs(s, y, sy)
        elif sy > 1e-150:  # NL2SOL's update needs positive curvature along the step (and sy^2 > 0)
            assert hessian is not None
            self._nl2sol(s, y, sy, hessian)
        else:
            return
        self.fresh = False

    def _bfgs(self, s: Array, y: Array, sy: float) -> None:
        """Damped BFGS (Powell: defined for any curvature along the step, negative
        too, as near an unstable balance), from the measured Hessian or the
        identity scaled to the first positive curvature seen (Nocedal & Wright, 6.20)."""
        if self.fresh and self.measure is None and sy > 0.0:
            self.model = np.eye(len(s)) * float(y @ y) / sy
        assert self.model is not None
        bs = self.model @ s
        sbs = float(s @ bs)
        if sbs <= 1e-300:
            return
        theta = 1.0 if sy >= 0.2 * sbs else 0.8 * sbs / (sbs - sy)
        r = theta * y + (1.0 - theta) * bs
        self.model = self.model - np.outer(bs, bs) / sbs + np.outer(r, r) / float(s @ r)

    def _nl2sol(self, s: Array, y: Array, sy: float, gauss_newton: Array) -> None:
        """S with (J^T J + S) s = y, sized down first when it overshoots (NL2SOL)."""
        assert self.model is not None
        wanted = y - gauss_newton @ s
        ss = self.model @ s
        s_ss = float(s @ ss)
        if s_ss > 0.0:
            size = min(1.0, abs(float(s @ wanted)) / s_ss)
            self.model, ss = self.model * size, ss * size
        v = wanted - ss
        self.model = (
            self.model + (np.outer(v, y) + np.outer(y, v)) / sy - float(s @ v) * np.outer(y, y) / sy**2
        )


def tangent_curvature(
    objective: Objective,
    x: Array,
    low: Array,
    high: Array,
    *,
    equality: Equality | None = None,
    linear: Linear | None = None,
    scale: Array | None = None,
    deadline: float = np.inf,
    exact_hessian: LagrangianHessian | None = None,
) -> tuple[Array, Array]:
    """The curvature of f at x along the constraints active there (c = 0, the
    bounds x is on, the spacing at 0): eigenvalues of the Lagrangian's Hessian
    on their tangent space, ascending, in objective units per scaled unit
    squared, and the matching directions in x (columns). A negative one makes
    x an unstable balance, and its direction is the way down. `exact_hessian`:
    the Lagrangian's in closed form (given x and the equality multipliers);
    without it the Hessian is measured, and past `deadline` (the measurement
    takes a gradient per variable) nothing is: no values, no directions."""
    problem = _Scaled.of(objective, low, high, equality, linear, scale, exact_hessian)
    u = np.asarray(x, dtype=float) * problem.scale
    _, gradient, _ = problem.evaluate(u)
    _, a = problem.constraints(u)
    g_rows, h = problem.linear_rows()
    rows = np.vstack([a, g_rows[g_rows @ u + h <= ACTIVE]])
    rows = np.vstack([rows, np.eye(len(u))[_held_by_bounds(problem, u, gradient, rows)]])
    # a step long against rounding (the Hessian is read for its sign), short against the
    # friction's half-millimetre smoothing
    hessian = _lagrangian_hessian(problem, u, gradient, a, step=1e-2, rows=rows, deadline=deadline)
    if hessian is None or not np.all(np.isfinite(hessian)):
        return np.zeros(0), np.zeros((len(u), 0))
    null = np.eye(len(u))
    if len(rows):
        _, singular, right_t = np.linalg.svd(rows, full_matrices=True)
        rank = _rank(singular)
        null = right_t[rank:].T
    values, vectors = np.linalg.eigh(null.T @ (0.5 * (hessian + hessian.T)) @ null)
    return values, (null @ vectors) / problem.scale[:, None]


def _held_by_bounds(problem: _Scaled, u: Array, gradient: Array, rows: Array) -> Array:
    """The variables on a bound that the gradient presses against it (a positive
    multiplier). One on a bound with no force on it (a hook balanced exactly on
    its tip) is free to leave inwards: its direction stays in the tangent space."""
    at_low, at_high = problem.on_bounds(u)
    inside = ~(at_low | at_high)
    multipliers = np.linalg.lstsq(rows[:, inside].T, gradient[inside], rcond=None)[0] if len(rows) else []
    push = gradient - rows.T @ multipliers if len(rows) else gradient
    threshold = 1e-6 * float(np.abs(gradient).max(initial=0.0)) + 1e-300
    return (at_low & (push > threshold)) | (at_high & (push < -threshold))


def _lagrangian_hessian(
    problem: _Scaled,
    u: Array,
    gradient: Array,
    a: Array,
    step: float = 1e-4,
    rows: Array | None = None,
    deadline: float = np.inf,
) -> Array | None:
    """Forward differences of the Lagrangian's gradient, stepping inwards at upper
    bounds. The loops' multipliers come from `rows` (the active constraints, the
    loops first) when given, else from the loops alone. The default step is in
    scaled units (mm): the friction smoothing is 0.5 mm, the swings far longer.
    One gradient per variable: None when the deadline passes on the way.
    With a closed form (`_Scaled.hessian`) none is measured: bounds and
    linear rows add no curvature, and the multipliers are the same in scaled
    and unscaled variables."""
    active = a if rows is None else rows
    multipliers = np.linalg.lstsq(active.T, gradient, rcond=None)[0][: len(a)] if len(active) else np.zeros(0)
    known = None if problem.hessian is None else problem.hessian(u / problem.scale, multipliers)
    if known is not None:
        return known / np.outer(problem.scale, problem.scale)
    base = gradient - a.T @ multipliers
    columns = []
    for i in range(len(u)):
        if time.monotonic() > deadline:
            return None
        h = -step if u[i] + step > problem.high[i] else step
        moved = u.copy()
        moved[i] += h
        _, g, _ = problem.evaluate(moved)
        _, a_moved = problem.constraints(moved)
        columns.append((g - a_moved.T @ multipliers - base) / h)
    return np.array(columns).T


def constrained_step(
    hessian: Array, gradient: Array, rows: Array, rhs: Array
) -> tuple[Array, Array, float] | None:
    """min g.d + d.H.d / 2 subject to rows d = rhs, rows possibly dependent
    (loops through symmetric joints repeat equations): (d, multipliers lam with
    g + H d = rows^T lam, largest component of the gradient projected on the
    constraints' null space); None when H is not positive definite there."""
    if rows.shape[0] == 0:
        d = _solve_spd(hessian, -gradient)
        return None if d is None else (d, np.zeros(0), float(np.abs(gradient).max(initial=0.0)))
    left, singular, right_t = np.linalg.svd(rows, full_matrices=True)
    rank = _rank(singular)
    image, null = right_t[:rank].T, right_t[rank:].T
    particular = image @ ((left[:, :rank].T @ rhs) / singular[:rank])
    projected = null @ (null.T @ gradient)
    if null.shape[1]:
        reduced = null.T @ hessian @ null
        w = _solve_spd(reduced, -(null.T @ (gradient + hessian @ particular)))
        if w is None:
            return None
        step = particular + null @ w
    else:
        step = particular
    multipliers = left[:, :rank] @ ((right_t[:rank] @ (gradient + hessian @ step)) / singular[:rank])
    return step, multipliers, float(np.abs(projected).max(initial=0.0))


def _rank(singular: Array) -> int:
    """How many singular values span a direction (above RANK of the largest)."""
    return int(np.sum(singular > RANK * max(float(singular.max(initial=0.0)), 1e-300)))


def _solve_spd(matrix: Array, rhs: Array) -> Array | None:
    """matrix^-1 rhs for a positive definite matrix; None for any other."""
    if len(rhs) >= LAPACK_UNKNOWNS:
        return _solve_spd_lapack(matrix, rhs)
    try:
        np.linalg.cholesky(matrix)  # the test of definiteness; numpy has no triangular solve
        return np.linalg.solve(matrix, rhs)
    except np.linalg.LinAlgError:  # not definite, or definite only to rounding (a pivot of 1e-17)
        return None


def _solve_spd_lapack(matrix: Array, rhs: Array) -> Array | None:
    """`_solve_spd` by LAPACK's Cholesky factorisation and its triangular solves
    (numpy has no triangular solve, so it factors twice: Cholesky, then LU)."""
    from scipy.linalg import lapack  # imported only for large problems: see LAPACK_UNKNOWNS

    factor, info = lapack.dpotrf(matrix, lower=True, clean=False)
    if info != 0:  # a pivot not positive: not definite
        return None
    solution, info = lapack.dpotrs(factor, rhs, lower=True)
    return solution if info == 0 else None


def _longest(problem: _Scaled, u: Array, step: Array) -> float:
    """The largest alpha keeping u + alpha step inside the inactive spacing."""
    alpha = np.inf
    g_rows, h = problem.linear_rows()
    if len(h):
        values, rates = g_rows @ u + h, g_rows @ step
        inactive = (values > ACTIVE) & (rates < 0)
        if np.any(inactive):
            alpha = min(alpha, float(np.min(-values[inactive] / rates[inactive])))
    return max(alpha, 0.0)


def _close(problem: _Scaled, u: Array) -> tuple[Array, Array, Array, bool]:
    """A start too far from the loops for Newton's projection: least squares on
    the closure residual first, inside the bounds."""
    assert problem.equality is not None
    closed = minimize(
        least_squares_objective(problem.equality),
        u / problem.scale,
        problem.low / problem.scale,
        problem.high / problem.scale,
        linear=problem.linear,
        scale=problem.scale,
        stop_below=0.5 * RESTORED**2,
    )
    return restore(problem, closed.x * problem.scale, np.zeros(len(u), dtype=bool))


def restore(problem: _Scaled, u: Array, fixed: Array) -> tuple[Array, Array, Array, bool]:
    """Newton projection onto c = 0 moving only the variables off their bounds
    (least-norm steps, keeping active spacing where it is): (u, c, dc/du, on c = 0)."""
    c, a = problem.constraints(u)
    if problem.equality is None:
        return u, c, a, True
    g_rows, h = problem.linear_rows()
    held = fixed.copy()
    previous = np.inf
    for _ in range(RESTORE_ITERATIONS):
        error = float(np.abs(c).max(initial=0.0))
        if not np.isfinite(error) or not np.all(np.isfinite(a)):
            break  # not a number: no projection to make
        if error <= RESTORED:
            return u, c, a, True
        if error >= previous:
            break  # not converging: the step went too far from the loops
        previous = error
        active = g_rows @ u + h <= ACTIVE
        free = ~held
        rows = np.vstack([a[:, free], g_rows[active][:, free]])
        rhs = -np.concatenate([c, g_rows[active] @ u + h[active]])
        u = u.copy()
        u[free] += np.linalg.lstsq(rows, rhs, rcond=RANK)[0]
        clipped = np.clip(u, problem.low, problem.high)
        held |= clipped != u
        u = clipped
        c, a = problem.constraints(u)
    return u, c, a, float(np.abs(c).max(initial=0.0)) <= RESTORED
