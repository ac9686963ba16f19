"""A start for step 1 with loops that hangs the way the hack will: the loops
closed round the target held at its frame, from the parts hanging under
gravity.

Closing many loops from the DoFs' defaults (the check's closure, a random
point) finds some closed configuration, often a crumpled one: a hoop hung by
twelve chains of S-hooks came out with the hoop up among the ceiling hooks and
the chains folded round it, and the target fit, which keeps the loops closed
at every step, cannot unfold it (a closed path out of a tangle need not exist
near it). A builder hangs the chains first, holds the target where it should
be and hooks the chains on. So: (1) the spanning tree settles under gravity,
loops open (every chain hangs straight from where it is hooked); (2) the tree
alone brings the target to its frame (the chain that carries it in the tree
reaches up or down); (3) least squares on the loops' gaps and the target's
error together, from there (each cut chain reaches the held target; the
target may give where the loops cannot close at its frame); (4) the loops
closed exactly from that point. Every stage is a few dozen Gauss-Newton or
BFGS steps over the free DoFs (0.2 s for the hoop's 108).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fabhal.check.cycles import close_loops
from fabhal.kinematics.frames import Array
from fabhal.model import Model
from fabhal.optimize import least_squares_objective, minimize
from fabhal.solve import target as target_mod
from fabhal.solve.energy import Energy

HANG_ITERATIONS = 300  # of the tree settling under gravity (the hoop's 12 chains: 67)
REACH_EVALUATIONS = 200  # of each least-squares stage
SCAN_STEPS = 24  # values tried for where on a ring a loop's chain hooks on (15 degrees apart)
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
    there. `gravity`: the potential energy; `scale`: mm of motion per unit of
    each free DoF."""
    low, high = (bounds[free] for bounds in model.bounds())

    def full(v: Array, base: Array) -> Array:
        x = base.copy()
        x[free] = v
        return x

    def energy(v: Array) -> tuple[float, Array, None]:
        value, gradient = gravity(full(v, x0))
        return value, gradient[free], None

    hung = minimize(
        energy, x0[free], low, high, scale=scale, max_iterations=HANG_ITERATIONS, gtol=HUNG_AT_REST,
        deadline=deadline,
    ).x  # fmt: skip
    start = full(hung, x0)

    def target_rows(v: Array) -> tuple[Array, Array]:
        fwd = model.forward(full(v, start), with_twists=True)
        residual = target_mod.residual(goal, target_mod.achieved(goal, fwd.frames))
        return residual, target_mod.residual_jacobian(goal, model, fwd)[:, free]

    def with_closure_rows(v: Array) -> tuple[Array, Array]:
        x = full(v, start)
        residual, jacobian = target_rows(v)
        return (
            np.concatenate([model.closure_residuals(x), residual]),
            np.vstack([model.closure_jacobian(x)[:, free], jacobian]),
        )

    v = _least_squares(target_rows, hung, low, high, scale, deadline)
    start = _turned_to_close(model, full(v, start), set(free.tolist()))
    v = _least_squares(with_closure_rows, start[free], low, high, scale, deadline)
    closing = close_loops(
        model, seed, starts=1, x0=full(v, start), evaluations=REACH_EVALUATIONS, deadline=deadline
    )
    return closing.x if closing.closed else None


def _turned_to_close(model: Model, x: Array, free: set[int]) -> Array:
    """`x` with each free turning DoF of a loop's closing connection (where on a
    ring a chain hooks on) at the best of SCAN_STEPS values for its loop's gap:
    from the default, the least squares would drag the contact round the ring,
    the chain with it."""
    x = x.copy()
    turns = np.linspace(0.0, 360.0, SCAN_STEPS, endpoint=False)
    for k, j in enumerate(model.closures):
        joint = model.joints[j]
        for i in joint.a.dof_indices + joint.b.dof_indices:
            if i not in free or not model.variables[i].dof.periodic:
                continue
            gaps = []
            for turn in turns:
                x[i] = turn
                gaps.append(float(np.linalg.norm(model.closure_residuals(x)[12 * k : 12 * k + 12])))
            x[i] = turns[int(np.argmin(gaps))]
    return x


Rows = Callable[[Array], tuple[Array, Array]]


def _least_squares(rows: Rows, v: Array, low: Array, high: Array, scale: Array, deadline: float) -> Array:
    return minimize(
        least_squares_objective(rows), v, low, high, scale=scale, max_evaluations=REACH_EVALUATIONS,
        deadline=deadline,
    ).x  # fmt: skip
