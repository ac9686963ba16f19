"""Statics of an assembly of rigid parts: the force each connection carries.

Pure numpy over arrays. Each connection j transmits a wrench from its part a
to its part b: a force f_j (N) and a moment m_j (N mm) about its contact point
p_j. Each movable part balances its weight with the wrenches of its
connections (6 equations: forces, and moments about its centre of mass), and a
connection transmits nothing along a motion it leaves free (one equation per
free degree of freedom: the wrench does no work on its twist). Where the
equations leave the wrenches undetermined (a part held at two points: a
statically indeterminate loop) the smallest wrenches are taken (least squares,
moments counted per MOMENT_ARM_MM): the answer then depends neither on the order
of the equations nor on that of the unknowns, so not on the order of a
program's lines. What a loop may add to them (its own force states) is given
too, with how much of each: where a loop is nearly singular (chains hanging
straight side by side) a state that almost balances itself may be added as far
as the parts stay at rest, and the wrenches given are the smallest within that
(what such states carry of the exact ones taken off: the chains share evenly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fabhal.kinematics.frames import Array

# moments enter the least squares divided by this lever arm (mm): the size of an
# everyday part, so a newton and a newton-decimetre weigh alike
MOMENT_ARM_MM = 100.0
# minimum norm by the SVD (numpy's: importing scipy.linalg for its cheaper
# orthogonal factorisation cost every process 0.33 s, more than the solves);
# directions below this fraction of the largest are the loop's own
# (indeterminate) forces: left out, not amplified. Rounding gives them ~1e-12,
# and at that size a settled state's 1e-5 imbalance became 300 kN in a loop
SINGULAR = 1e-8
# from this many unknowns (6 per connection) a system of full column rank (a tree:
# each part hangs by one connection) is solved by its normal equations: numpy's SVD
# least squares took 74 ms at 600 unknowns (a chain of 100 S-hooks, 12 times a
# solve), the sparse normal equations about 5; smaller systems keep the SVD
NORMAL_EQUATIONS_UNKNOWNS = 300
# a direction is one of a loop's own force states where this fraction of the total
# load along it unbalances the parts by no more than the `slack` a state at rest
# keeps (twelve chains hanging straight from a hoop: 4e-4 to 1.4e-3 N per N, the
# next 0.30; a mug's handle on a rod and on an S-hook: 0.028, a real stiffness)
OWN_REACH = 0.1


@dataclass(frozen=True)
class Wrenches:
    forces: Array  # (J, 3) N, what part a exerts on part b, world axes
    moments: Array  # (J, 3) N mm about each connection's contact point
    imbalance: float  # largest unbalanced force (N, moments per MOMENT_ARM_MM) over all parts
    unbalanced: Array  # (P, 2) per part: the force (N) and the moment (N mm) left over (0 for environments)
    # (K, J, 3) N: the forces of a loop's own force states (balanced by themselves, or
    # nearly: see `reach`), which the smallest wrenches leave out
    indeterminate: Array
    # (K,) N: how much of each state may be added (either sign) with the parts still
    # balanced within `slack` (inf where it balances itself exactly); added together,
    # the amounts over their reaches have at most unit norm (`pressing`)
    reach: Array
    # (K,) N: how much of each state `forces` has had taken off the smallest wrenches
    # (what the nearly own states carried of them), counted against the reach
    taken: Array


def _skew(r: Array) -> Array:
    """(..., 3) -> (..., 3, 3) with skew(r) @ f = r x f."""
    out = np.zeros((*r.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -r[..., 2], r[..., 1]
    out[..., 1, 0], out[..., 1, 2] = r[..., 2], -r[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -r[..., 1], r[..., 0]
    return out


def joint_wrenches(
    part_a: Array,
    part_b: Array,
    points: Array,
    movable: Array,
    loads: Array,
    centres: Array,
    free_joint: Array,
    free_velocity: Array,
    free_rotation: Array,
    load_moments: Array | None = None,
    force_only: Array | None = None,
    slack: float = 0.0,
) -> Wrenches:
    """The wrenches that hold every movable part in balance.

    part_a, part_b: (J,) part indices of each connection; points: (J, 3) its
    contact point (mm, world); movable: (P,) whether a part's balance is
    written (not for environments); loads: (P, 3) the force of gravity on each
    part (N) at centres: (P, 3) its centre of mass (mm, world); free_joint: (F,)
    the connection of each free motion, free_velocity (F, 3) the velocity of b
    against a at the contact point (mm per unit) and free_rotation (F, 3) its
    angular velocity (rad per unit); load_moments: (P, 3) N mm about each
    part's centre of mass, of loads that do not act there (contacts);
    force_only: (J,) the connections that touch at a point and can carry no
    moment (a ball on a floor): their moments are 0, and where the rest
    cannot balance a part without them, `unbalanced` says by how much;
    slack: the imbalance (N) a state may keep and still be at rest, which
    makes a direction along which a part of the load (`OWN_REACH`)
    unbalances the parts by no more than that one of a loop's own states,
    and `reach` says how much of each may be added. Twelve chains hanging
    straight from a hoop share its weight in any way, but their last kinks
    make the equations just determinate, and the smallest wrenches are the
    settle's leftover 2e-4 N amplified up to 2,500 times: one chain pushing
    the hoop down, another carrying three times its share."""
    n_joints, n_parts = len(part_a), len(movable)
    row_of = np.full(n_parts, -1)
    row_of[movable] = np.arange(int(movable.sum()))
    n_balance = 6 * int(movable.sum())
    matrix = np.zeros((n_balance + len(free_joint), 6 * n_joints))
    rhs = np.zeros(n_balance + len(free_joint))
    for parts, sign in ((part_b, 1.0), (part_a, -1.0)):
        for j in np.flatnonzero(row_of[parts] >= 0):
            r, c = 6 * row_of[parts[j]], 6 * j
            arm = (points[j] - centres[parts[j]]) / MOMENT_ARM_MM
            matrix[r : r + 3, c : c + 3] += sign * np.eye(3)
            matrix[r + 3 : r + 6, c : c + 3] += sign * _skew(arm)
            matrix[r + 3 : r + 6, c + 3 : c + 6] += sign * np.eye(3)
    placed = np.flatnonzero(movable)
    rhs[:n_balance].reshape(-1, 6)[:, :3] = -loads[placed]
    if load_moments is not None:
        rhs[:n_balance].reshape(-1, 6)[:, 3:] = -load_moments[placed] / MOMENT_ARM_MM
    # no work along a free motion: f . v + m . w = 0, with m = MOMENT_ARM_MM x the unknown
    rows = np.hstack([free_velocity, MOMENT_ARM_MM * free_rotation])
    norms = np.linalg.norm(rows, axis=1, keepdims=True)
    rows = rows / np.where(norms > 0.0, norms, 1.0)
    for k, j in enumerate(free_joint):
        matrix[n_balance + k, 6 * j : 6 * j + 6] = rows[k]
    if force_only is not None:
        for j in np.flatnonzero(force_only):
            matrix[:, 6 * j + 3 : 6 * j + 6] = 0.0  # no moment unknowns: the least squares leaves them 0
    total = float(np.linalg.norm(loads[movable], axis=1).sum())
    near = slack / (OWN_REACH * total) if total > 0.0 else 0.0
    tree = n_joints <= int(movable.sum())
    solution, own, reach = _least_squares(matrix, rhs, near, slack, tree)
    # the smallest wrenches within the slack: what the nearly own states carry of them taken off, as far
    # as their reach allows (twelve straight chains then share a hoop evenly)
    finite = np.isfinite(reach)
    taken = np.zeros(len(own))
    taken[finite] = own[finite] @ solution
    taken /= max(1.0, float(np.linalg.norm(taken[finite] / reach[finite])))
    solution = solution - taken @ own
    wrenches = solution.reshape(n_joints, 6)
    residual = np.abs(matrix @ solution - rhs) if len(rhs) else np.zeros(0)
    per_part = residual[:n_balance].reshape(-1, 2, 3)
    unbalanced = np.zeros((n_parts, 2))
    unbalanced[placed] = np.linalg.norm(per_part, axis=2) * (1.0, MOMENT_ARM_MM)
    imbalance = float(residual.max(initial=0.0))
    own_forces = own.reshape(len(own), n_joints, 6)[:, :, :3]
    return Wrenches(
        wrenches[:, :3], wrenches[:, 3:] * MOMENT_ARM_MM, imbalance, unbalanced, own_forces, reach, taken
    )


def _least_squares(
    matrix: Array, rhs: Array, near: float, slack: float, tree: bool
) -> tuple[Array, Array, Array]:
    """The minimum-norm least-squares solution (SVD, directions below SINGULAR left
    out); the directions (K, unknowns) among the used unknowns whose singular
    value is below SINGULAR of the largest or `near`: the loop's own force
    states; and how much of each leaves the parts unbalanced by `slack`
    (slack / its singular value; inf for the exact ones). A `tree`
    (each part hangs by one connection: no loop, so no states) of many
    unknowns is solved by the normal equations, the same solution to rounding
    (their Cholesky pivots, the singular values' scale, all above SINGULAR of
    the largest). Unknowns no equation uses (the moments of a connection that
    carries none) are 0, as the minimum norm has them. The solution is
    LAPACK's least squares (gelsd), not the directions' SVD: where a singular
    value lies near SINGULAR the two round it differently, and three mugs on one
    rod (a nearly singular leaning loop) settled elsewhere."""
    n = matrix.shape[1]
    none = np.zeros((0, n)), np.zeros(0)
    if not matrix.size:
        return np.zeros(n), *none
    if tree and n >= NORMAL_EQUATIONS_UNKNOWNS:
        used = np.flatnonzero(np.any(matrix != 0.0, axis=0))
        solved = _normal_equations(matrix[:, used], rhs)
        if solved is not None:
            solution = np.zeros(n)
            solution[used] = solved
            return solution, *none
    solution = np.asarray(np.linalg.lstsq(matrix, rhs, rcond=SINGULAR)[0], dtype=float)
    return solution, *_own_states(matrix, near, slack)


def _own_states(matrix: Array, near: float, slack: float) -> tuple[Array, Array]:
    """(K, unknowns) an orthonormal basis of the directions the equations leave
    free or nearly (singular values below SINGULAR of the largest, or below
    `near`), among the unknowns some equation uses; (K,) slack / their
    singular values, inf for those below SINGULAR (free)."""
    used = np.flatnonzero(np.any(matrix != 0.0, axis=0))
    if not len(used):
        return np.zeros((0, matrix.shape[1])), np.zeros(0)
    values, right = np.linalg.svd(matrix[:, used], full_matrices=matrix.shape[0] < len(used))[1:]
    values = np.concatenate([values, np.zeros(len(used) - len(values))])  # more unknowns than equations
    free = values <= SINGULAR * values.max()
    kept = free | (values <= near)
    own = np.zeros((int(kept.sum()), matrix.shape[1]))
    own[:, used] = right[kept]
    reach = np.full(len(own), np.inf)
    nearly = ~free[kept]
    reach[nearly] = slack / values[kept][nearly]
    return own, reach


def pressing(normal: Array, own: Array, reach: Array | None = None, taken: Array | None = None) -> Array:
    """The contacts' normal forces (M,) made as nearly all pressing (>= 0) as
    a loop's own force states allow: own (K, M) is what each adds to them, in
    any multiple up to its `reach` (K,), either sign (no limit where None):
    the amounts over their reaches have at most unit norm (what they leave
    unbalanced adds up to at most the slack the reaches were made for; the
    states are orthogonal), counting what was `taken` off already. Least
    squares of the shortfalls (min(0, force)^2, summed), convex and
    piecewise quadratic: Newton's step on the contacts short each time,
    scaled back into the reach (a few steps; the loops are few)."""
    limit = np.full(len(own), np.inf) if reach is None else reach
    already = np.zeros(len(own)) if taken is None else -taken
    combination = np.zeros(len(own))
    for _ in range(PRESSING_STEPS):
        forces = normal + combination @ own
        short = forces < 0.0
        if not short.any() or not len(own):
            return forces
        rows = own[:, short]
        gram = rows @ rows.T
        step = np.linalg.lstsq(gram, -(rows @ forces[short]), rcond=SINGULAR)[0]
        if np.abs(step).max(initial=0.0) < 1e-12:
            break
        total = already + combination + step
        combination = total / max(1.0, float(np.linalg.norm(total / limit))) - already
    return normal + combination @ own


PRESSING_STEPS = 20


def _normal_equations(matrix: Array, rhs: Array) -> Array | None:
    """min |A w - b| by the Cholesky factor of A^T A, formed sparsely (a part's
    balance touches only its own connections); None where A has a direction
    below SINGULAR (a loop's own forces): the SVD's minimum norm decides there."""
    from scipy import sparse  # imported only for large systems: NORMAL_EQUATIONS_UNKNOWNS
    from scipy.linalg import cho_solve

    sparse_matrix = sparse.csr_matrix(matrix)
    gram = (sparse_matrix.T @ sparse_matrix).toarray()
    try:
        factor = np.linalg.cholesky(gram)
    except np.linalg.LinAlgError:
        return None
    pivots = np.abs(np.diag(factor))
    if pivots.min() < SINGULAR * pivots.max():
        return None
    return np.asarray(cho_solve((factor, True), sparse_matrix.T @ rhs), dtype=float)
