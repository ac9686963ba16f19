"""Spacing: parts sharing a rod, tube or edge cannot pass through each other.

For two connections i, j on one primitive of length L, to different parts,
with half-widths c_i, c_j (a hook's wire radius, half a clip's width):

    s * (t_j - t_i) * L - (c_i + c_j) >= 0

where s keeps the order they start in (the paper's |t_i - t_j| L >= (w_i + w_j)/2,
made smooth). Linear in x, so its Jacobian is constant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fabhal.check.dimensions import across
from fabhal.kinematics.frames import Array
from fabhal.model import Model


@dataclass(frozen=True)
class Spacing:
    first: int  # DoF index of t on the shared primitive, connection i
    second: int  # the same for connection j
    length: float
    gap: float  # c_i + c_j, mm
    sign: float


def spacing_constraints(model: Model, x0: Array) -> list[Spacing]:
    shares: dict[
        tuple[int, str], list[tuple[int, int, float]]
    ] = {}  # host -> (t index, other part, half-width)
    for joint in model.joints:
        for host, guest in ((joint.a, joint.b), (joint.b, joint.a)):
            if host.primitive.kind not in ("rod", "tube", "edge"):
                continue
            slide = next(
                (i for i, d in zip(host.dof_indices, host.primitive.dofs, strict=True) if d.critical), None
            )
            if slide is None:
                continue
            entries = shares.setdefault((host.part, host.primitive.name), [])
            if all(other != guest.part for _, other, _ in entries):  # first connection per neighbouring part
                entries.append((slide, guest.part, across(guest.primitive) / 2.0))
    constraints = []
    for (part, name), entries in shares.items():
        length = model.parts[part].spec.primitive(name).params["length"]  # type: ignore[union-attr]
        for (i, _, ci), (j, _, cj) in ((a, b) for k, a in enumerate(entries) for b in entries[k + 1 :]):
            sign = 1.0 if x0[j] >= x0[i] else -1.0
            constraints.append(Spacing(i, j, length, ci + cj, sign))
    return constraints


def spacing_values(constraints: list[Spacing], x: Array) -> Array:
    """>= 0 when satisfied (mm)."""
    return np.array([c.sign * (x[c.second] - x[c.first]) * c.length - c.gap for c in constraints])


def spacing_jacobian(constraints: list[Spacing], n: int) -> Array:
    jac = np.zeros((len(constraints), n))
    for k, c in enumerate(constraints):
        jac[k, c.second] = c.sign * c.length
        jac[k, c.first] = -c.sign * c.length
    return jac


def spread(constraints: list[Spacing], x: Array) -> Array:
    """Parts sharing a primitive start spread evenly along it, in program order
    (all defaults are the middle, which would put them inside each other)."""
    x = x.copy()
    for members in _connected(constraints):
        for rank, i in enumerate(members):
            x[i] = (rank + 1) / (len(members) + 1)
    return x


def _connected(constraints: list[Spacing]) -> list[list[int]]:
    groups: list[set[int]] = []
    for c in constraints:
        joined = [g for g in groups if c.first in g or c.second in g]
        merged = {c.first, c.second}.union(*joined) if joined else {c.first, c.second}
        groups = [g for g in groups if g not in joined] + [merged]
    return [sorted(g) for g in groups]
