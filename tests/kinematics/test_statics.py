"""The statics kernel on assemblies whose forces follow by hand."""

from __future__ import annotations

import numpy as np

from fabhal.kinematics.statics import joint_wrenches

NONE = np.zeros(0, dtype=int)
NO_MOTION = np.zeros((0, 3))


def test_a_chain_carries_everything_below_each_link() -> None:
    """Environment 0; part 1 hangs from it at (0, 0, 100), part 2 from part 1 at
    (0, 0, 50); weights 2 N and 3 N, centres straight below their supports.
    By hand: the upper connection carries 2 + 3 = 5 N, the lower 3 N, both
    straight down (what a exerts on b: the environment's side is b here, so the
    part pulls it down), no moments. Tolerance 1e-9 N: a least-squares solve
    of a small, well-conditioned system."""
    wrenches = joint_wrenches(
        part_a=np.array([1, 2]),
        part_b=np.array([0, 1]),
        points=np.array([[0.0, 0.0, 100.0], [0.0, 0.0, 50.0]]),
        movable=np.array([False, True, True]),
        loads=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -2.0], [0.0, 0.0, -3.0]]),
        centres=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 70.0], [0.0, 0.0, 20.0]]),
        free_joint=NONE,
        free_velocity=NO_MOTION,
        free_rotation=NO_MOTION,
    )
    np.testing.assert_allclose(wrenches.forces, [[0, 0, -5], [0, 0, -3]], atol=1e-9)
    np.testing.assert_allclose(wrenches.moments, 0.0, atol=1e-9)
    assert wrenches.imbalance < 1e-9


def test_a_bar_on_two_pivots_shares_its_weight_by_the_lever_rule() -> None:
    """A 10 N bar from x = -100 to x = 300 (centre at x = 100) rests on pivots at
    x = 0 and x = 200, each free to turn about y (a free motion: no moment about
    y). By hand, moments about the left pivot: F_right x 200 = 10 x 100, so 5 N
    each; with the centre at x = 150 instead: F_right = 7.5 N, F_left = 2.5 N.
    The pivots' other reactions are indeterminate; the smallest are taken
    (zero). Tolerance 1e-9 N."""
    for centre, expected in ((100.0, (5.0, 5.0)), (150.0, (2.5, 7.5))):
        wrenches = joint_wrenches(
            part_a=np.array([0, 0]),
            part_b=np.array([1, 1]),
            points=np.array([[0.0, 0.0, 0.0], [200.0, 0.0, 0.0]]),
            movable=np.array([False, True]),
            loads=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -10.0]]),
            centres=np.array([[0.0, 0.0, 0.0], [centre, 0.0, 0.0]]),
            free_joint=np.array([0, 1]),
            free_velocity=np.zeros((2, 3)),
            free_rotation=np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]]),
        )
        np.testing.assert_allclose(wrenches.forces[:, 2], expected, atol=1e-9)
        np.testing.assert_allclose(wrenches.forces[:, :2], 0.0, atol=1e-9)
        np.testing.assert_allclose(wrenches.moments[:, 1], 0.0, atol=1e-9)


def test_the_forces_do_not_depend_on_the_order_of_the_connections() -> None:
    """The statically indeterminate case (a bar held rigidly at both ends) listed
    in both orders: the same forces, each at its own connection (to 1e-12 N:
    only rounding differs)."""
    points = np.array([[0.0, 0.0, 0.0], [200.0, 0.0, 30.0]])

    def solve(order: list[int]) -> np.ndarray:
        return joint_wrenches(
            part_a=np.array([0, 0]),
            part_b=np.array([1, 1]),
            points=points[order],
            movable=np.array([False, True]),
            loads=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -10.0]]),
            centres=np.array([[0.0, 0.0, 0.0], [60.0, 10.0, 5.0]]),
            free_joint=NONE,
            free_velocity=NO_MOTION,
            free_rotation=NO_MOTION,
        ).forces

    np.testing.assert_allclose(solve([0, 1]), solve([1, 0])[::-1], atol=1e-12)
