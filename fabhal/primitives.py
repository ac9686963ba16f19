"""The eight connector primitive kinds, as tables, and their connector frames.

Each kind has shape parameters (with units and validity rules) and flags; the
flags pick a *variant* (centre-line rods/holes/tubes, flexible hooks/holes),
and the variant fixes the connection's degrees of freedom and the connector
frame formula. Numbers and formulas follow shared/spec/FABHAL_REFERENCE.md
(sections b.1-b.3); the tags follow its "Decisions" 4-5:

* sliding off the free end of an open rod, tube or edge, or off a hook's free
  tip, is BOUNDED_AND_OPEN (leaving the range = falling off);
* flex angles, hemisphere angles, clip positions and positions on primitives
  that cannot be slid off (`slide_off: false`) are BOUNDED_AND_CLAMPED;
* full-circle angles are UNBOUNDED (periodic).

`connector_frames` is pure numpy, batched over DoF samples.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from enum import Enum
from functools import cached_property

import numpy as np

from fabhal.kinematics.frames import Array, frame_matrix, rot_x, rot_y, rot_z, translation


class Tag(str, Enum):
    UNBOUNDED = "UNBOUNDED"
    BOUNDED_AND_CLAMPED = "BOUNDED_AND_CLAMPED"
    BOUNDED_AND_OPEN = "BOUNDED_AND_OPEN"


@dataclass(frozen=True)
class ParamSpec:
    """A numeric shape parameter. `rule`: positive, nonnegative or arc_angle (0, 360]."""

    name: str
    unit: str
    rule: str = "positive"
    optional: bool = False  # an optional parameter without a value is simply absent


@dataclass(frozen=True)
class FlagSpec:
    """A true/false property; `default` None means "same as `follows`"."""

    name: str
    meaning: str
    default: bool | None = False
    follows: str | None = None


@dataclass(frozen=True)
class KindSpec:
    kind: str
    meaning: str
    params: tuple[ParamSpec, ...]
    flags: tuple[FlagSpec, ...]
    single_connection: bool = False

    def param(self, name: str) -> ParamSpec | None:
        return next((p for p in self.params if p.name == name), None)

    def flag(self, name: str) -> FlagSpec | None:
        return next((f for f in self.flags if f.name == name), None)


_SLIDE_OFF = FlagSpec("slide_off", "a connection can slide off its free end(s) and fall", True)
_THREADABLE = FlagSpec(
    "threadable", "has an opening a closed loop can be threaded through", None, follows="slide_off"
)
_CENTERLINE = FlagSpec("centerline", "connect on the centre line instead of the surface")
_FLEX = FlagSpec("flex", "may also twist about the contact normal (one more angle)")
_SPIN = FlagSpec(
    "spin",
    "where a hook holds it, may also turn about its own wire (one more angle): a hoop hung level on hooks",
)

KINDS: dict[str, KindSpec] = {
    spec.kind: spec
    for spec in (
        KindSpec(
            "rod",
            "a cylinder along its local z axis, centred",
            (ParamSpec("radius", "mm"), ParamSpec("length", "mm")),
            (_SLIDE_OFF, _THREADABLE, _CENTERLINE),
        ),
        KindSpec(
            "hook",
            "a wire arc in the local y-z plane from -z (theta 0) through -y (90) to +z (180)",
            (
                ParamSpec("arc_radius", "mm"),
                ParamSpec("arc_angle", "deg", "arc_angle"),
                ParamSpec("thickness", "mm"),
                ParamSpec("tip", "deg", "nonnegative", optional=True),
            ),
            (_SLIDE_OFF, _THREADABLE, _FLEX),
        ),
        KindSpec(
            "hole",
            "a closed ring (a hook with a 360-degree arc)",
            (ParamSpec("arc_radius", "mm"), ParamSpec("thickness", "mm")),
            (_CENTERLINE, _FLEX, _SPIN),
        ),
        KindSpec(
            "clip",
            "two jaws opening along the local z axis",
            (
                ParamSpec("width", "mm"),
                ParamSpec("height", "mm"),
                ParamSpec("thickness", "mm"),
                ParamSpec("dist", "mm", "nonnegative"),
                ParamSpec("open_gap", "mm"),
            ),
            (),
            single_connection=True,
        ),
        KindSpec(
            "tube",
            "a hollow cylinder along its local z axis, centred",
            (ParamSpec("inner_radius", "mm"), ParamSpec("thickness", "mm"), ParamSpec("length", "mm")),
            (_SLIDE_OFF, _CENTERLINE),
        ),
        KindSpec(
            "edge",
            "a box edge along local x, on the face y = +width/2",
            (ParamSpec("width", "mm"), ParamSpec("length", "mm"), ParamSpec("height", "mm")),
            (),
        ),
        KindSpec(
            "surface",
            "a plate length (x) by width (y), connectors on its top face (normal +z)",
            (ParamSpec("width", "mm"), ParamSpec("length", "mm")),
            (FlagSpec("slide_off", "a connection can slide off its border and fall", False),),
        ),
        KindSpec(
            "hemisphere",
            "the lower half of a ball, centred at the origin",
            (ParamSpec("radius", "mm"),),
            (),
            single_connection=True,
        ),
    )
}


def variant_of(kind: str, flags: Mapping[str, bool]) -> str:
    """The reference's connector-kind name, which selects DoFs and frame formula."""
    if kind == "rod":
        return "RodCtl" if flags.get("centerline") else "Rod"
    if kind == "hook":
        return "HookFlex" if flags.get("flex") else "Hook"
    if kind == "hole":
        if flags.get("centerline"):
            return "RingCtl"
        return ("RingFlex" if flags.get("flex") else "Ring") + ("Spin" if flags.get("spin") else "")
    if kind == "tube":
        return "TubeCtl" if flags.get("centerline") else "Tube"
    return kind.capitalize()


# ---------------------------------------------------------------- validation


# each rule of ParamSpec: whether a value follows it, what the value must do, how to mend it
_RULES: dict[str, tuple[Callable[[float], bool], str, str]] = {
    "positive": (lambda v: v > 0, "be positive", "a value above 0"),
    "nonnegative": (lambda v: v >= 0, "not be negative", "a value of 0 or more"),
    "arc_angle": (lambda v: 0 < v <= 360, "be in (0, 360]", "an angle above 0 and at most 360"),
}
_PAIR_FIX = {
    "thickness": "make `thickness` (the wire's radius) smaller than `arc_radius`",
    "tip": "write `tip: 0` (the tip at the arc's start) or `tip` equal to `arc_angle` (at its end)",
}


def param_fix(kind: str, name: str, value: float) -> str:
    """How to mend a shape parameter that `check_params` rejected: its own rule
    if `value` breaks it, else the rule that relates it to another parameter."""
    spec = next(p for p in KINDS[kind].params if p.name == name)
    follows, _, mend = _RULES[spec.rule]
    fix = _PAIR_FIX[name] if follows(value) else f"give `{name}` {mend} ({spec.unit})"
    return f"{fix}; docs/primitives.md describes each {kind} parameter"


def check_params(kind: str, params: Mapping[str, float]) -> list[tuple[str | None, str]]:
    """Problems with a primitive's numeric parameters: (parameter or None, message)."""
    spec = KINDS[kind]
    problems: list[tuple[str | None, str]] = []
    for p in spec.params:
        if p.name not in params:
            if not p.optional:
                problems.append((None, f"missing parameter `{p.name}` ({p.unit})"))
            continue
        value = params[p.name]
        follows, must, _ = _RULES[p.rule]
        if not follows(value):
            problems.append((p.name, f"{p.name} == {value:g}, but must {must}"))
    if kind in ("hook", "hole") and {"arc_radius", "thickness"} <= params.keys():
        if params["thickness"] >= params["arc_radius"]:
            problems.append(
                (
                    "thickness",
                    f"thickness {params['thickness']:g} mm leaves no opening inside arc_radius "
                    f"{params['arc_radius']:g} mm (the wire radius must be smaller)",
                )
            )
    if kind == "hook" and "tip" in params and {"arc_angle"} <= params.keys():
        if params["tip"] not in (0.0, params["arc_angle"]):
            problems.append(
                ("tip", f"tip == {params['tip']:g}, but must be 0 or the arc angle ({params['arc_angle']:g})")
            )
    return problems


def resolve_flags(kind: str, given: Mapping[str, bool]) -> dict[str, bool]:
    """Every flag of the kind, defaults filled in (a `follows` flag copies its leader)."""
    resolved: dict[str, bool] = {}
    for f in KINDS[kind].flags:
        if f.name in given:
            resolved[f.name] = given[f.name]
        elif f.follows is not None:
            resolved[f.name] = given.get(f.follows, resolved.get(f.follows, True))
        else:
            resolved[f.name] = bool(f.default)
    return resolved


# ---------------------------------------------------------------- degrees of freedom


@dataclass(frozen=True)
class Dof:
    """One connection degree of freedom on a primitive (angles in degrees, t in [0, 1])."""

    name: str
    low: float
    high: float
    default: float
    periodic: bool = False
    low_open: bool = False
    high_open: bool = False
    critical: bool = False  # a position that uses up the primitive's length/area
    # a lean (a flex angle: a hook tilting on its rod): its range is where the
    # model stops it, not an end a real contact has, and it carries no load...
    lean: bool = False
    # ...unless its range is where the wire jams on what it goes round (`yaw_jam_deg`)
    jammed: bool = False

    @property
    def ends_hold(self) -> bool:
        """Whether the ends of its range are real stops, which carry what presses
        on them: all but a lean's whose jam is not known."""
        return not self.lean or self.jammed

    @property
    def tag(self) -> Tag:
        if self.periodic:
            return Tag.UNBOUNDED
        return Tag.BOUNDED_AND_OPEN if self.low_open or self.high_open else Tag.BOUNDED_AND_CLAMPED


def _slide(name: str, open_ends: bool) -> Dof:
    return Dof(name, 0.0, 1.0, 0.5, low_open=open_ends, high_open=open_ends, critical=True)


def _spin(name: str, default: float = 0.0) -> Dof:
    return Dof(name, 0.0, 360.0, default, periodic=True)


def _hook_theta(params: Mapping[str, float], flags: Mapping[str, bool]) -> Dof:
    arc = params["arc_angle"]
    if arc >= 360.0:
        return _spin("theta", 180.0)
    slides_off = flags.get("slide_off", True)
    tip = params.get("tip")  # the free end; unannotated, either end may be free
    low_open = slides_off and tip in (None, 0.0)
    high_open = slides_off and tip in (None, arc)
    return Dof("theta", 0.0, arc, arc / 2.0, low_open=low_open, high_open=high_open)


def dofs_of(variant: str, params: Mapping[str, float], flags: Mapping[str, bool]) -> tuple[Dof, ...]:
    """The DoFs a connection creates on a primitive, in storage order."""
    slides_off = flags.get("slide_off", True)
    flex_phi = Dof("phi", 45.0, 135.0, 90.0, lean=True)
    ring_phi = Dof("phi", 30.0, 150.0, 90.0, lean=True)
    ring_spin = Dof("spin", -180.0, 180.0, 0.0, periodic=True)  # narrowed where it stops
    table: dict[str, Callable[[], tuple[Dof, ...]]] = {
        # spin: the rod turns in what holds it (a handle in a hook); the reference
        # welds the contact to one line of the rod, so a basket pivoted about its
        # hook's arc centre instead of its handle
        "Rod": lambda: (_slide("t", slides_off), flex_phi, _spin("spin")),
        # what is threaded on a centre line may also turn about it (the reference has no such DoF)
        # phi (the reference has none): what hangs on a centre line tilts along it, as on a
        # rod's surface, until its wire jams (`tilt_jam_deg`); held square, a hook near a
        # flag stick's end held the stick out as a cantilever
        "RodCtl": lambda: (_slide("t", slides_off), _spin("spin"), flex_phi),
        "Tube": lambda: (_slide("t", slides_off), _spin("theta", 180.0)),
        "TubeCtl": lambda: (_slide("t", slides_off), _spin("theta", 180.0)),
        "Hook": lambda: (_hook_theta(params, flags),),
        "HookFlex": lambda: (_hook_theta(params, flags), flex_phi),
        "Ring": lambda: (_spin("theta", 180.0),),
        "RingFlex": lambda: (_spin("theta", 180.0), ring_phi),
        # spin (the reference has no such DoF, and welds the contact to the ring's inner
        # line): a ring on a hook turns about its own wire, so a hoop hangs level from a
        # hook that holds its tube from above. Only a hook leaves it free
        # (`ring_spin_stop_deg`); on a rod or tube the rod's tilt is that turn already
        "RingSpin": lambda: (_spin("theta", 180.0), ring_spin),
        "RingFlexSpin": lambda: (_spin("theta", 180.0), ring_phi, ring_spin),
        # stored (phi, theta) as in the reference: phi turns about y, theta about x
        "RingCtl": lambda: (_spin("phi", 0.0), _spin("theta", 180.0)),
        "Clip": lambda: (Dof("t", 0.0, 1.0, 0.5),),
        "Edge": lambda: (_slide("t", True),),
        "Surface": lambda: (_slide("t1", slides_off), _slide("t2", slides_off), _spin("s")),
        "Hemisphere": lambda: (Dof("theta", 90.0, 270.0, 180.0), Dof("phi", 90.0, 270.0, 180.0), _spin("s")),
    }
    return table[variant]()


# ---------------------------------------------------------------- connector frames

# parameters are numbers, or (n,) arrays when many primitives of one variant are evaluated together
FrameFormula = Callable[[Mapping[str, float | Array], Array], Array]


def _rod(p: Mapping[str, float | Array], x: Array) -> Array:
    # Rz(spin) @ T(0, r, (t - 0.5) L) @ Rx(phi - 180), written out (hot in the
    # solver, as `_arc`); spin 0 when not given (the reference's two DoFs)
    phi = np.radians(x[..., 1])
    c, s = -np.cos(phi), -np.sin(phi)  # of phi - 180
    spin = np.radians(x[..., 2]) if x.shape[-1] > 2 else np.zeros(phi.shape)
    cz, sz = np.cos(spin), np.sin(spin)
    out = np.zeros((*phi.shape, 4, 4))
    out[..., 3, 3] = 1.0
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2], out[..., 0, 3] = cz, -sz * c, sz * s, -sz * p["radius"]
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2], out[..., 1, 3] = sz, cz * c, -cz * s, cz * p["radius"]
    out[..., 2, 1], out[..., 2, 2], out[..., 2, 3] = s, c, (x[..., 0] - 0.5) * p["length"]
    return out


_AXIS_TO_Y = rot_x(-90.0)  # a centre-line connector's y runs along the primitive's axis


def _rod_centerline(p: Mapping[str, float | Array], x: Array) -> Array:
    spin = x[..., 1] if x.shape[-1] > 1 else np.zeros(x.shape[:-1])  # about the axis: connector y
    along = translation(0.0, 0.0, (x[..., 0] - 0.5) * p["length"]) @ _AXIS_TO_Y
    if x.shape[-1] < 3:
        return along @ rot_y(spin)
    return along @ rot_y(spin) @ rot_x(x[..., 2] - 90.0)  # the tilt along the axis, square at 90


def _tube_at(rho: float | Array, p: Mapping[str, float | Array], x: Array) -> Array:
    theta = np.radians(x[..., 1])
    along = translation(0.0, 0.0, (x[..., 0] - 0.5) * p["length"]) @ _AXIS_TO_Y
    around = translation(-rho * np.sin(theta), 0.0, -rho * np.cos(theta)) @ rot_y(x[..., 1])
    return along @ around


def _tube(p: Mapping[str, float | Array], x: Array) -> Array:
    return _tube_at(p["inner_radius"] + p["thickness"], p, x)


def _tube_centerline(p: Mapping[str, float | Array], x: Array) -> Array:
    return _tube_at(p["inner_radius"], p, x)


def _arc(p: Mapping[str, float | Array], x: Array) -> Array:
    # T(0, -rho sin theta, -rho cos theta) @ Rx(-theta), written out: the hottest formula
    rho = p["arc_radius"] - p["thickness"]
    theta = np.radians(x[..., 0])
    c, s = np.cos(theta), np.sin(theta)
    out = np.zeros((*theta.shape, 4, 4))
    out[..., 0, 0] = out[..., 3, 3] = 1.0
    out[..., 1, 1], out[..., 1, 2], out[..., 1, 3] = c, s, -rho * s
    out[..., 2, 1], out[..., 2, 2], out[..., 2, 3] = -s, c, -rho * c
    return out


def _arc_flex(p: Mapping[str, float | Array], x: Array) -> Array:
    # `_arc` @ Rz(phi - 90), written out
    rho = p["arc_radius"] - p["thickness"]
    theta, phi = np.radians(x[..., 0]), np.radians(x[..., 1] - 90.0)
    c, s = np.cos(theta), np.sin(theta)
    cz, sz = np.cos(phi), np.sin(phi)
    out = np.zeros((*theta.shape, 4, 4))
    out[..., 3, 3] = 1.0
    out[..., 0, 0], out[..., 0, 1] = cz, -sz
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2], out[..., 1, 3] = c * sz, c * cz, s, -rho * s
    out[..., 2, 0], out[..., 2, 1], out[..., 2, 2], out[..., 2, 3] = -s * sz, -s * cz, c, -rho * c
    return out


def _ring_spun(p: Mapping[str, float | Array], x: Array) -> Array:
    # `_arc` @ T(0, 0, -w) @ Ry(spin) @ T(0, 0, w): the ring turned by its spin about
    # the centre line of its wire (w below the contact, away from the ring's centre)
    return _arc(p, x) @ _about_the_wire(p, x[..., -1])


def _ring_flex_spun(p: Mapping[str, float | Array], x: Array) -> Array:
    # `_ring_spun` @ Rz(phi - 90): the flex turns about the line of the spun contact
    return _arc(p, x) @ _about_the_wire(p, x[..., 2]) @ rot_z(x[..., 1] - 90.0)


def _about_the_wire(p: Mapping[str, float | Array], spin: Array) -> Array:
    w = p["thickness"]
    gamma = np.radians(spin)
    c, s = np.cos(gamma), np.sin(gamma)
    out = np.zeros((*gamma.shape, 4, 4))
    out[..., 1, 1] = out[..., 3, 3] = 1.0
    out[..., 0, 0], out[..., 0, 2], out[..., 0, 3] = c, s, w * s
    out[..., 2, 0], out[..., 2, 2], out[..., 2, 3] = -s, c, w * (c - 1.0)
    return out


def _ring_centerline(p: Mapping[str, float | Array], x: Array) -> Array:
    return rot_y(x[..., 0]) @ rot_x(x[..., 1])


def _clip(p: Mapping[str, float | Array], x: Array) -> Array:
    return translation(0.0, 0.0, (x[..., 0] - 0.5) * p["height"])


def _edge(p: Mapping[str, float | Array], x: Array) -> Array:
    return translation((x[..., 0] - 0.5) * p["length"], p["width"] / 2.0, 0.0)


def _surface(p: Mapping[str, float | Array], x: Array) -> Array:
    offset = translation((x[..., 1] - 0.5) * p["length"], (0.5 - x[..., 0]) * p["width"], 0.05)
    return offset @ rot_z(x[..., 2])


def _hemisphere(p: Mapping[str, float | Array], x: Array) -> Array:
    r = p["radius"]
    theta, phi = np.radians(x[..., 0]), np.radians(x[..., 1])
    on_dome = translation(r * np.sin(phi), r * np.cos(phi) * np.sin(theta), -r * np.cos(phi) * np.cos(theta))
    return on_dome @ rot_y(x[..., 1]) @ rot_x(-x[..., 0]) @ rot_z(x[..., 2])


FRAME_FORMULAS: dict[str, FrameFormula] = {
    "Rod": _rod,
    "RodCtl": _rod_centerline,
    "Tube": _tube,
    "TubeCtl": _tube_centerline,
    "Hook": _arc,
    "HookFlex": _arc_flex,
    "Ring": _arc,
    "RingFlex": _arc_flex,
    "RingSpin": _ring_spun,
    "RingFlexSpin": _ring_flex_spun,
    "RingCtl": _ring_centerline,
    "Clip": _clip,
    "Edge": _edge,
    "Surface": _surface,
    "Hemisphere": _hemisphere,
}


# ---------------------------------------------------------------- a resolved primitive


@dataclass(frozen=True)
class Primitive:
    """A primitive of a part type, all numbers evaluated."""

    name: str
    kind: str
    params: Mapping[str, float]
    flags: Mapping[str, bool]
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    dofs: tuple[Dof, ...] = field(default=())

    @property
    def variant(self) -> str:
        return variant_of(self.kind, self.flags)

    @property
    def single_connection(self) -> bool:
        return KINDS[self.kind].single_connection

    def base_frame(self) -> Array:
        """(4, 4): the primitive's frame in its part's frame."""
        return self._base.copy()

    @cached_property
    def _base(self) -> Array:
        return frame_matrix(self.position, self.rotation)

    @cached_property
    def _formula(self) -> FrameFormula:
        return FRAME_FORMULAS[self.variant]

    def connector_frames(self, dof_values: np.ndarray) -> Array:
        """(..., k) DoF values -> (..., 4, 4) connector frames in the part's frame."""
        values = np.asarray(dof_values, dtype=float)
        return self._base @ self._formula(self.params, values)


def make_primitive(
    name: str,
    kind: str,
    params: Mapping[str, float],
    flags: Mapping[str, bool],
    position: tuple[float, float, float] = (0.0, 0.0, 0.0),
    rotation: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> Primitive:
    """Fill in defaults and DoFs; `params` must already satisfy `check_params`."""
    spec = KINDS[kind]
    full_params = {p.name: float(params[p.name]) for p in spec.params if p.name in params}
    full_flags = resolve_flags(kind, flags)
    dofs = dofs_of(variant_of(kind, full_flags), full_params, full_flags)
    return Primitive(name, kind, full_params, full_flags, position, rotation, dofs)


# ---------------------------------------------------------------- connecting two kinds

LOOPS = ("hook", "hole")


def opening(p: Primitive) -> float:
    """Inside diameter of a hook or hole: what can pass through it."""
    return 2.0 * (p.params["arc_radius"] - p.params["thickness"])


def across(p: Primitive) -> float:
    """How thick it is where another part goes around it (mm across)."""
    if p.kind in LOOPS:
        return 2.0 * p.params["thickness"]
    if p.kind == "rod":
        return 2.0 * p.params["radius"]
    if p.kind == "tube":
        return 2.0 * (p.params["inner_radius"] + p.params["thickness"])
    if p.kind == "edge":
        return p.params["height"]
    if p.kind == "clip":
        return p.params["width"]
    if p.kind == "hemisphere":
        return 2.0 * p.params["radius"]
    return 0.0


ROUND = ("rod", "tube", "hook", "hole")  # what a loop goes round: round in section


def yaw_jam_deg(loop: Primitive, inside: Primitive) -> float | None:
    """How far a hook or ring turns from square about the line of its contact
    (its flex angle `phi`, a yaw) on the round wire, rod or tube it goes round,
    before its wire jams on it; None where `inside` is not round or `loop` is
    no loop.

    Turned by b, the loop's plane cuts the rod (radius r) in an ellipse with
    half-axes r across the loop's wire and a = r / cos b along it, resting at
    the bottom of the loop's inner circle (radius p, the wire's inner side).
    Centred on the circle's centre, the ellipse's point at angle t from the
    contact lies at squared distance p^2 + (1 - cos t) x ((1 + cos t)(a^2 -
    r^2) - 2 (p - r) r), within the circle for every t while a^2 <= p r (the
    bracket is largest as t -> 0: the ellipse first pokes out beside the
    contact, where its curvature radius a^2 / r passes the circle's). So the
    wire jams at cos^2 b = r / p: a hook fitting snugly (r = p) cannot turn; a
    link of 14 mm inner radius on a 3 mm wire turns 62.4 degrees.
    """
    if loop.kind not in LOOPS or inside.kind not in ROUND or loop.flags.get("centerline"):
        return None
    rho, r = opening(loop) / 2.0, across(inside) / 2.0
    if rho <= r:
        return 0.0
    return math.degrees(math.acos(math.sqrt(r / rho)))


def yaw_jam_between(a: Primitive, b: Primitive) -> float | None:
    """How far two connected primitives turn about the line of their contact
    before a wire jams (degrees from square): the less of each loop's on what
    it goes round (a link on a thick ring jams on the ring's wire before the
    ring jams on the link's); None where neither is a loop round something round."""
    jams = [jam for loop, inside in ((a, b), (b, a)) if (jam := yaw_jam_deg(loop, inside)) is not None]
    return min(jams, default=None)


def tilt_jam_deg(loop: Primitive, rod: Primitive) -> float | None:
    """How far a hook or ring hanging on a rod tilts along it (the rod's `phi`,
    the loop's plane turned about the horizontal line across the rod at the
    contact) before its wire jams; None where `rod` is no rod or `loop` no
    loop, and where the loop fits snugly (`grips`: it does not tilt).

    Tilted by b, the loop's plane cuts the rod (radius r) in an ellipse of
    half-axes r across the rod and a = r / cos b along the line of the
    contact, which ends at the contact: the ellipse, touching the loop's inner
    circle (radius p) there, stays inside it while a <= p (its point at angle
    t from the contact lies at squared distance p^2 - (1 - cos t) x (2 a (p -
    a) + (1 + cos t)(a^2 - r^2)) from the circle's centre: within p^2 while
    the bracket is positive; past a = p the far end, t = pi, at (2 a - p)^2,
    pokes out first). So it jams at cos b = r / p, later than
    the turn about the contact line (cos^2 b = r / p): an eye ring 10.3 mm
    inside on an 8 mm rod tilts 39.2 degrees."""
    if rod.kind != "rod" or loop.kind not in LOOPS or loop.flags.get("centerline"):
        return None
    rho, r = opening(loop) / 2.0, across(rod) / 2.0
    return math.degrees(math.acos(r / rho)) if rho > r else None


def grips(loop: Primitive, rod: Primitive) -> bool:
    """Whether a hook or ring fits round a rod or tube so snugly that it holds
    it all round (its inside no wider than the rod: a wire hook bent open
    round it, N416): it cannot tilt along it (`tilt_jam_deg` has no jam
    there), and no side of it can lift off (`solve.falls`: a small S-hook on
    a 20 mm broom handle holds it at the root of its arc as well as at its
    lowest point, the handle filling the arc)."""
    if rod.kind not in ("rod", "tube") or loop.kind not in LOOPS or loop.flags.get("centerline"):
        return False
    return rod.variant != "TubeCtl" and opening(loop) <= across(rod)  # not threaded through its core


def ring_spin_stop_deg(ring: Primitive, hook: Primitive) -> float | None:
    """How far a ring hanging on a hook turns about its own wire (its `spin`)
    before the far side of the ring meets the hook's wire; None where the ring
    is too large for its far side ever to reach the hook's arc (a hoop).

    The spin turns the ring in the hook's plane about the ring's wire at the
    contact. With the wires' centre lines d = w_ring + w_hook apart there, the
    hook's centre line a circle of radius P whose centre lies P above the
    hook's, and the ring's far side 2 R from the ring's (its centre line's
    radius R), turned by b from straight down: the far side lies at squared
    distance 4 R^2 + (P + d)^2 + 4 R (P + d) cos b from the hook's centre, and
    meets the hook's wire (at P + d) where cos b = -R / (P + d): past 90
    degrees always, so a ring can lie flat under a hook only if it is large;
    an eye ring of R = 10 on a hook of P = 16 (wire radius 2 mm) turns 120 degrees."""
    if ring.kind != "hole" or hook.kind != "hook":
        return None
    big_r = ring.params["arc_radius"]
    reach = hook.params["arc_radius"] + hook.params["thickness"] + ring.params["thickness"]
    return math.degrees(math.acos(-big_r / reach)) if big_r < reach else None


# the variants whose `phi` turns about the line of the contact
FLEXING = ("HookFlex", "RingFlex", "RingFlexSpin")
TILTING = ("Rod", "RodCtl")  # the variants whose `phi` tilts what hangs on them along them
SPINNING = ("RingSpin", "RingFlexSpin")  # the variants whose `spin` turns them about their own wire


def is_ring_twist(variant: str, dof_name: str) -> bool:
    """Whether a DoF is a spinning ring's twist about the line of its contact
    (a toss ring's `flex`), which exists only in a hack with loops
    (fabhal/model.py `_twisting` says why)."""
    return variant == "RingFlexSpin" and dof_name == "phi"


def is_flex_angle(dof: Dof, variant: str) -> bool:
    """Whether `dof` is a flex angle: the `phi` of a flexible hook or ring, its
    turn about the line of its contact."""
    return variant in FLEXING and dof.name == "phi"


def jam_of(dof: Dof, primitive: Primitive, other: Primitive) -> float | None:
    """Where a wire jams the turn `dof` of `primitive` makes on `other`
    (degrees from square): a flex angle's (`yaw_jam_between`), a rod's tilt
    of the loop that hangs on it (`tilt_jam_deg`), a ring's spin on a hook
    (`ring_spin_stop_deg`); None for other DoFs."""
    if is_flex_angle(dof, primitive.variant):
        return yaw_jam_between(primitive, other)
    if primitive.variant in TILTING and dof.name == "phi":
        return tilt_jam_deg(other, primitive)
    if primitive.variant in SPINNING and dof.name == "spin":
        return ring_spin_stop_deg(primitive, other)
    return None


def turning_to_the_jam(dof: Dof, jam: float | None) -> Dof:
    """A flex angle or a rod's tilt turns as far as a wire jams, a ring's spin
    as far as its far side meets the hook (`jam`, from `jam_of`): its range
    becomes default +- jam, a real stop that carries what presses on it.
    Narrower or wider than the reference's [45, 135], whose ends nothing real
    holds (E509): an S-hook on a 5 mm rod sloping 50 degrees tilts 50 along it
    to hang plumb, its wire jamming only at 58.6; a spin's full turn no
    longer wraps round. A DoF with no jam, as it is."""
    if jam is None:
        return dof
    return replace(dof, low=dof.default - jam, high=dof.default + jam, jammed=True, periodic=False)


# Which kinds may connect: the paper's Table 2 (13 unordered pairs).
CONNECTABLE: frozenset[frozenset[str]] = frozenset(
    frozenset(pair)
    for pair in (
        ("hook", "hook"),
        ("hook", "hole"),
        ("hook", "rod"),
        ("hook", "tube"),
        ("hole", "rod"),
        ("hole", "tube"),
        ("hemisphere", "surface"),
        ("edge", "clip"),
        ("rod", "tube"),
        ("rod", "clip"),
        ("tube", "tube"),
        ("tube", "clip"),
        ("surface", "surface"),
    )
)


def partners(kind: str) -> list[str]:
    """The kinds `kind` can connect to, in table order."""
    return [k for k in KINDS if frozenset((kind, k)) in CONNECTABLE]


@dataclass(frozen=True)
class Alignment:
    """world(first connector) @ R(rot) == world(second connector); `flip` changes `flip_axes`."""

    rot: tuple[float, float, float]
    flip_axes: tuple[int, ...]


# One canonical direction per pair (the reference's offsets, reference section
# c.2); the other direction uses the inverse, so `connect a -- b` and
# `connect b -- a` mean the same. Keys are kinds, or variants where a variant
# differs from its kind's offset. Pairs not listed meet with no offset.
ALIGNMENTS: dict[tuple[str, str], Alignment] = {
    ("hook", "hook"): Alignment((180.0, 0.0, 90.0), (2,)),
    ("hook", "hole"): Alignment((180.0, 0.0, 90.0), (2,)),
    ("rod", "hook"): Alignment((180.0, 0.0, 90.0), (2,)),
    ("hook", "tube"): Alignment((0.0, 0.0, 90.0), (2,)),
    ("rod", "hole"): Alignment((180.0, 0.0, 90.0), (2,)),
    ("RingCtl", "RodCtl"): Alignment((0.0, 0.0, 90.0), (2,)),
    ("hole", "tube"): Alignment((0.0, 0.0, 90.0), (2,)),
    ("edge", "clip"): Alignment((0.0, 270.0, 270.0), (1, 2)),
    ("rod", "tube"): Alignment((0.0, 90.0, 0.0), ()),
    ("Rod", "TubeCtl"): Alignment((0.0, 0.0, 0.0), ()),
    ("rod", "clip"): Alignment((0.0, 180.0, 0.0), (1,)),
    ("surface", "surface"): Alignment((0.0, 0.0, 0.0), (0,)),
}


def _flipped(angle: float) -> float:
    if angle % 360.0 == 0.0:
        return 180.0
    if angle % 360.0 == 180.0:
        return 0.0
    return -angle


def _lookup(first: Primitive, second: Primitive) -> tuple[Alignment, bool] | None:
    """The table entry and whether it is written in this order (variants before kinds)."""
    for a, b in ((first.variant, second.variant), (first.kind, second.kind)):
        if (a, b) in ALIGNMENTS:
            return ALIGNMENTS[(a, b)], True
        if (b, a) in ALIGNMENTS:
            return ALIGNMENTS[(b, a)], False
    return None


def alignment_offset(first: Primitive, second: Primitive, flip: bool = False) -> Array:
    """(4, 4) rotation A with world(first connector) @ A == world(second connector)."""
    found = _lookup(first, second)
    if found is None:
        return np.eye(4)
    entry, forward = found
    rot = list(entry.rot)
    if flip:
        for axis in entry.flip_axes:
            rot[axis] = _flipped(rot[axis])
    matrix = frame_matrix((0.0, 0.0, 0.0), rot)
    return matrix if forward else matrix.T  # a rotation's inverse is its transpose
