"""A start for step 1 with loops that hangs the way the hack will: the loops
closed round the target held at its frame, from the parts hanging under
gravity.

Closing many loops from the DoFs' defaults (the check's closure, a random
point) finds some closed configuration, often a crumpled one: a hoop hung by
twelve chains of S-hooks came out with the hoop up among the ceiling hooks and
the chains folded round it, 140 mm from its request, and the target fit keeps
the loops closed at every step on its long way out (a hoop on three chains
from ceiling hooks turned a quarter turn: 4.2 s of fits, settles and retries
from such a start; 0.3 s hung). A builder hangs the chains first, holds the
target where it should
be and hooks the chains on. So: (1) the spanning tree settles under gravity,
loops open (every chain hangs straight from where it is hooked); (2) the
turning DoFs on the target's path are each set to the best of SCAN_STEPS
values for the target's error, then the tree alone brings the target to its
frame (the chain that carries it in the tree reaches up or down); (3) each
loop's turning DoFs (where on a ring its chain hooks on) are set to the best
of SCAN_STEPS for the loop's gap, then least squares on the loops' gaps and
the target's error together (each cut chain reaches the held target); (4) the
loops closed exactly from that point. Every stage is a few dozen Gauss-Newton
or BFGS steps over the free DoFs, or a few hundred forward passes (0.2 s for
the hoop's 108 DoFs).

It is a start only where it reaches the target (GOOD_FIT), and is not closed
where the tree alone, after (2), does not (the loops only constrain it more):
where nothing reaches the request, the closure from the defaults is as good a start as any,
and hung, the reading nook's balanced loops settle elsewhere (33 degrees from
the request instead of 19).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from fabhal.check.cycles import close_loops
from fabhal.kinematics.frames import Array
from fabhal.model import Model
from fabhal.optimize import least_squares_objective, minimize
from fabhal.solve import target as target_mod
from fabhal.solve.energy import Energy
from fabhal.solve.steps import GOOD_FIT, Rows

HANG_ITERATIONS = 300  # of the tree settling under gravity (the hoop's 12 chains: 67)
REACH_EVALUATIONS = 200  # of each least-squares stage
SCAN_STEPS = 24  # values tried for a turning DoF (15 degrees apart): see _scanned
HUNG_AT_REST = 1e-7  # joules per mm: the tree has hung once no force along a DoF is larger


def hanging_start(
    model: Model,
    x0: Array,
    free: Array,
    gravity: Energy,
    goal: target_mod.TargetGoal,
    scale: Array,
    seed: int,
    deadline: float,
) -> Array | None:
    """The free DoFs of `x0` hung, reached and closed as the module says (pinned
    DoFs keep their values); None where the loops do not close exactly from
    there or the target ends more than GOOD_FIT from its request. `gravity`:
    the potential energy; `scale`: mm of motion per unit of each free DoF."""
    low, high = (bounds[free] for bounds in model.bounds())

    def full(v: Array) -> Array:
        x = x0.copy()
        x[free] = v
        return x

    def energy(v: Array) -> tuple[float, Array, None]:
        value, gradient = gravity(full(v))
        return value, gradient[free], None

    def target_rows(v: Array) -> tuple[Array, Array]:
        fwd = model.forward(full(v), with_twists=True)
        residual = target_mod.residual(goal, target_mod.achieved(goal, fwd.frames))
        return residual, target_mod.residual_jacobian(goal, model, fwd)[:, free]

    def with_closure_rows(v: Array) -> tuple[Array, Array]:
        x = full(v)
        residual, jacobian = target_rows(v)
        return (
            np.concatenate([model.closure_residuals(x), residual]),
            np.vstack([model.closure_jacobian(x)[:, free], jacobian]),
        )

    hung = minimize(
        energy, x0[free], low, high, scale=scale, max_iterations=HANG_ITERATIONS, gtol=HUNG_AT_REST,
        deadline=deadline,
    ).x  # fmt: skip
    turning = {int(i) for i in free if model.variables[i].dof.periodic}
    moves_target = np.abs(target_rows(hung)[1]).max(axis=0) > 0.0
    on_the_path = [int(i) for i, moves in zip(free, moves_target, strict=True) if moves and int(i) in turning]
    x = _scanned(full(hung), on_the_path, lambda x: float(np.linalg.norm(_target_residual(model, goal, x))))

    def reaches(x: Array) -> bool:
        """Whether the target at x is within GOOD_FIT of its request."""
        return float(np.linalg.norm(_target_residual(model, goal, x))) <= GOOD_FIT

    x = full(_least_squares(target_rows, x[free], low, high, scale, deadline))
    if not reaches(x):
        # the tree alone does not bring the target to its frame from here: closing the
        # loops, which only constrains it more, does not either (the reading nook: 0.1 s)
        return None
    for k, j in enumerate(model.closures):
        closing = model.joints[j]
        turns = [i for i in closing.a.dof_indices + closing.b.dof_indices if i in turning]
        x = _scanned(x, turns, partial(_position_gap, model, loop=k))
    x = full(_least_squares(with_closure_rows, x[free], low, high, scale, deadline))
    closed = close_loops(model, seed, starts=1, x0=x, evaluations=REACH_EVALUATIONS, deadline=deadline)
    if not closed.closed:
        return None
    return closed.x if reaches(closed.x) else None


def _scanned(x: Array, dofs: list[int], cost: Callable[[Array], float]) -> Array:
    """`x` with each of `dofs` in turn (turning DoFs) at the best of SCAN_STEPS
    values for `cost`: from where the parts hang, a least squares would turn
    the wrong way round a ring or a wire and drag the rest with it (a hoop
    hanging from one chain tipped level by sliding along the hook, not by
    turning about its tube; a loop's chain dragged round the hoop to where it
    hooks on)."""
    x = x.copy()
    turns = np.linspace(0.0, 360.0, SCAN_STEPS, endpoint=False)
    for i in dofs:
        costs = []
        for turn in turns:
            x[i] = turn
            costs.append(cost(x))
        x[i] = turns[int(np.argmin(costs))]
    return x


def _target_residual(model: Model, goal: target_mod.TargetGoal, x: Array) -> Array:
    return target_mod.residual(goal, target_mod.achieved(goal, model.part_frames(x)))


def _position_gap(model: Model, x: Array, *, loop: int) -> float:
    """How far apart the closing connection's two sides are (mm): how the chain
    is turned there the least squares mends."""
    return float(np.linalg.norm(model.closure_errors(x)[loop, :3, 3]))


def _least_squares(rows: Rows, v: Array, low: Array, high: Array, scale: Array, deadline: float) -> Array:
    return minimize(
        least_squares_objective(rows), v, low, high, scale=scale, max_evaluations=REACH_EVALUATIONS,
        deadline=deadline,
    ).x  # fmt: skip
