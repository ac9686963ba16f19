"""The target: where it should be, where it is, and how far apart, in stated units.

Reported error: the position error in mm and the geodesic rotation angle in
degrees, modulo the target primitive's symmetry (a rod turned about its own
axis, or end for end, is the same rod).

Optimised: a smooth residual with the same zero set, position (mm) and
rotation entries weighted so that 1 degree counts like 1 mm:

    target cost = |dp|^2 + (ROTATION_WEIGHT * dR)^2,  ROTATION_WEIGHT = 180/pi mm per radian
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fabhal.elaborate import Target
from fabhal.kinematics.frames import Array, frame_matrix, rot_x, rot_y, rot_z
from fabhal.model import Forward, Model
from fabhal.primitives import Primitive

ROTATION_WEIGHT_MM = 180.0 / math.pi  # mm per radian: 1 degree of rotation error weighs as 1 mm

# (kind of symmetry, axis in the primitive's frame, end-for-end flip too)
_AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}
SYMMETRY: dict[str, tuple[str, str, bool]] = {
    "rod": ("axis", "z", True),  # any turn about the axis; either end up
    "tube": ("axis", "z", True),
    "hole": ("axis", "x", True),  # a ring's axis is the normal of its plane
    "hemisphere": ("axis", "z", False),
    "clip": ("half_turn", "z", False),
    "surface": ("half_turn", "z", False),
    "edge": ("half_turn", "y", False),
}
_HALF_TURN = {"x": rot_x(180.0), "y": rot_y(180.0), "z": rot_z(180.0)}


@dataclass(frozen=True)
class TargetGoal:
    part: int
    primitive: Primitive | None  # None: the part's own frame
    requested: Array  # (4, 4) world frame
    source: Target
    rotation_weight: float = ROTATION_WEIGHT_MM  # 0: fit the position alone

    @property
    def symmetry(self) -> tuple[str, str, bool] | None:
        return SYMMETRY.get(self.primitive.kind) if self.primitive is not None else None

    def local(self) -> Array:
        return self.primitive.base_frame() if self.primitive is not None else np.eye(4)


def goal_of(model: Model) -> TargetGoal:
    (target,) = model.program.targets[:1]
    part = model.part_index(target.part)
    primitive = model.parts[part].spec.primitive(target.primitive) if target.primitive else None
    return TargetGoal(part, primitive, frame_matrix(target.position, target.rotation), target)


def achieved(goal: TargetGoal, frames: Array) -> Array:
    """(4, 4) world frame of the target (part frame, or the primitive's frame in it)."""
    return frames[goal.part] @ goal.local()


def errors(goal: TargetGoal, frame: Array) -> tuple[float, float]:
    """(position error mm, rotation error degrees modulo the symmetry)."""
    position = float(np.linalg.norm(frame[:3, 3] - goal.requested[:3, 3]))
    return position, _angle_deg(goal, frame[:3, :3])


def _angle_deg(goal: TargetGoal, rotation: Array) -> float:
    wanted = goal.requested[:3, :3]
    symmetry = goal.symmetry
    if symmetry is None:
        return _geodesic(wanted, rotation)
    kind, axis_name, flips = symmetry
    if kind == "axis":
        axis = _AXES[axis_name]
        cosine = float((rotation @ axis) @ (wanted @ axis))
        return math.degrees(math.acos(min(1.0, abs(cosine) if flips else max(-1.0, cosine))))
    return min(_geodesic(wanted, rotation), _geodesic(wanted @ _HALF_TURN[axis_name][:3, :3], rotation))


def _geodesic(a: Array, b: Array) -> float:
    cosine = (float((a.T @ b).trace()) - 1.0) / 2.0
    return math.degrees(math.acos(min(1.0, max(-1.0, cosine))))


# ---------------------------------------------------------------- for the optimiser


def residual(goal: TargetGoal, frame: Array) -> Array:
    """Smooth residual whose zero set is the requested frame up to symmetry."""
    rotation_part = _rotation_residual(goal, frame[:3, :3])
    return np.concatenate([frame[:3, 3] - goal.requested[:3, 3], goal.rotation_weight * rotation_part])


def residual_jacobian(goal: TargetGoal, model: Model, fwd: Forward) -> Array:
    """(len(residual), n_dofs)."""
    d_frames = model.frame_derivatives(fwd, goal.part) @ goal.local()  # (n, 4, 4)
    d_position = d_frames[:, :3, 3].T
    d_rotation = d_frames[:, :3, :3]
    if goal.symmetry is not None and goal.symmetry[0] == "axis":
        d_residual = (d_rotation @ _AXES[goal.symmetry[1]]).T  # only the axis counts
    else:
        d_residual = d_rotation.reshape(len(d_frames), 9).T
    return np.vstack([d_position, goal.rotation_weight * d_residual])


def _rotation_residual(goal: TargetGoal, rotation: Array) -> Array:
    """The rotation residual: the difference to the nearest rotation the symmetry allows."""
    wanted = goal.requested[:3, :3]
    symmetry = goal.symmetry
    if symmetry is not None and symmetry[0] == "axis":
        _, axis_name, flips = symmetry
        axis = _AXES[axis_name]
        sign = 1.0
        if flips and float((rotation @ axis) @ (wanted @ axis)) < 0.0:
            sign = -1.0  # the nearer end of a symmetric axis
        return rotation @ axis - sign * (wanted @ axis)
    if symmetry is not None:
        turned = wanted @ _HALF_TURN[symmetry[1]][:3, :3]
        if _geodesic(turned, rotation) < _geodesic(wanted, rotation):
            wanted = turned
    return (rotation - wanted).ravel()
