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
Hessian is measured where it must be exact (the stability test), and the
part it knows (`Energy.nearly`, within 7e-4 of the differences on the caddy)
serves the aim's derivatives and BFGS's start.
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
    holds; `hessian` itself is None when none ever does. `nearly(x)`: a
    second derivative at every x, exact where `hessian` is and close where
    it is not (a contact spring's but for the obstacle's curvature), for
    derivatives that need not be exact (the aim's, BFGS's start); None where
    a term has none."""

    value_and_gradient: ValueAndGradient
    hessian: Callable[[Array], Array | None] | None = None
    nearly: Callable[[Array], Array] | None = None

    def __call__(self, x: Array) -> tuple[float, Array]:
        return self.value_and_gradient(x)

    def plus(
        self,
        value_and_gradient: ValueAndGradient,
        hessian: Callable[[Array], Array | None] | None,
        nearly: Callable[[Array], Array] | None = None,
    ) -> Energy:
        """The energy `value_and_gradient` (which includes this one's value and
        gradient), with this one's Hessian plus `hessian`: known only where both
        are; and this one's `nearly` plus the term's (`nearly`: given where its
        `hessian` is not known everywhere, else that)."""
        own, own_nearly = self.hessian, self.nearly
        theirs_nearly = nearly if nearly is not None else hessian
        total_nearly: Callable[[Array], Array] | None = None
        if own_nearly is not None and theirs_nearly is not None:

            def total_nearly(x: Array) -> Array:
                theirs = theirs_nearly(x)
                assert theirs is not None  # a term whose Hessian may be unknown gives `nearly`
                return own_nearly(x) + theirs

        if own is None or hessian is None:
            return Energy(value_and_gradient, None, total_nearly)

        def total(x: Array) -> Array | None:
            mine, theirs = own(x), hessian(x)
            return None if mine is None or theirs is None else mine + theirs

        return Energy(value_and_gradient, total, total_nearly)
