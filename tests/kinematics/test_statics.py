"""The statics kernel on assemblies whose forces follow by hand."""

from __future__ import annotations

import numpy as np

from fabhal.kinematics.statics import Wrenches, joint_wrenches

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


def bar_on_two_pivots(centre: float) -> Wrenches:
    """A 10 N bar (centre of mass at x = `centre`) on pivots at x = 0 and 200,
    each free to turn about y."""
    return joint_wrenches(
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


def test_a_bar_on_two_pivots_shares_its_weight_by_the_lever_rule() -> None:
    """A 10 N bar from x = -100 to x = 300 (centre at x = 100) rests on pivots at
    x = 0 and x = 200, each free to turn about y (a free motion: no moment about
    y). By hand, moments about the left pivot: F_right x 200 = 10 x 100, so 5 N
    each; with the centre at x = 150 instead: F_right = 7.5 N, F_left = 2.5 N.
    The pivots' other reactions are indeterminate; the smallest are taken
    (zero). Tolerance 1e-9 N."""
    for centre, expected in ((100.0, (5.0, 5.0)), (150.0, (2.5, 7.5))):
        wrenches = bar_on_two_pivots(centre)
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


def test_a_long_chain_solved_by_its_normal_equations_carries_everything_below() -> None:
    """60 parts of 1 N hang one below the other from the environment (part 0), each
    connection 41 mm below the last, each free to swing about x and y at its
    point: 360 unknowns, past NORMAL_EQUATIONS_UNKNOWNS, a tree (full column
    rank). By hand: connection k (from the top, 0-based) carries the 60 - k
    parts below it, straight down, no moments. Tolerance 1e-9 N, as the small
    chain above: the system's condition number is about 150 here, so its
    normal equations lose 4-5 of 16 digits."""
    from fabhal.kinematics.statics import NORMAL_EQUATIONS_UNKNOWNS

    n = 60
    assert 6 * n >= NORMAL_EQUATIONS_UNKNOWNS
    points = np.array([[0.0, 0.0, -41.0 * k] for k in range(n)])
    swings = np.repeat(np.eye(3)[:2][None], n, axis=0).reshape(-1, 3)
    wrenches = joint_wrenches(
        part_a=np.arange(1, n + 1),
        part_b=np.arange(n),
        points=points,
        movable=np.arange(n + 1) > 0,
        loads=np.array([[0.0, 0.0, 0.0]] + [[0.0, 0.0, -1.0]] * n),
        centres=np.array([[0.0, 0.0, 0.0]] + [[0.0, 0.0, -41.0 * k - 20.5] for k in range(n)]),
        free_joint=np.repeat(np.arange(n), 2),
        free_velocity=np.zeros((2 * n, 3)),
        free_rotation=swings,
    )
    expected = np.zeros((n, 3))
    expected[:, 2] = -(n - np.arange(n))
    np.testing.assert_allclose(wrenches.forces, expected, atol=1e-9)
    np.testing.assert_allclose(wrenches.moments, 0.0, atol=1e-9)
    assert wrenches.imbalance < 1e-9


def test_many_bars_on_two_pivots_keep_the_smallest_reactions() -> None:
    """50 bars of 10 N, each on two pivots as the lever-rule test above (centre at
    x = 150: 2.5 N and 7.5 N): 600 unknowns, but each bar's pivots leave forces
    along the bar indeterminate (a loop's own), so the normal equations are
    singular and the SVD's minimum norm decides: those forces 0, the lever rule
    exact. Tolerance 1e-9 N."""
    bars = 50
    wrenches = joint_wrenches(
        part_a=np.zeros(2 * bars, dtype=int),
        part_b=np.repeat(np.arange(1, bars + 1), 2),
        points=np.tile([[0.0, 0.0, 0.0], [200.0, 0.0, 0.0]], (bars, 1)),
        movable=np.arange(bars + 1) > 0,
        loads=np.array([[0.0, 0.0, 0.0]] + [[0.0, 0.0, -10.0]] * bars),
        centres=np.array([[0.0, 0.0, 0.0]] + [[150.0, 0.0, 0.0]] * bars),
        free_joint=np.arange(2 * bars),
        free_velocity=np.zeros((2 * bars, 3)),
        free_rotation=np.tile([0.0, 1.0, 0.0], (2 * bars, 1)),
    )
    np.testing.assert_allclose(wrenches.forces[:, 2], np.tile([2.5, 7.5], bars), atol=1e-9)
    np.testing.assert_allclose(wrenches.forces[:, :2], 0.0, atol=1e-9)


def test_a_loops_own_force_states_are_given() -> None:
    """The bar on two pivots (as above, centre at x = 100): the pivots'
    reactions along x are indeterminate, a push of s at one balanced by s at
    the other (what a exerts on b, equal and opposite along x: the bar
    squeezed or stretched between them); vertically the lever rule fixes
    everything. So the own states' forces are multiples of (+1, -1) along x
    at the two pivots, and nothing vertical (1e-9: an SVD's orthonormal basis)."""
    own = bar_on_two_pivots(100.0).indeterminate  # (K, J, 3)
    assert len(own)
    np.testing.assert_allclose(own[:, :, 2], 0.0, atol=1e-9)
    along_x = own[:, :, 0]
    np.testing.assert_allclose(along_x[:, 0], -along_x[:, 1], atol=1e-9)
    assert np.abs(along_x).max() > 0.1  # the squeeze is among them


def test_pressing_uses_a_loops_own_states_to_make_contacts_press() -> None:
    """Normal forces (N) with a loop's own state adding (+1, -1) in any
    multiple. (-1, 3): one contact pulls; adding 1 of the state gives (0, 2),
    all pressing. (-1, -1): the state only moves load from one to the other,
    so the least shortfall is where they share it, (-1, -1) itself. Without
    a state nothing can change; with a reach of 0.5 N only half the pull is
    taken off, (-0.5, 2.5), and what was taken off before counts against
    it. Newton on the short contacts is exact here (the shortfall is
    quadratic on each piece): 1e-12."""
    from fabhal.kinematics.statics import pressing

    state = np.array([[1.0, -1.0]])
    np.testing.assert_allclose(pressing(np.array([-1.0, 3.0]), state), [0.0, 2.0], atol=1e-12)
    np.testing.assert_allclose(pressing(np.array([-1.0, -1.0]), state), [-1.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(pressing(np.array([-1.0, 3.0]), np.zeros((0, 2))), [-1.0, 3.0])
    half = pressing(np.array([-1.0, 3.0]), state, np.array([0.5]))
    np.testing.assert_allclose(half, [-0.5, 2.5], atol=1e-12)
    # what was taken off already counts: 0.5 taken (forces moved by -0.5) leaves 1.0 to add; -0.5, none
    back = pressing(np.array([-1.0, 3.0]), state, np.array([0.5]), np.array([0.5]))
    np.testing.assert_allclose(back, [0.0, 2.0], atol=1e-12)
    spent = pressing(np.array([-1.0, 3.0]), state, np.array([0.5]), np.array([-0.5]))
    np.testing.assert_allclose(spent, [-1.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(pressing(np.array([2.0, 3.0]), state), [2.0, 3.0])


def bar_on_three_links(tilt_mm: float, push_n: float, slack: float) -> Wrenches:
    """A 10 N bar (centre at x = 100) hung by three links 100 mm long from
    points over x = 0, 100 and 200 (z = 100) to the bar (z = 0), each with a
    ball joint at both ends (free to turn about every axis: a link carries
    only a force along itself, as a straight chain does); the middle link's
    lower end `tilt_mm` further along x. The bar also carries `push_n` along
    x: what a state at rest may leave unbalanced. Parts: 0 the ceiling, 1-3
    the links (weightless), 4 the bar; connections 0-2 the links' tops, 3-5
    their lower ends."""
    tops = np.array([[0.0, 0.0, 100.0], [100.0, 0.0, 100.0], [200.0, 0.0, 100.0]])
    ends = np.array([[0.0, 0.0, 0.0], [100.0 + tilt_mm, 0.0, 0.0], [200.0, 0.0, 0.0]])
    return joint_wrenches(
        part_a=np.array([1, 2, 3, 4, 4, 4]),
        part_b=np.array([0, 0, 0, 1, 2, 3]),
        points=np.vstack([tops, ends]),
        movable=np.array([False, True, True, True, True]),
        loads=np.array([[0.0, 0.0, 0.0]] * 4 + [[push_n, 0.0, -10.0]]),
        centres=np.vstack([[[0.0, 0.0, 0.0]], (tops + ends) / 2.0, [[100.0, 0.0, 0.0]]]),
        free_joint=np.repeat(np.arange(6), 3),
        free_velocity=np.zeros((18, 3)),
        free_rotation=np.tile(np.eye(3), (6, 1)),
        slack=slack,
    )


def test_a_nearly_straight_loop_may_share_its_load_as_a_straight_one() -> None:
    """The bar on three links (above). Straight links share the bar's weight
    in any way with t1 = t3 (moments about the middle) and t1 + t2 + t3 = 10:
    a state (1, -2, 1) of the tensions, balanced by itself. With the middle
    link's end 0.01 mm aside the equations are just determinate: its tension
    pulls the bar 1e-4 of itself back along x, so only it can balance the
    bar's x-load, and the smallest wrenches take t2 = push x 100 / 0.01: a
    push of -1e-4 N (a settled state's leftover) makes the middle link push
    the bar down with 1 N and the outer ones carry 5.5 N each (hand: t1 + t3
    = 10 - t2 = 11, moments about the middle t3 - t1 = -t2 x 1e-4: 5.5 -+
    5e-5). The state is then balanced only
    nearly: as unit forces (the tensions (1, -2, 1) / sqrt(12) at both ends
    of each link, t3 - t1 cancelling its moment) it leaves the bar
    unbalanced along x by 2 / sqrt(12) x 1e-4 = 5.8e-5 N per N, so the
    smallest singular value is at most that (the SVD's state spreads the
    imbalance over the links' rows as well: 1.8e-5). With a slack of 0.01 N
    (1e-3 of the weight, the settle's) it is one of the loop's own states,
    with a reach of at least 0.01 / 5.8e-5 = 173 N, and the tensions can all
    pull (t2 >= 0 needs 1 N x sqrt(12) / 2 = 1.7 N of it). Without slack it
    is not (the middle link then pushes). With it, the wrenches given are
    the smallest within the slack: the state's part taken off, 10/3 N a link.
    Tolerances: 1e-6 N on the smallest wrenches (a condition number of 1e5
    on 1e-16); 1e-3 N on the even split (the SVD's state is the hand's to
    first order in the tilt)."""
    from fabhal.kinematics.statics import pressing

    exact = bar_on_three_links(0.0, 0.0, 0.0)
    assert len(exact.indeterminate) and np.isinf(exact.reach).all()
    without = bar_on_three_links(0.01, -1e-4, 0.0)
    tension = -without.forces[:3, 2]  # what a link exerts on the ceiling: down, where it pulls
    np.testing.assert_allclose(tension, [5.5 - 5e-5, -1.0, 5.5 + 5e-5], atol=1e-6)
    # with the slack the state's part of them is taken off, as far as its reach allows (all of it here):
    # (5.5, -1, 5.5) - 13/6 (1, -2, 1) = 10/3 each, the straight links' even split
    shared = -bar_on_three_links(0.01, -1e-4, 0.01).forces[:3, 2]
    np.testing.assert_allclose(shared, [10.0 / 3.0] * 3, atol=1e-3)
    for slack, states in ((0.01, 1), (0.0, 0)):
        tilted = bar_on_three_links(0.01, -1e-4, slack)
        assert len(tilted.indeterminate) == states
        if states:
            assert np.isfinite(tilted.reach[0]) and tilted.reach[0] >= 0.01 / (2.0 / np.sqrt(12.0) * 1e-4)
        pressed = pressing(tension, -tilted.indeterminate[:, :3, 2], tilted.reach)
        assert (pressed >= -1e-9).all() == bool(states)
