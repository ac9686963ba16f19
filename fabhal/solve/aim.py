"""Aiming: choose what the builder sets once so that the hack, once it has
settled under gravity, hangs nearest the request.

The paper's two steps fit the target with gravity off, then let gravity act,
and step 2 keeps whatever step 1 left in the choices that stay put: the held
DoFs of `fixed` connections and clips (where a clip grips a bar, at what
angle) and where a part is placed on a rod, tube, edge or floor that friction
then holds. Those were chosen blind to where the hack hangs (the demo's
S-hook left at 86 % of the hanger's bar: the hanger tilts and the ring hangs
117 mm from the request; at the bar's middle it hangs within a millimetre).

Aiming fits again, from the settled configuration, asking for both at once:
the target at its request, and every part that gravity moves at rest. The
residuals are the target's (mm, degrees counted as mm) and the generalised
force on each DoF that gravity moves (projected along the loops, as the
equilibrium check measures it: a fraction of the weight per mm of motion)
times FORCE_AS_MM; the unknowns are all the free DoFs, the choices among
them. Gauss-Newton on that least-squares problem (fabhal/optimize.py): the
target's Jacobian exact, the force's from the Lagrangian's Hessian (in
closed form, fabhal/solve/energy.py; while a contact touches, what the
springs nearly know, `Energy.nearly`: all but the obstacle's curvature under
the points; by forward differences of the exact energy gradient, a gradient
per DoF, only where no closed form is given), kept up to date between those
by Broyden's secant updates (one gradient per step); the force's
weight is raised in stages (a stiff start is ill-conditioned and stalls).
A force within the equilibrium tolerance costs about a millimetre. Its
answer only proposes the choices: step 2 settles from it with them held
(friction from where the parts were placed) and the solver keeps whichever
settled result ranks first, so aiming never makes an answer worse.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np
from numpy.typing import NDArray

from fabhal.kinematics.frames import Array
from fabhal.model import Model
from fabhal.optimize import least_squares_objective
from fabhal.primitives import Dof, is_flex_angle
from fabhal.solve import target as target_mod
from fabhal.solve.energy import Energy
from fabhal.solve.forces import friction_slides, slide_dofs
from fabhal.solve.steps import Problem, residual_stalled, unbalanced_force

Index = NDArray[np.intp]

# a force left unbalanced of 1/FORCE_AS_MM of the weight per mm costs like 1 mm of
# target error; raised in stages: 1 mm per 1 % of the weight, then per 0.1 % (the tolerance)
FORCE_AS_MM = (100.0, 1000.0)
AIM_EVALUATIONS = 30  # per stage
DIFFERENCE_MM = 1e-4  # the forward-difference step, in mm of motion
BROYDEN_STEPS = 8  # secant updates of the force's derivative before it is differenced afresh
# a stage ends when its last AIM_STALL_STEPS steps brought the residual less than AIM_GAIN_MM
# nearer: aiming that cannot gain (the mug hanger's rotation is out of reach) stops early
AIM_STALL_STEPS = 4
AIM_GAIN_MM = 0.5


def builder_settings(model: Model) -> set[int]:
    """The DoFs a builder sets once and that then stay put: those of held
    connections (clips, `fixed`) and the slides that friction holds."""
    held = {i for joint in model.joints if joint.held for i in joint.a.dof_indices + joint.b.dof_indices}
    return held | set(slide_dofs(friction_slides(model)))


def choices(problem: Problem) -> Index:
    """Positions in `problem.free` of the builder's settings (`builder_settings`)."""
    chosen = builder_settings(problem.model)
    return np.array([k for k, i in enumerate(problem.free) if int(i) in chosen], dtype=int)


def aim(
    problem: Problem,
    x: Array,
    energy: Energy,
    goal: target_mod.TargetGoal,
    weight: float,
    chosen: Index,
) -> Array:
    """Free DoFs (over `problem.free`) from the settled `x`: the target nearest
    its request with the parts that gravity moves (all but `chosen`) at rest.
    weight: the assembly's, joules per mm."""
    model = problem.model
    free, per_mm = problem.free, problem.scale
    moving = np.setdiff1d(np.arange(len(free)), chosen)
    low, high = (bound[free] for bound in model.bounds())
    leans = np.array([not model.variables[int(free[k])].dof.ends_hold for k in moving], dtype=bool)

    def weighed(v: Array) -> Array:
        """(moving,) the energy's gradient on each DoF gravity moves, over the weight per mm."""
        return energy(problem.full(v))[1][free][moving] / per_mm[moving] / weight

    def pressed(v: Array) -> tuple[Array, Array]:
        """(moving,) the generalised force on each DoF gravity moves, over the
        weight per mm; along a loop, less what the loop's constraint carries.
        And which of them an end of its range carries: pressed onto it (but
        not a lean's end: nothing real holds it there, E509)."""
        force = weighed(v)
        if model.closures:
            force = unbalanced_force(force, (problem.closure_jacobian(v) / per_mm)[:, moving])
        at_low = (v[moving] <= low[moving]) & ~leans
        at_high = (v[moving] >= high[moving]) & ~leans
        return force, (at_low & (force > 0)) | (at_high & (force < 0))

    def unbalanced(v: Array) -> Array:
        """The force left once the ends have carried their share."""
        force, carried = pressed(v)
        force[carried] = 0.0
        return force

    known = problem.free_hessian(energy, nearly=True)

    def differenced(v: Array, force: Array) -> Array:
        """The force's derivative: from the Lagrangian's Hessian in closed form
        where the energy has one (nearly: a touching spring's leaves out the
        obstacle's curvature), or else forward differences of its exact
        gradient (a gradient per DoF). Along loops the force is the gradient
        projected off the constraints' rows C (per mm, the moving DoFs), with
        multipliers mu (force = g + C^T mu); its derivative is that projection
        of the Lagrangian's Hessian (the multipliers lambda = -weight x mu), up
        to a term in the force itself, which vanishes at rest."""
        if known is not None:
            rows: Array | None = None
            multipliers: Array = np.zeros(0)
            if model.closures:
                rows = (problem.closure_jacobian(v) / per_mm)[:, moving]
                multipliers = -weight * np.linalg.lstsq(rows.T, -weighed(v), rcond=None)[0].astype(float)
            hessian = known(v, multipliers)
            if hessian is not None:
                change = hessian[moving] / per_mm[moving, None] / weight
                if rows is not None:
                    change = change - rows.T @ np.linalg.lstsq(rows.T, change, rcond=None)[0]
                change[pressed(v)[1]] = 0.0
                return change
        change = np.empty((len(force), len(v)))
        for k in range(len(v)):
            step = DIFFERENCE_MM / per_mm[k]
            moved = v.copy()
            moved[k] += step
            change[:, k] = (unbalanced(moved) - force) / step
        return change

    def with_jacobian(force_as_mm: float) -> Callable[[Array], tuple[Array, Array]]:
        # the last point, its force and the force's derivative there: between fresh
        # differences (a gradient per DoF), Broyden's secant update (one)
        last: list[tuple[Array, Array, Array, int]] = []

        def residual_and_jacobian(v: Array) -> tuple[Array, Array]:
            fwd = model.forward(problem.full(v), with_twists=True)
            target = target_mod.residual(goal, target_mod.achieved(goal, fwd.frames))
            force = unbalanced(v)
            if last and last[0][3] < BROYDEN_STEPS:
                before, force_before, change, age = last.pop()
                moved = v - before
                if moved @ moved > 0.0:
                    change = change + np.outer(force - force_before - change @ moved, moved) / (moved @ moved)
                last.append((v.copy(), force, change, age + 1))
            else:
                last[:] = [(v.copy(), force, differenced(v, force), 0)]
            change = last[0][2]
            jacobian = np.vstack(
                [target_mod.residual_jacobian(goal, model, fwd)[:, free], force_as_mm * change]
            )
            return np.concatenate([target, force_as_mm * force]), jacobian

        return residual_and_jacobian

    v = x[free].copy()
    for force_as_mm in FORCE_AS_MM:
        if problem.out_of_time():
            break
        objective = least_squares_objective(with_jacobian(force_as_mm))
        v = problem.minimize(objective, v, max_evaluations=AIM_EVALUATIONS, ftol=1e-10, stalled=_stalled).x
    return v


_stalled = partial(residual_stalled, steps=AIM_STALL_STEPS, gain_mm=AIM_GAIN_MM)


def within_a_turn(dof: Dof, value: float) -> float:
    """A DoF's value as a builder sets it: one that turns freely within one
    turn (a bottle turned 790 degrees on a floor is at 70), others as they are."""
    return value % 360.0 if dof.periodic else value


def setting_text(model: Model, i: int, value: float, length: float) -> str:
    """A DoF's value as a builder sets it: along a primitive in mm (`length`: mm
    per unit, steps.mm_per_unit); a tilt (a lean) from upright, a flexing
    hook's or ring's turn about the line of its contact from square, a turn
    about a rod or round a ring, in degrees."""
    variable = model.variables[i]
    dof = variable.dof
    where = variable.name.rsplit(".", 1)[0]  # part.primitive
    value = within_a_turn(dof, value)
    if not dof.periodic and dof.high <= 1.0:
        return f"{value * length:.0f} mm along {where} (of {length:.0f}){_counted_from(model, i)}"
    primitive = model.side_of(i).primitive
    kind = primitive.kind
    if is_flex_angle(dof, primitive.variant):  # a hook's or ring's turn on what it goes round
        return f"turned {round(value - dof.default):+d} degrees on {where} about the line of its contact"
    if dof.lean:
        return f"tilted {round(value - dof.default):+d} degrees on {where}"  # never "-0"
    if dof.name == "theta" and kind in ("hook", "hole"):  # where along its arc or round its ring
        return f"at {value:.0f} degrees round {where}"
    if dof.periodic:  # a rod's spin, a tube's theta, a surface's s
        return f"turned {value:.0f} degrees about {where}"
    return f"{dof.name} {value:.0f} degrees on {where}"


# an end of a rod is named by another primitive of its part lying this much nearer it
# than the other end (a hanger's corner bend by its bar's end, not its hook above the middle)
NAMED_END_SHARE = 0.5


def _counted_from(model: Model, i: int) -> str:
    """Which end a slide along a rod or tube counts from, as a builder finds it:
    " from its end by `part.primitive`" where another primitive of the same
    part lies by that end (a hanger's bar: the corner bend there), else ""."""
    side = model.side_of(i)
    primitive = side.primitive
    others = [p for p in model.parts[side.part].spec.primitives if p.name != primitive.name]
    if primitive.kind not in ("rod", "tube") or not others:
        return ""
    # where t = 0 and t = 1 put a connection on it, the other DoFs at their defaults
    at_ends = np.array([[t, *(d.default for d in primitive.dofs[1:])] for t in (0.0, 1.0)])
    start, end = primitive.connector_frames(at_ends)[:, :3, 3]
    by = min(others, key=lambda p: float(np.linalg.norm(p.base_frame()[:3, 3] - start)))
    place = by.base_frame()[:3, 3]
    if np.linalg.norm(place - start) > NAMED_END_SHARE * np.linalg.norm(place - end):
        return ""
    return f" from its end by `{model.parts[side.part].name}.{by.name}`"
