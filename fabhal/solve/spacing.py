"""The solver's linear inequalities: spacing, and flex angles turning together.

Spacing: parts sharing a rod, tube, edge or hook cannot pass through each other.

For two connections i, j on one primitive of length L, to different parts,
with half-widths c_i, c_j (a hook's wire radius, half a clip's width):

    s * (t_j - t_i) * L - (c_i + c_j) >= 0

where s keeps the order they start in (the paper's |t_i - t_j| L >= (w_i + w_j)/2,
made smooth). Linear in x, so its Jacobian is constant.

Turning together (`TurnLimit`, fabhal/model.py): where both sides of a
connection flex in a model with loops, |(x_i - 90) + sign (x_j - 90)| <= jam,
as two rows (without loops the pair is folded into one DoF and a bound).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from fabhal.kinematics.frames import Array
from fabhal.model import Joint, Model, Side, TurnLimit, threaded
from fabhal.primitives import across


@dataclass(frozen=True)
class Spacing:
    first: int  # DoF index of t on the shared primitive, connection i
    second: int  # the same for connection j
    length: float
    gap: float  # c_i + c_j, mm
    sign: float
    # on a hook's arc: not spread at the start (parts hung on one hook start where they
    # hang, their order the check's closure's: spread along the closet basket's handle,
    # its two eye hooks crossed over and the basket hung turned round)
    along_arc: bool = False


def spacing_constraints(model: Model, x0: Array) -> list[Spacing]:
    shares: dict[
        tuple[int, str], list[tuple[int, int, float]]
    ] = {}  # host -> (t index, other part, half-width)
    for joint in model.joints:
        for host, guest in ((joint.a, joint.b), (joint.b, joint.a)):
            slide = _place_on(host)
            if slide is None:
                continue
            entries = shares.setdefault((host.part, host.primitive.name), [])
            if all(other != guest.part for _, other, _ in entries):  # first connection per neighbouring part
                entries.append((slide, guest.part, half_width(joint, guest)))
    constraints = []
    for (part, name), entries in shares.items():
        shared = model.parts[part].spec.primitive(name)
        assert shared is not None
        along_arc = shared.kind == "hook"
        # mm per unit of the place: a slide's t its whole length, a hook's theta a degree of its arc
        length = float(np.radians(shared.params["arc_radius"])) if along_arc else shared.params["length"]
        for (i, _, ci), (j, _, cj) in ((a, b) for k, a in enumerate(entries) for b in entries[k + 1 :]):
            sign = 1.0 if x0[j] >= x0[i] else -1.0
            constraints.append(Spacing(i, j, length, ci + cj, sign, along_arc))
    return constraints


def _place_on(host: Side) -> int | None:
    """The DoF that says where along its host a connection sits, where parts
    side by side must keep apart: a rod's, tube's or edge's t; a hook's theta
    along its arc (two rings on one hook hang side by side near its lowest
    point, not one in the other). Not a ring's or a coil's turn all round,
    nor a surface's (its objects' bases: fabhal/solve/__init__.py)."""
    kind, dofs = host.primitive.kind, host.primitive.dofs
    if kind in ("rod", "tube", "edge"):
        return next((i for i, d in zip(host.dof_indices, dofs, strict=True) if d.critical), None)
    if kind == "hook" and not dofs[0].periodic:
        return host.dof_indices[0]
    return None


def half_width(joint: Joint, guest: Side) -> float:
    """How far a part reaches along the primitive it is on, each way from its
    connection point: half its thickness across, or half the length of a sleeve
    threaded on it (held at its middle: fabhal/model.py `threaded`)."""
    sides = threaded(joint)
    if sides is not None and sides[0] is guest:
        return guest.primitive.params["length"] / 2.0
    return across(guest.primitive) / 2.0


def spacing_values(constraints: list[Spacing], x: Array) -> Array:
    """>= 0 when satisfied (mm)."""
    return np.array([c.sign * (x[c.second] - x[c.first]) * c.length - c.gap for c in constraints])


def spacing_jacobian(constraints: list[Spacing], n: int) -> Array:
    jac = np.zeros((len(constraints), n))
    for k, c in enumerate(constraints):
        jac[k, c.second] = c.sign * c.length
        jac[k, c.first] = -c.sign * c.length
    return jac


def spread(constraints: list[Spacing], x: Array, low: Array, high: Array) -> Array:
    """Parts sharing a primitive start spread along it (all defaults are the
    middle, which would put them inside each other): in the order that fits
    them within their ranges (`low`, `high`) with their widths apart and spans
    the most of the primitive (a sleeve between the two hooks that hold its
    rod, not beside both), of equals the first of their canonical order and
    then the others; halfway between packed to one end and packed to the
    other; evenly in the canonical order where no order fits (then the fit
    reports what it cannot close). A DoF whose range is one value (`low` ==
    `high`: written by the program) stays where it is."""
    x = x.copy()
    constraints = [c for c in constraints if not c.along_arc]
    gaps = {}
    for c in constraints:
        gaps[c.first, c.second] = gaps[c.second, c.first] = c.gap / c.length
    for members in _connected(constraints):
        orders = itertools.islice(itertools.permutations(members), MAX_ORDERS)
        fits = [p for p in (_packed(o, gaps, low, high) for o in orders) if p is not None]
        # max keeps the first of equals
        placed = max(fits, key=lambda p: max(p.values()) - min(p.values()), default=None)
        if placed is None:
            placed = {
                i: (rank + 1) / (len(members) + 1) for rank, i in enumerate(members) if low[i] < high[i]
            }
        for i, t in placed.items():
            x[i] = t
    return x


MAX_ORDERS = 120  # the orders of five parts on one primitive; more are kept in the canonical one


def _packed(
    order: tuple[int, ...], gaps: dict[tuple[int, int], float], low: Array, high: Array
) -> dict[int, float] | None:
    """The members in this order, each its gap from the last, spread over the
    room they have: the k-th of n at (k + 1) / (n + 1) of the way from packed
    at the low end to packed at the high end (halfway, where that would break
    a gap); None if they do not fit."""
    up = [float(low[order[0]])]
    for last, i in itertools.pairwise(order):
        up.append(max(float(low[i]), up[-1] + gaps.get((last, i), 0.0)))
    down = [float(high[order[-1]])]
    for last, i in itertools.pairwise(order[::-1]):
        down.append(min(float(high[i]), down[-1] - gaps.get((last, i), 0.0)))
    down.reverse()
    if any(u > d + 1e-12 for u, d in zip(up, down, strict=True)):
        return None
    share = (np.arange(len(order)) + 1.0) / (len(order) + 1.0)
    spread_out = np.array(up) + share * (np.array(down) - np.array(up))
    steps = [gaps.get(pair, 0.0) for pair in itertools.pairwise(order)]
    if np.any(np.diff(spread_out) < np.array(steps) - 1e-12):
        spread_out = (np.array(up) + np.array(down)) / 2  # both packings keep the gaps: so does their mean
    return {i: float(t) for i, t in zip(order, spread_out, strict=True)}


def _connected(constraints: list[Spacing]) -> list[list[int]]:
    groups: list[set[int]] = []
    for c in constraints:
        joined = [g for g in groups if c.first in g or c.second in g]
        merged = {c.first, c.second}.union(*joined) if joined else {c.first, c.second}
        groups = [g for g in groups if g not in joined] + [merged]
    return [sorted(g) for g in groups]


SQUARE_DEG = 90.0  # a flex angle's value where its loop is square to what it goes round


def turn_rows(limits: tuple[TurnLimit, ...], n: int) -> tuple[Array, Array]:
    """(2k, n) G and (2k,) h with G x + h >= 0 exactly where every limit not
    folded into one DoF (a bound) holds: jam - u >= 0 and jam + u >= 0,
    u = (x_i - 90) + sign (x_j - 90)."""
    limits = tuple(limit for limit in limits if not limit.folded)
    matrix, offset = np.zeros((2 * len(limits), n)), np.zeros(2 * len(limits))
    for k, limit in enumerate(limits):
        for row, way in ((2 * k, -1.0), (2 * k + 1, 1.0)):
            matrix[row, limit.first] = way
            matrix[row, limit.second] = way * limit.sign
            offset[row] = limit.jam - way * SQUARE_DEG * (1.0 + limit.sign)
    return matrix, offset


def stopped_turns(limits: tuple[TurnLimit, ...], x: Array) -> set[int]:
    """The flex angles of the limits x rests on (within 1e-6 degrees): stopped
    together where the wire jams, which carries what presses on it."""
    limits = tuple(limit for limit in limits if not limit.folded)  # folded: at its bound
    matrix, offset = turn_rows(limits, len(x))
    on = np.any((matrix @ x + offset <= 1e-6).reshape(-1, 2), axis=1).tolist()
    stopped = [limit for limit, jammed in zip(limits, on, strict=True) if jammed]
    return {i for limit in stopped for i in (limit.first, limit.second)}
