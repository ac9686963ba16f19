"""The settle's energy and its closed-form Hessian (fabhal/solve/energy.py)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from fabhal import api
from fabhal.meshes import mass_properties
from fabhal.model import Model
from fabhal.solve import _mass_table, _weight
from fabhal.solve.contacts import Pairs, _inside, contact_pairs, with_contacts
from fabhal.solve.energy import Energy
from fabhal.solve.forces import friction_slides
from fabhal.solve.steps import Problem, mm_per_unit, potential, with_friction
from tests.conftest import REPO
from tests.solve.test_contacts import MUG_BY_A_WALL

BASKET_ON_ONE_HANDLE = """\
environment ceiling = CeilingHook() at (0, 0, 1000)
basket = Basket()
connect basket.rod1 -- ceiling.hook
target basket.surface at (0, 0, 700)
"""


def test_gravitys_hessian_is_the_pendulums_stiffness(tmp_path: Path) -> None:
    """A basket hung by one handle turns about the handle's axis (the rod's spin
    in the hook). At rest its centre of mass is straight below that axis, at
    D = hypot(124.5, 151.5) = 196.09 mm (the handle at x 124.5, z 252 of the
    basket; the centre of mass at z 100.5). Turning by phi raises it as
    U = -w D cos(phi): U'' = w D at rest, per degree squared w D (pi / 180)^2 =
    0.4 kg x 9.81 / 1000 J/mm x 196.09 mm x 3.046e-4 = 2.344e-4 J. Tolerance
    1e-5 relative: the settle stops within 0.01 degrees (cos changes 1e-8) and
    the connector's second differences are good to ~1e-8."""
    program = tmp_path / "basket.fhl"
    program.write_text(BASKET_ON_ONE_HANDLE)
    result = api.solve(program)
    assert result.solution is not None
    model, x = result.solution.model, result.solution.x
    masses, centres = _mass_table(model)
    hessian = potential(model, masses, centres).hessian
    assert hessian is not None
    spin = next(i for i, v in enumerate(model.variables) if v.name == "basket.rod1.spin")
    mass_kg = mass_properties(model.parts[model.part_index("basket")].spec).mass_g / 1000.0
    expected = mass_kg * 9.81 / 1000.0 * np.hypot(124.5, 151.5) * np.radians(1.0) ** 2
    assert hessian(x)[spin, spin] == pytest.approx(expected, rel=1e-5)


def _numeric_jacobian(function, x: np.ndarray, per_mm: np.ndarray) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Central differences, 0.01 mm of motion per step: rounding in the exact
    gradients (their twists are differences themselves, ~1e-10) dominates
    below that, truncation above (the friction's 0.5 mm smoothing)."""
    columns = []
    for i in range(len(x)):
        step = np.zeros(len(x))
        step[i] = 1e-2 / per_mm[i]
        columns.append((function(x + step) - function(x - step)) / (2 * step[i]))
    return np.array(columns).T


@pytest.mark.parametrize(
    "program",
    [
        "clip_light_m",  # hooks, rings and a clip: DoFs on parent and child sides, two per side
        "reading_nook",  # deep, two loops (their DoFs off the tree), slides held by friction
        "toothbrush_holder",  # two loops through hemispheres and clips
    ],
)
def test_the_lagrangians_hessian_matches_differences_of_its_gradient(program: str) -> None:
    """Gravity plus friction on every slide (with an origin 2 mm away, so it is
    not at its kink), less random multipliers times the loops' six equations
    each, at step 1's configuration moved off by up to 0.2 mm: the closed
    form (gravity through `Model.load_hessian`, the loops through
    `Model.closure_hessian`) against central differences of the exact
    gradient g - J^T lambda. Tolerance 1e-4 of the largest entry, in mm of
    motion: the differences are good to ~1e-5 of it (their asymmetry)."""
    result = api.solve(REPO / "programs" / f"{program}.fhl", gravity=False)
    assert result.solution is not None
    model = result.solution.model
    per_mm = mm_per_unit(model)
    rng = np.random.default_rng(3)
    x = result.solution.x + rng.uniform(-0.2, 0.2, len(per_mm)) / per_mm
    masses, centres = _mass_table(model)
    weight = _weight(masses)
    energy = potential(model, masses, centres)
    slides = friction_slides(model)
    if slides:
        origin = x + 2.0 / per_mm
        energy = with_friction(model, energy, slides, np.full(len(slides), 0.3 * weight), origin)
    free = np.arange(len(x))
    problem = Problem(model, free, x.copy())
    multipliers = rng.normal(0.0, weight, 6 * len(model.closures))

    def lagrangian_gradient(u: np.ndarray) -> np.ndarray:
        constraints = problem.closure_jacobian(u) if model.closures else np.zeros((0, len(u)))
        return energy(u)[1] - constraints.T @ multipliers

    hessian = problem.free_hessian(energy)
    assert hessian is not None
    in_mm = 1.0 / np.outer(per_mm, per_mm)
    exact = hessian(x, multipliers)
    assert exact is not None
    numeric = _numeric_jacobian(lagrangian_gradient, x, per_mm) * in_mm
    np.testing.assert_allclose(exact * in_mm, numeric, atol=1e-4 * np.abs(numeric).max())
    np.testing.assert_allclose(exact, exact.T, atol=1e-12 * np.abs(exact).max())


@dataclass(frozen=True)
class MugByTheWall:
    """The mug resting against the wall, solved: where it rests, swung
    towards the wall until a settle point presses (`x`), swung
    30 degrees off the wall (`away`: nothing touches), gravity's energy and
    it with the springs against the environment (`pairs`)."""

    model: Model
    x: np.ndarray
    away: np.ndarray
    pairs: Pairs
    gravity: Energy
    energy: Energy


def mug_by_the_wall(tmp_path: Path) -> MugByTheWall:
    program = tmp_path / "mug.fhl"
    program.write_text(MUG_BY_A_WALL)
    result = api.solve(program)
    assert result.solution is not None and result.solution.contacts
    model, rest = result.solution.model, result.solution.x
    masses, centres = _mass_table(model)
    world = contact_pairs(model).against({i for i, part in enumerate(model.parts) if part.environment})
    gravity = potential(model, masses, centres)
    spin = next(i for i, v in enumerate(model.variables) if v.name == "rod.rod.spin")
    off_the_wall = 1.0 if result.solution.frames[model.part_index("mug")][1, 3] < 0 else -1.0
    away = rest.copy()
    away[spin] += 30.0 * off_the_wall
    # it rests on its rim's corner, which the check's finer points found between the settle's
    # own: swung towards the wall (by tenths of a degree) until one of those presses too
    x = next(
        at
        for at in (rest - np.eye(len(rest))[spin] * off_the_wall * tenth / 10.0 for tenth in range(51))
        if len(_inside(model, model.forward(at), world).depth)
    )
    return MugByTheWall(model, x, away, world, gravity, with_contacts(model, gravity, world, _weight(masses)))


def test_while_a_spring_touches_the_hessian_is_measured(tmp_path: Path) -> None:
    """The mug rests against the wall: a point inside it, whose obstacle's
    curvature only the distance grid knows, so no closed form is given there
    (the optimiser differences); swung 30 degrees off the wall, none touches
    and the springs add nothing to gravity's."""
    mug = mug_by_the_wall(tmp_path)
    energy, gravity = mug.energy, mug.gravity
    assert energy.hessian is not None and gravity.hessian is not None
    assert energy.hessian(mug.x) is None
    assert not len(_inside(mug.model, mug.model.forward(mug.away), mug.pairs).depth)
    np.testing.assert_array_equal(energy.hessian(mug.away), gravity.hessian(mug.away))


def test_what_a_touching_spring_nearly_knows_is_exact_on_a_flat_wall(tmp_path: Path) -> None:
    """The mug resting against the wall again: the Hessian the aim and BFGS's
    start use there (`Energy.nearly`: each point's k (dd/dx)^T (dd/dx) and
    its push held as a load, leaving out only the obstacle's curvature under
    the point) is the springs' whole Hessian on a flat face, whose distance
    is linear (the smooth reading reproduces it exactly): it matches central
    differences of the exact gradient as gravity's does, to 1e-4 of the
    largest entry (the differences' own error; the springs' stiffness makes
    the entries large), and it is gravity's own where no spring touches."""
    mug = mug_by_the_wall(tmp_path)
    energy, gravity = mug.energy, mug.gravity
    assert energy.nearly is not None and gravity.hessian is not None
    numeric = _numeric_jacobian(lambda at: energy(at)[1], mug.x, mm_per_unit(mug.model))
    nearly = energy.nearly(mug.x)
    assert not np.allclose(nearly, gravity.hessian(mug.x))  # the springs count
    np.testing.assert_allclose(nearly, numeric, atol=1e-4 * np.abs(numeric).max())
    np.testing.assert_array_equal(energy.nearly(mug.away), gravity.hessian(mug.away))


def test_a_sum_knows_its_hessian_only_when_every_term_does() -> None:
    """A term without a closed form (the pull towards the target), or one
    without it at some x (a touching spring): the sum has none there, and the
    optimiser differences the gradient instead."""
    quadratic = Energy(lambda x: (float(x @ x), 2 * x), lambda x: 2 * np.eye(len(x)))
    nowhere = Energy(lambda x: (0.0, x), lambda x: None)
    unknown = Energy(lambda x: (float(x @ x), 2 * x))
    x = np.ones(3)
    assert quadratic.plus(lambda u: (0.0, u), lambda u: np.eye(len(u))).hessian is not None
    assert quadratic.plus(lambda u: (0.0, u), lambda u: np.eye(len(u))).hessian(x)[0, 0] == 3.0  # type: ignore[misc]
    assert unknown.plus(lambda u: (0.0, u), lambda u: np.eye(len(u))).hessian is None
    assert quadratic.plus(lambda u: (0.0, u), None).hessian is None
    assert nowhere.plus(lambda u: (0.0, u), lambda u: np.eye(len(u))).hessian(x) is None  # type: ignore[misc]
    # what they nearly know: a term's own where it has none exact everywhere, else its exact one
    spring = nowhere.plus(lambda u: (0.0, u), lambda u: None, lambda u: 5 * np.eye(len(u)))
    assert spring.nearly is None  # `nowhere` knows nothing nearly
    near = Energy(quadratic.value_and_gradient, quadratic.hessian, quadratic.hessian)  # type: ignore[arg-type]
    assert near.plus(lambda u: (0.0, u), lambda u: None, lambda u: 5 * np.eye(len(u))).nearly(x)[0, 0] == 7.0  # type: ignore[misc]
    assert near.plus(lambda u: (0.0, u), lambda u: np.eye(len(u))).nearly(x)[0, 0] == 3.0  # type: ignore[misc]
