"""The potential that settling minimises, with its Hessian where it is known.

The optimiser needs the energy's value and gradient at every point; its
Hessian only now and then (the start of BFGS, the stability test, aiming),
and measuring that by differences costs a gradient per DoF: O(n^2) for a
chain of n parts. Each term that knows its Hessian in closed form carries it
(gravity through `Model.load_hessian`, friction exactly); a sum knows it only
where every term does, and elsewhere the optimiser differences as before.
A contact spring touching an obstacle knows its Hessian only in part (the
obstacle's curvature under the point is the distance grid's, which a
difference measures and a closed form would leave out: the diaper caddy's
hooks rest on the seat backs' rounded tops), so while a spring touches, the
Hessian is measured.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from fabhal.kinematics.frames import Array

ValueAndGradient = Callable[[Array], tuple[float, Array]]


@dataclass(frozen=True)
class Energy:
    """A potential over the whole DoF vector x: `energy(x)` is its value
    (joules) and gradient (joules per unit of each DoF); `hessian(x)` its
    second derivative (n_dofs, n_dofs), or None at an x where no closed form
    holds; `hessian` itself is None when none ever does."""

    value_and_gradient: ValueAndGradient
    hessian: Callable[[Array], Array | None] | None = None

    def __call__(self, x: Array) -> tuple[float, Array]:
        return self.value_and_gradient(x)

    def plus(
        self, value_and_gradient: ValueAndGradient, hessian: Callable[[Array], Array | None] | None
    ) -> Energy:
        """The energy `value_and_gradient` (which includes this one's value and
        gradient), with this one's Hessian plus `hessian`: known only where both are."""
        own = self.hessian
        if own is None or hessian is None:
            return Energy(value_and_gradient)

        def total(x: Array) -> Array | None:
            mine, theirs = own(x), hessian(x)
            return None if mine is None or theirs is None else mine + theirs

        return Energy(value_and_gradient, total)
