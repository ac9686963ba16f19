"""The potential that settling minimises, with its Hessian where it is known.

The optimiser needs the energy's value and gradient at every point; its
Hessian only now and then (the start of BFGS, the stability test, aiming),
and measuring that by differences costs a gradient per DoF: O(n^2) for a
chain of n parts. Each term that knows its Hessian in closed form carries it
(gravity and the contacts' constant-direction forces through
`Model.load_hessian`, the contacts' springs as Gauss-Newton, friction
exactly); a sum knows it only when every term does, and without it the
optimiser differences as before.
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
    second derivative (n_dofs, n_dofs), None when no closed form is known."""

    value_and_gradient: ValueAndGradient
    hessian: Callable[[Array], Array] | None = None

    def __call__(self, x: Array) -> tuple[float, Array]:
        return self.value_and_gradient(x)

    def plus(self, value_and_gradient: ValueAndGradient, hessian: Callable[[Array], Array] | None) -> Energy:
        """The energy `value_and_gradient` (which includes this one's value and
        gradient), with this one's Hessian plus `hessian`: known only if both are."""
        own = self.hessian
        if own is None or hessian is None:
            return Energy(value_and_gradient)
        return Energy(value_and_gradient, lambda x: own(x) + hessian(x))
