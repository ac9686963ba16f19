"""The two solver steps, as optimisation problems over the free DoFs.

Step 1 (fit): minimise the target cost subject to loop closure, spacing and
the DoFs' bounds. Step 2 (settle): from step 1, with the target free, minimise
the potential energy under the same constraints, holding the DoFs of `fixed`
connections and clips. Both are solved by fabhal.optimize with exact
Jacobians, in millimetres of motion (`mm_per_unit`): Gauss-Newton for the fit,
BFGS for the energy, every iterate on the closed loops.

Loop closure is imposed with 6 equations per loop: the position error and the
antisymmetric part of the rotation error (zero at a closed loop; the
starting point is always a closed configuration, so the half-turn solution
of that form is never near).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from functools import cached_property, partial
from typing import Any

import numpy as np

from fabhal.kinematics.frames import Array
from fabhal.model import ROTATION_LENGTH_MM, Model
from fabhal.optimize import (
    LagrangianHessian,
    Linear,
    Objective,
    Result,
    least_squares_objective,
    minimize,
    tangent_curvature,
)
from fabhal.solve import target as target_mod
from fabhal.solve.contacts import Pairs, passing_through, penetration, wires_crossed
from fabhal.solve.energy import Energy
from fabhal.solve.forces import Slide, slide_dofs, weight_newtons
from fabhal.solve.spacing import Spacing, spacing_jacobian, spacing_values, turn_rows

# static friction coefficient of a part sliding along a rod, tube or edge (steel, plastic, wood)
FRICTION = 0.3
# |s| is smoothed as sqrt(s^2 + 0.5^2) - 0.5 for the gradient methods: a held part may
# creep up to about half a millimetre (a contact's elastic give) before friction holds
FRICTION_SMOOTHING_MM = 0.5
# two estimates of what friction holds agree within this fraction of the assembly's
# weight (times FRICTION): the settle's rounds of friction, the test of a slip
FRICTION_AGREEMENT = 0.01
CLOSED_MM = 1e-6
FIT_EVALUATIONS = 200  # for the most promising start of step 1 without loops
FIT_PROBE_EVALUATIONS = 20  # for each start first
FIT_FTOL = 1e-8  # relative decrease of the target cost that ends a fit
# a start whose target residual (mm, and degrees counted as mm) is this close needs no other start
GOOD_FIT = 0.5
RUNNER_UP_MM = 100.0  # see _worth_settling
# probes finished at most, best first: the answer and its runner-up; a third
# rarely wins and costs a whole fit (an unreachable target stalls from every start)
FINISHED_FITS = 2
FIT_STALL_STEPS = 15  # see residual_stalled
# no DoF moves its connection more than this in one step (mm; degrees count as mm):
# longer steps from a nearly singular model took up to 18 halvings each
MAX_STEP_MM = 50.0
BOUND_TOLERANCE = 1e-6  # a DoF within this fraction of its range from an end rests on that end
SETTLE_ITERATIONS = 400  # of one settle; each iteration is one to a few energy evaluations
# a settle ends when its last SETTLE_STALL_STEPS steps lowered the energy less than the
# force left at rest does over SETTLE_STALL_MM (at 1e-4 of the weight: the whole
# assembly lowered by a micrometre); whether it is at rest is then verified by statics
SETTLE_STALL_STEPS = 20
SETTLE_STALL_MM = 10.0

# rows (per loop) of the 12 closure residuals kept as the 6 constraint equations:
# position (3) and vee((R - R^T) / 2) from the 9 rotation entries
_ANTISYMMETRIC = np.zeros((3, 9))
for _row, (_i, _j) in enumerate(((2, 1), (0, 2), (1, 0))):
    _ANTISYMMETRIC[_row, 3 * _i + _j] = 0.5
    _ANTISYMMETRIC[_row, 3 * _j + _i] = -0.5


def _closure_weights(multipliers: Array) -> Array:
    """(6k,) multipliers of the loops' six equations -> (k, 3, 4) weights W with
    multipliers . equations = sum <W, E[:3, :]> + constant (E: each loop's error
    frame; `Model.closure_hessian`): `_to_six`'s transpose, the rotation entries
    scaled as the residuals scale them."""
    blocks = multipliers.reshape(-1, 6)
    weights = np.zeros((len(blocks), 3, 4))
    weights[:, :, 3] = blocks[:, :3]
    weights[:, :, :3] = (blocks[:, 3:] @ _ANTISYMMETRIC).reshape(-1, 3, 3) * ROTATION_LENGTH_MM
    return weights


def _to_six(residual12: Array) -> Array:
    """(..., 12k, ...) -> (..., 6k, ...) along the first axis."""
    blocks = residual12.reshape(-1, 12, *residual12.shape[1:])
    position = blocks[:, :3]
    rotation = np.einsum("ij,kj...->ki...", _ANTISYMMETRIC, blocks[:, 3:])
    return np.concatenate([position, rotation], axis=1).reshape(-1, *residual12.shape[1:])


@dataclass
class Problem:
    """The free DoFs of a model and the constraints on them."""

    model: Model
    free: Array  # indices into x of the DoFs being solved for
    x_base: Array  # values of the others
    spacing: list[Spacing] = field(default_factory=list)
    deadline: float = float("inf")

    def full(self, v: Array) -> Array:
        x = self.x_base.copy()
        x[self.free] = v
        return x

    def bounds(self) -> tuple[Array, Array]:
        low, high = self.model.bounds()
        return low[self.free], high[self.free]

    def closure(self, v: Array) -> Array:
        return _to_six(self.model.closure_residuals(self.full(v)))

    def closure_jacobian(self, v: Array) -> Array:
        return _to_six(self.model.closure_jacobian(self.full(v)))[:, self.free]

    def limit_values(self, v: Array) -> Array:
        """The linear inequalities' values (>= 0 where kept): spacing, then turning together."""
        matrix, offset = self._turns
        x = self.full(v)
        return np.concatenate([spacing_values(self.spacing, x), matrix @ x + offset])

    def limit_jacobian(self) -> Array:
        """Their rows over the free DoFs (constant: the inequalities are linear)."""
        rows = np.vstack([spacing_jacobian(self.spacing, len(self.x_base)), self._turns[0]])
        return rows[:, self.free]

    @cached_property
    def _turns(self) -> tuple[Array, Array]:
        return turn_rows(self.model.turn_limits, len(self.x_base))

    def has_limits(self) -> bool:
        return bool(self.spacing) or len(self._turns[1]) > 0

    def equality(self) -> Callable[[Array], tuple[Array, Array]] | None:
        """Loop closure as the optimiser's equality constraints (None without loops)."""
        if not self.model.closures:
            return None
        return lambda v: (self.closure(v), self.closure_jacobian(v))

    def linear(self) -> Linear | None:
        """Spacing and turning together as the optimiser's linear inequalities
        (None without either)."""
        if not self.has_limits():
            return None
        return Linear(self.limit_jacobian(), self.limit_values(np.zeros(len(self.free))))

    @cached_property
    def scale(self) -> Array:
        """Millimetres of motion per unit of each free DoF (`mm_per_unit`)."""
        return mm_per_unit(self.model)[self.free]

    def _optimiser_setting(self) -> tuple[Array, Array, dict[str, Any]]:
        """Bounds, loops, spacing and millimetres, as the optimiser takes them."""
        low, high = self.bounds()
        return low, high, {"equality": self.equality(), "linear": self.linear(), "scale": self.scale}

    def minimize(
        self,
        objective: Objective,
        start: Array,
        max_iterations: int = 200,
        max_evaluations: int | None = None,
        ftol: float = 0.0,
        gtol: float = 0.0,
        measure_curvature: bool = False,
        curvature: Array | None = None,
        stalled: Callable[[list[float]], bool] | None = None,
        hessian: LagrangianHessian | None = None,
    ) -> Result:
        """The optimiser on this problem: bounds, loops, spacing, millimetres, time limit."""
        low, high, setting = self._optimiser_setting()
        return minimize(
            objective,
            start,
            low,
            high,
            **setting,
            max_iterations=max_iterations,
            max_evaluations=max_evaluations,
            ftol=ftol,
            gtol=gtol,
            deadline=self.deadline,
            measure_curvature=measure_curvature,
            curvature=curvature,
            stalled=stalled,
            max_step=MAX_STEP_MM,
            exact_hessian=hessian,
        )

    def curvature(self, energy: Energy, v: Array) -> tuple[Array, Array]:
        """The energy's curvature at v along the active constraints: eigenvalues
        (joules per mm of motion squared, ascending) and directions in v."""
        low, high, setting = self._optimiser_setting()
        return tangent_curvature(
            _free_objective(self, energy),
            v,
            low,
            high,
            **setting,
            deadline=self.deadline,
            exact_hessian=self.free_hessian(energy),
        )

    def free_hessian(self, energy: Energy, nearly: bool = False) -> LagrangianHessian | None:
        """Over the free DoFs, given the loops' multipliers (six per loop, as
        `closure`): the Hessian of the energy less multipliers x closure
        constraints (the Lagrangian's); None where the energy has no closed form
        (always, or at that v). `nearly`: from the energy's `nearly`."""
        whole = energy.nearly if nearly else energy.hessian
        if whole is None:
            return None
        model, block = self.model, np.ix_(self.free, self.free)

        def hessian(v: Array, multipliers: Array) -> Array | None:
            x = self.full(v)
            out = whole(x)
            if out is None:
                return None
            if model.closures and np.any(multipliers):
                fwd = model.forward(x, with_twists=True)
                out = out - model.closure_hessian(x, fwd, _closure_weights(multipliers))
            return out[block]

        return hessian

    def out_of_time(self) -> bool:
        return time.monotonic() > self.deadline


# ---------------------------------------------------------------- step 1


@dataclass(frozen=True)
class Fit:
    v: Array  # the best free DoFs found
    late: bool  # stopped early for the time limit
    # the most promising other start's probe when no start fitted (GOOD_FIT): where
    # starts end in different valleys, the hack may also hang from there
    runner_up: Array | None = None
    # the movable parts, in twos, that the fit found passing through each other and
    # took apart (`fit_target`): their springs act from the settle's start
    untangled: frozenset[frozenset[int]] = frozenset()


Rows = Callable[[Array], tuple[Array, Array]]  # residuals and their Jacobian over the free DoFs

# in step 1's refit, a millimetre inside an obstacle costs like this many of target error
PENETRATION_WEIGHT = 100.0
# step 1's refits at most, while each one's answer has parts crossing it did not keep apart
UNTANGLE_ROUNDS = 3


def fit_target(
    problem: Problem,
    goal: target_mod.TargetGoal,
    starts: Iterable[Array],
    pairs: Pairs | None = None,
    evaluations: int = FIT_EVALUATIONS,
    objective: Rows | None = None,
) -> Fit:
    """Best free DoFs over the starts (taken from `starts` only as needed).
    `objective`: rows to least-square instead of the target's residual
    (`taken_apart`).

    Every start is fitted for FIT_PROBE_EVALUATIONS first, then the most
    promising ones (FINISHED_FITS at most) to FIT_EVALUATIONS, best first, until
    one fits (GOOD_FIT) or the rest end too far from the target to be worth it
    (`_worth_settling`): a chain that cannot reach its target converges slowly
    from every start. A start whose probe fits ends the search; it is still
    finished (polished to convergence). Where none fits, the runner-up is the
    next best finished fit. If the answer passes through the environment
    (`pairs`: the environment or another part), it is fitted once more with
    each millimetre a point is inside costing like PENETRATION_WEIGHT
    millimetres of target error: a builder gives up some accuracy before
    pushing one object through another. Two movable parts whose walls cross
    (`passing_through`: two mugs' rims through each other) are kept apart by their
    convex hulls in that fit (`Pairs.hulls`): inside a thin wall the way out is
    either face, inside the hull it is the way apart."""
    model = problem.model

    def residual_and_jacobian(v: Array) -> tuple[Array, Array]:
        if objective is not None:
            return objective(v)
        fwd = model.forward(problem.full(v), with_twists=True)
        r = target_mod.residual(goal, target_mod.achieved(goal, fwd.frames))
        return r, target_mod.residual_jacobian(goal, model, fwd)[:, problem.free]

    def kept_out(v: Array, kept_apart: tuple[Pairs, ...]) -> tuple[Array, Array]:
        rows = [residual_and_jacobian(v)]
        for apart in kept_apart:
            depth, depth_jacobian = penetration(model, problem.full(v), apart)
            rows.append((PENETRATION_WEIGHT * depth, PENETRATION_WEIGHT * depth_jacobian[:, problem.free]))
        return np.concatenate([r for r, _ in rows]), np.vstack([jacobian for _, jacobian in rows])

    def fit(start: Array, evaluations: int, kept_apart: tuple[Pairs, ...] = ()) -> tuple[Array, float]:
        residuals = partial(kept_out, kept_apart=kept_apart) if kept_apart else residual_and_jacobian
        v = problem.minimize(
            least_squares_objective(residuals),
            start,
            max_evaluations=evaluations,
            ftol=FIT_FTOL,
            stalled=_fit_stalled,
        ).x
        r = residuals(v)[0]
        return v, float(r @ r) if feasible(problem, v) else np.inf

    def out_of_the_world(result: Fit) -> Fit:
        """The fit again from where it ended, now kept out of the environment,
        when it passes through it (fitted without: contact residuals switch on
        and off, and from the start they lead the fit astray), and two movable
        parts kept apart by their hulls where walls or wires cross
        (`passing_through`, `wires_crossed`); again while that fit's answer has
        parts crossing that it did not keep apart (UNTANGLE_ROUNDS). Each kept
        only if its loops are closed and spacings kept (`fit`'s cost is finite)."""
        if not pairs or result.late or problem.out_of_time():
            return result
        v, tangled = result.v, frozenset[frozenset[int]]()
        for refits in range(UNTANGLE_ROUNDS):
            if problem.out_of_time():
                break  # each round's fine check costs a hoop on twelve chains 0.25 s
            x = problem.full(v)
            crossed = passing_through(model, x, pairs) | wires_crossed(model, x, pairs)
            if crossed <= tangled and (refits or not penetration(model, x, pairs)[0].any()):
                break
            if problem.out_of_time():
                break
            tangled |= crossed
            kept_apart = (pairs, pairs.hulls(tangled)) if tangled else (pairs,)
            refitted, cost = fit(v, evaluations, kept_apart)
            if not np.isfinite(cost):
                break  # not at the price of an open loop
            v = refitted
        if v is result.v:
            return result
        return replace(result, v=v, untangled=tangled - passing_through(model, problem.full(v), pairs))

    probes: list[tuple[float, Array]] = []
    remaining = iter(starts)
    first = next(remaining)
    for start in itertools.chain([first], remaining):
        if problem.out_of_time():
            break
        v, cost = fit(start, FIT_PROBE_EVALUATIONS)
        probes.append((cost, v))
        if cost < GOOD_FIT**2:
            break  # the other starts are there for when this one is stuck far away
    if not probes:
        return Fit(first, True)
    probes.sort(key=lambda probe: probe[0])
    best_probe = probes[0][0]
    if problem.out_of_time():
        return Fit(probes[0][1], True)
    # finished best first, until one fits: a probe's cost after a few evaluations
    # ranks the starts only roughly (clip light S: the third-ranked probe fits)
    finished: list[tuple[float, Array]] = []
    for cost, probe in probes:
        if finished and (
            len(finished) == FINISHED_FITS or not _worth_settling(cost, best_probe) or problem.out_of_time()
        ):
            break
        v, final = fit(probe, evaluations)
        finished.append((final, v) if final <= cost else (cost, probe))
        if finished[-1][0] < GOOD_FIT**2:
            break
    finished.sort(key=lambda result: result[0])
    (cost, v), others = finished[0], [u for c, u in finished[1:] if _worth_settling(c, finished[0][0])]
    return out_of_the_world(Fit(v, False, None if cost < GOOD_FIT**2 or not others else others[0]))


def taken_apart(problem: Problem, goal: target_mod.TargetGoal, v: Array, pairs: Pairs) -> Fit:
    """A given configuration (a neighbouring member's: `fabhal search --smooth`)
    as step 1's answer, with what crosses in it taken apart as step 1's refit
    does (`fit_target`), each DoF moved as little as it can be (millimetres,
    a degree as a millimetre): the neighbour's configuration given to a
    shorter chain had two of its rings 3 mm inside each other from the start,
    where a settle leaves them. As it is where nothing crosses."""
    scale = problem.scale

    def moves(u: Array) -> tuple[Array, Array]:
        return scale * (u - v), np.diag(scale)

    return fit_target(problem, goal, [v], pairs, objective=moves)


def _worth_settling(cost: float, best: float) -> bool:
    """Whether a probe that ended at `cost` may settle to hang nearer the request
    than the best probe (costs are squared residuals): when it ended no more
    than RUNNER_UP_MM further away, the distance a hack of everyday parts moves
    when it settles (the gallery's clip lights move 30-100 mm)."""
    return bool(np.isfinite(cost) and np.sqrt(cost) - np.sqrt(best) <= RUNNER_UP_MM)


def residual_stalled(costs: list[float], steps: int, gain_mm: float) -> bool:
    """A least-squares fit's last `steps` steps brought its residual less than
    `gain_mm` nearer (costs are |r|^2 / 2): the rest is not worth it."""
    if len(costs) <= steps:
        return False
    before, now = (np.sqrt(2.0 * max(c, 0.0)) for c in (costs[-1 - steps], costs[-1]))
    return bool(before - now < gain_mm)


# step 1's fit: the target less than GOOD_FIT closer in FIT_STALL_STEPS steps; it then
# settles under gravity anyway (the reading nook crept 1 mm in 100 evaluations)
_fit_stalled = partial(residual_stalled, steps=FIT_STALL_STEPS, gain_mm=GOOD_FIT)


# ---------------------------------------------------------------- step 2


def potential(model: Model, masses: Array, centres: Array) -> Energy:
    """U(x) = sum of m g z of each part's centre of mass, in joules, dU/dx and
    its exact Hessian (the weights as loads: `Model.load_hessian`).

    masses: (n_parts,) grams (0 for environments); centres: (n_parts, 3) mm in part frames."""
    weights = weight_newtons(masses) / 1000.0  # joules per mm of height

    def energy(x: Array) -> tuple[float, Array]:
        fwd = model.forward(x, with_twists=True)
        heights = np.einsum("pj,pj->p", fwd.frames[:, 2, :3], centres) + fwd.frames[:, 2, 3]
        return float(weights @ heights), model.weighted_height_gradient(fwd, weights, centres)

    def hessian(x: Array) -> Array:
        fwd = model.forward(x, with_twists=True)
        loads = np.zeros((len(weights), 3, 4))  # e_z (x) (centre, 1), times the weight
        world = np.einsum("pij,pj->pi", fwd.frames[:, :3, :3], centres) + fwd.frames[:, :3, 3]
        loads[:, 2, :3] = weights[:, None] * world
        loads[:, 2, 3] = weights
        return model.load_hessian(x, fwd, loads)

    return Energy(energy, hessian, hessian)


def with_friction(
    model: Model,
    energy: Energy,
    slides: list[Slide],
    resistance: Array,
    origin: Array,
) -> Energy:
    """The energy plus static friction on the slides (along rods, tubes and
    edges; over a floor).

    Quasi-static Coulomb friction as a dissipation potential (the incremental
    energy of rate-independent friction): sliding s mm from `origin` costs
    resistance x |s| (joules per mm: FRICTION x the contact's normal force),
    smoothed over FRICTION_SMOOTHING_MM; over a floor |s| is the length of the
    two-way slide, so friction resists every direction alike. So a slide moves
    only where the force along it beats FRICTION x the force across it: a hook
    on a rod sloping more than atan(0.3) = 16.7 degrees slides, and so does a
    bottle on a floor as steep. Turning DoFs (a hook rolling round its rod) stay
    frictionless. The normal forces come from the statics of the settled
    assembly (fabhal/solve/forces.py), not from the order of lines."""
    if not slides:
        return energy
    index = np.array(slide_dofs(slides), dtype=int)
    group = np.repeat(np.arange(len(slides)), [len(slide.dofs) for slide in slides])
    lengths = mm_per_unit(model)[index]
    start = origin[index].copy()
    same = group[:, None] == group[None, :]

    def moved_and_root(x: Array) -> tuple[Array, Array]:
        moved = (x[index] - start) * lengths
        return moved, np.sqrt(np.bincount(group, moved**2, len(slides)) + FRICTION_SMOOTHING_MM**2)

    def total(x: Array) -> tuple[float, Array]:
        value, gradient = energy(x)
        moved, root = moved_and_root(x)
        gradient = gradient.copy()
        gradient[index] += (resistance / root)[group] * moved * lengths
        return value + float(resistance @ (root - FRICTION_SMOOTHING_MM)), gradient

    def hessian(x: Array) -> Array:
        """r |s| on a slide s (mm): r (I / |s| - s s^T / |s|^3), in DoF units."""
        moved, root = moved_and_root(x)
        r, rooted = resistance[group], root[group]
        block = same * (np.eye(len(index)) / rooted[:, None] - np.outer(moved, moved) / rooted[:, None] ** 3)
        out = np.zeros((len(x), len(x)))
        out[np.ix_(index, index)] = r[:, None] * block * np.outer(lengths, lengths)
        return out

    return energy.plus(total, hessian)


def with_target_pull(model: Model, energy: Energy, goal: target_mod.TargetGoal, strength: float) -> Energy:
    """The energy plus a weak spring from the target to its requested frame:
    strength / 2 x |target residual|^2 (joules; the residual in mm, degrees as mm).
    Settling with it, then without it, picks among the configurations of equal
    energy (a part hanging from one point turns about the vertical for free)
    the one nearest the request, as someone hanging it by hand would."""

    def pulled(x: Array) -> tuple[float, Array]:
        value, gradient = energy(x)
        fwd = model.forward(x, with_twists=True)
        r = target_mod.residual(goal, target_mod.achieved(goal, fwd.frames))
        pull = target_mod.residual_jacobian(goal, model, fwd).T @ r
        return value + 0.5 * strength * float(r @ r), gradient + strength * pull

    return Energy(pulled)  # the residual's own curvature has no closed form here


def settle(
    problem: Problem,
    energy: Energy,
    start: Array,
    at_rest: float,
    curvature: Array | None = None,
) -> Result:
    """Free DoFs at rest (`.x`): minimum potential energy under the constraints,
    stopped once no generalised force (joules per mm of motion) exceeds
    `at_rest`. BFGS starts from the Hessian in closed form (`Energy.nearly`), or
    from `curvature` (an earlier settle's `.curvature`) when starting near
    where that one ended."""

    objective = _free_objective(problem, energy)
    # a long loop settles slowly (its energy valley is flat): more DoFs, more iterations
    iterations = max(SETTLE_ITERATIONS, 12 * len(problem.free))
    return problem.minimize(
        objective,
        start,
        max_iterations=iterations,
        gtol=at_rest,
        measure_curvature=True,
        curvature=curvature,
        stalled=partial(_settle_stalled, stall=at_rest * SETTLE_STALL_MM),
        # BFGS starts from the Lagrangian's Hessian in closed form, a touching contact
        # spring's but for the obstacle's curvature (`Energy.nearly`; the secant updates
        # correct the start), not measured by differences: a long loop's valley holds rests
        # within 0.01 J of each other, and which one a settle reaches is its path's; from
        # this start the diaper caddy comes to rest 10.0 mm from its request instead of
        # 32.5, the reading nook 18.8 instead of 23.5, both 10-30 % slower (bench/README.md
        # item 71). The stability test keeps the measured curvature: there the obstacle's
        # curvature decides (a part balanced on a round)
        hessian=problem.free_hessian(energy, nearly=True),
    )


def _settle_stalled(energies: list[float], stall: float) -> bool:
    """The last SETTLE_STALL_STEPS steps lowered the energy by less than `stall`
    (joules): creeping along a flat valley whose floor a contact's kinks
    make rough (the caddy's loop crept 0.4 degrees in 200 iterations)."""
    return len(energies) > SETTLE_STALL_STEPS and energies[-1 - SETTLE_STALL_STEPS] - energies[-1] < stall


def _free_objective(problem: Problem, energy: Callable[[Array], tuple[float, Array]]) -> Objective:
    """The energy as the optimiser's objective over the problem's free DoFs."""

    def objective(v: Array) -> tuple[float, Array, None]:
        value, gradient = energy(problem.full(v))
        return value, gradient[problem.free], None

    return objective


SURFACE_DIMENSION = {"t1": "width", "t2": "length"}


def mm_per_unit(model: Model) -> Array:
    """How far a connection point moves per unit of each DoF: a fraction t moves
    along the primitive's length (or width, height); an angle moves about 1 mm
    per degree at the radii of everyday hooks and rings (50 to 60 mm)."""
    scales = np.ones(len(model.variables))
    for i, variable in enumerate(model.variables):
        if not variable.dof.periodic and variable.dof.high <= 1.0:
            primitive = model.side_of(i).primitive
            if variable.dof.name in SURFACE_DIMENSION:  # a surface's t1 runs across its width, t2 along it
                lengths = [primitive.params[SURFACE_DIMENSION[variable.dof.name]]]
            else:
                lengths = [primitive.params.get(k, 0.0) for k in ("length", "height", "width")]
            scales[i] = max(max(lengths), 1.0)
    return scales


def feasible(problem: Problem, v: Array) -> bool:
    """Loops closed (to 1e-4 mm), spacings and turn limits kept. The closure is
    checked on the whole residual: the six the optimiser keeps at zero
    (`_to_six`) also vanish where a connector is turned half round, a loop
    closed the wrong way."""
    if closure_residual_mm(problem.model, problem.full(v)) > 1e-4:
        return False
    return not problem.has_limits() or bool(problem.limit_values(v).min() > -1e-6)


def end_of(low: Array, high: Array, i: int, x: Array) -> str | None:
    """The end of its range DoF i rests on at x ("min", "max"), within
    BOUND_TOLERANCE of the range; None inside it."""
    span = high[i] - low[i] if np.isfinite(high[i] - low[i]) else 1.0
    if np.isfinite(low[i]) and x[i] - low[i] <= BOUND_TOLERANCE * span:
        return "min"
    if np.isfinite(high[i]) and high[i] - x[i] <= BOUND_TOLERANCE * span:
        return "max"
    return None


def unbalanced_force(gradient: Array, constraint: Array, fitted: Array | None = None) -> Array:
    """The generalised force the constraints leave unbalanced: `gradient` less
    the combination of constraint forces (the rows of `constraint`, in the same
    variables) that cancels most of it over the DoFs `fitted` (all by default),
    by least squares."""
    columns = slice(None) if fitted is None else fitted
    multipliers = np.linalg.lstsq(constraint[:, columns].T, -gradient[columns], rcond=None)[0]
    force: Array = gradient + constraint.T @ multipliers
    return force


def closure_residual_mm(model: Model, x: Array) -> float:
    """Largest loop-closure error: position in mm, rotation entries as mm-equivalent
    (x ROTATION_LENGTH_MM, see fabhal.model)."""
    if not model.closures:
        return 0.0
    return float(np.abs(model.closure_residuals(x)).max())
