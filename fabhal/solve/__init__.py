"""Checked program -> solution: where every part ends up.

Step 1 brings the target as close as it can to its requested frame; step 2
lets the assembly settle under gravity from there (the target free, with its
mass) and verifies the equilibrium; a part whose open connection is pushed
past the end of its range falls off. See fabhal/solve/steps.py.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace

import numpy as np

from fabhal.check.cycles import close_loops
from fabhal.diagnostics import Diagnostic, Severity, error, listed, warning, written_settings_hint
from fabhal.elaborate import Connection
from fabhal.kinematics.contact import rectangles_overlap
from fabhal.kinematics.frames import Array
from fabhal.kinematics.statics import Wrenches
from fabhal.meshes import mass_properties
from fabhal.model import Joint, Model, Side, Standing, build_model
from fabhal.optimize import Result
from fabhal.primitives import is_ring_twist
from fabhal.solve import aim as aim_mod
from fabhal.solve import reach
from fabhal.solve import target as target_mod
from fabhal.solve.contacts import (
    Contact,
    Pairs,
    check,
    coinciding,
    contact_loads,
    contact_pairs,
    contacts_at,
    crossings,
    passing_through,
    with_contacts,
)
from fabhal.solve.energy import Energy
from fabhal.solve.falls import (
    RESTLESS,
    Failure,
    Fall,
    Lean,
    LiftOff,
    Slip,
    Swivel,
    Topple,
    Turn,
    fall_diagnostic,
    falling_part,
    lifts_off,
    swivels,
    tips_off_its_feet,
    topples,
    turns_about_wires,
)
from fabhal.solve.forces import (
    Slide,
    about_the_normal,
    about_the_wire,
    connection_wrenches,
    friction_slides,
    normal_forces,
    slide_dofs,
    square_loops,
    weight_newtons,
    welded_rings,
)
from fabhal.solve.hanging import hanging_start
from fabhal.solve.spacing import (
    Spacing,
    half_width,
    spacing_constraints,
    spacing_values,
    spread,
    stopped_turns,
)
from fabhal.solve.steps import (
    FRICTION,
    FRICTION_AGREEMENT,
    FRICTION_SMOOTHING_MM,
    Fit,
    Problem,
    closure_residual_mm,
    end_of,
    feasible,
    fit_target,
    mm_per_unit,
    potential,
    settle,
    taken_apart,
    unbalanced_force,
    with_friction,
    with_target_pull,
)

LOOP_KEPT_MM = 1e-3  # a result whose loops are open by more is never solved (E506)
# a result with a part this deep in another is never solved (E508): five times the
# contact springs' give under the assembly's whole weight (fabhal/solve/contacts.py)
OVERLAP_KEPT_MM = 1.0
# two movable parts that the check's points find crossing by more than OVERLAP_KEPT_MM
# and up to this (mm) where the settle's points do not (their springs act at those
# points only): W508, a wire's edge passing between the points of a ring or link
# (the reading nook's: 2.8 mm); deeper is a part through another (E508)
CROSSING_WARNED_MM = 5.0
# settles repeated with more contact (`_settle`): each round adds the pairs of parts
# found inside each other and the check's points where the settle's missed a contact
CONTACT_ROUNDS = 3
ROUND_REASONS_TOLD = 3  # a status line names this many reasons for a round (a hoop has dozens)
EXTRA_STARTS = 3  # seeded random starts for step 1, besides the spread-out defaults
# a random start whose loops take longer to close than this is dropped: on the gallery
# those that close do so within 26 evaluations, and one that fails spends the whole budget
RANDOM_CLOSE_EVALUATIONS = 40
FALL_RETRIES = 2  # more attempts, from other seeds' starts, when a result falls apart
# a settled point whose energy curves down along some direction by more than this
# (x the assembly's weight, joules per mm of motion squared) is an unstable balance,
# where the gradient vanishes too (a hook upside down on its rod): an upside-down
# hook with a 1 mm lever arm curves about -3e-4; the gallery's stable results
# measure above -2e-6 (flat turns, finite differences)
UNSTABLE_CURVATURE = 1e-4
NUDGE_MM = 5.0  # the nudge off an unstable balance, along its way down (degrees count as mm)
# the pull towards the requested frame that picks among equally low configurations
# (x the weight, joules per mm^2 of target error): at 100 mm off it pulls with 1 % of
# the weight, which turns a free turn but barely moves what gravity holds, and the
# assembly settles again without it
TARGET_PULL = 1e-4
POLISH_ROUNDS = 2  # settles again from the result while it is not yet at rest
# KKT residual: the unbalanced generalised force per mm of motion, as a fraction of
# the assembly's total weight; 1e-3 = 0.1 % of the weight left unbalanced
EQUILIBRIUM_TOLERANCE = 1e-3
# settling stops at a tenth of that: the verification then has room for rounding
SETTLE_TOLERANCE = 0.1 * EQUILIBRIUM_TOLERANCE
# settling again while the contacts' normal forces still change by more than
# FRICTION_AGREEMENT (friction comes from them)
FRICTION_ROUNDS = 3
# two settled results from different starts are the same when their targets are
# this close: a builder's precision (see fabhal/solve/reach.py)
DISAGREE_MM = 5.0
DISAGREE_DEG = 5.0
# a lean pushed against its stop by more than this (x the weight, per mm of motion; a
# degree counts as a mm) is held by nothing real: the gallery's leans rest on their stops
# with at most 0.0009, the basket on two eye hooks written without `flip` with 0.52
LEAN_CARRIES = 0.01


@dataclass(frozen=True)
class SolveOptions:
    seed: int = 0
    time_limit: float | None = None  # seconds, from the start of the command (for messages)
    deadline: float = float("inf")  # time.monotonic() when the time limit ends, for every stage
    gravity: bool = True
    # choose what the builder sets once so that the settled target lands nearest (fabhal/solve/aim.py);
    # False: the paper's two steps, those choices left where step 1 put them
    aim: bool = True
    progress: Callable[[str], None] | None = None  # told what the solver is doing, for a status line
    # continue from this configuration of the model instead of fitting the target (step 1): a
    # neighbouring member of a family, solved, whose settings this member may keep (`fabhal search
    # --smooth`); settled, aimed and verified from there as any start is
    start: Array | None = None
    # say what limits a target out of reach (W505's help: a fit more); a family's members,
    # whose notes `fabhal search` keeps as codes only, skip it
    explain: bool = True

    def report(self, doing: str) -> None:
        if self.progress is not None:
            self.progress(doing)


class NumericFailure(Exception):
    """The solver's numbers stopped being numbers (NaN or infinite) in a step:
    which step, and the first part whose frame, mass or centre of mass broke."""

    def __init__(self, step: str, part: str) -> None:
        self.step, self.part = step, part
        super().__init__(f"non-finite numbers in {step} at part {part}")


@dataclass(frozen=True)
class Solution:
    status: str  # solved, falls_apart, not_at_rest
    model: Model
    x: Array
    frames: Array
    masses: Array  # grams per part
    goal: target_mod.TargetGoal
    energy: float  # joules (0 at z = 0)
    residual: float  # largest loop-closure error, mm
    equilibrium: float | None  # KKT residual after settling, relative; None without gravity
    at_bound: tuple[int, ...]  # DoFs resting on an end of their range
    falls: tuple[Failure, ...]
    diagnostics: tuple[Diagnostic, ...]
    # (J, 3) N that each connection's a side exerts on its b side, world axes; None without gravity
    forces: Array | None = None
    contacts: tuple[Contact, ...] = ()  # where parts rest on the environment (with gravity)
    # mm: how far step 1 left the target from its requested position where the parts cannot
    # reach it (W505: their lengths fall short or over, which turning a connection over may
    # change, `_aligned_nearer`); 0 where they can, or where only the rotation is out of reach
    out_of_reach_mm: float = 0.0
    # (part, environment) pairs the result leaves more than OVERLAP_KEPT_MM inside each other (E508)
    in_the_world: tuple[tuple[int, int], ...] = ()

    def target_frame(self) -> Array:
        return target_mod.achieved(self.goal, self.frames)

    def target_errors(self) -> tuple[float, float]:
        return target_mod.errors(self.goal, self.target_frame())


def solve(model: Model, options: SolveOptions, loop_start: Array | None = None) -> Solution:
    """Fit, settle, verify. A configuration that falls apart may be the fault of
    the start rather than the design (step 1 can leave a `fixed` hook turned onto
    its tip): FALL_RETRIES more attempts from the next seeds' starts, and of those
    that hang at rest the one `_rank` prefers is the answer, with a note saying
    so. The design falls apart when no attempt hangs at rest (one that holds but
    is not at rest, or lies in the world, is no answer). A result that does not
    hang at rest (on a lean's stop, or not at rest at all) may be the fault of
    how a connection is turned: where the program leaves that open, the solver
    turns it over (`_aligned`); where it wrote it, the error says whether
    turned over it would hang (`_with_flip_advice`). Where one that falls
    apart leans on a stop or lies in the environment, it is turned over
    before other starts are tried. One that hangs at rest with loops but with
    a toss ring twisted on its jam is turned over there, and kept so where it
    then rests lower (`_untwisted`). One that hangs at rest
    but whose parts cannot reach the requested position is turned over where
    the program leaves that open, and kept so where it then hangs nearer
    (`_aligned_nearer`)."""
    if options.time_limit is not None and not np.isfinite(options.deadline):
        options = replace(options, deadline=time.monotonic() + options.time_limit)
    first = _solve_once(model, options, loop_start)
    # without gravity, or from a continued start, one try: the member's own solve makes the others
    one_try = not options.gravity or options.start is not None
    turning = None if one_try else _with_loops_turning(model, options, loop_start, first)
    if turning is not None:
        return turning
    jammed = _jammed_rings(model, first) if first.status == "solved" and not one_try else []
    if jammed:
        first = _untwisted(model, options, first, jammed)
    if first.status == "solved" and first.out_of_reach_mm > 0.0 and not one_try:
        return _aligned_nearer(model, options, first)
    if first.status in ("solved", "infeasible", "error") or one_try:
        return first
    if first.falls and all(isinstance(fall, Turn) for fall in first.falls):
        # a ring held still by the model's contact: the ring's model is what fails, not the
        # start or the way a connection is turned (the reading nook's rings, from seeds 0-3)
        return first
    if not first.falls:  # not at rest, or inside something: turned over, it may hang
        return _aligned(model, options, first) or _with_flip_advice(model, options, first)
    turned_first = all(isinstance(fall, Lean) for fall in first.falls) or first.in_the_world
    if turned_first:
        # a builder turns such a connection over first, as one whose mug hangs into the
        # rod it hangs from does (no other start takes it out: a user's mug on one S-hook
        # lay 3.6-4.6 mm inside the rod from three seeds before it was turned, 2.8 s)
        turned = _aligned(model, options, first)
        if turned is not None:
            return turned
    held: list[tuple[int, Solution]] = []
    for k in range(1, FALL_RETRIES + 1):
        if time.monotonic() > options.deadline:
            break
        options.report(f"it fell apart; trying again from seed {options.seed + k}")
        retry = _solve_once(model, replace(options, seed=options.seed + k), None)
        # only one that hangs at rest: a start that holds but is not at rest, or lies in the
        # world, is no answer, and the fall is (a mug on an S-hook on an open rod tilted 30
        # degrees was shown not at rest 3.4 mm inside the rod, "nothing falls apart")
        if retry.status == "solved":
            held.append((k, retry))
    if not held:
        # a contact that pulls is often a connection turned the wrong way (a hook hung
        # from inside a ring's top): turned over, it may hang
        # (not again where they were turned over first: the same solves, each whole)
        lifts = any(isinstance(fall, LiftOff) for fall in first.falls) and not turned_first
        return (lifts and _aligned(model, options, first)) or _with_flip_advice(model, options, first)
    # of the attempts that hold, the rule between starts (`_pick`): at rest, then nearest the request
    k, best = min(held, key=lambda attempt: _rank(attempt[1].goal, attempt[1].frames, attempt[1]))
    fall = first.falls[0]
    note = Diagnostic(
        Severity.NOTE,
        "N504",
        f"from the first start `{fall.part}` {_what_failed(fall)} here; from another start (seed "
        f"{options.seed + k}) the design holds",
        model.joints[fall.joint].connection.span,
        "the result is that configuration; set up by hand, mind how this connection is turned",
    )
    return replace(best, diagnostics=(note, *best.diagnostics))


def _what_failed(fall: Failure) -> str:
    if isinstance(fall, Topple):
        return "fell over"
    if isinstance(fall, Slip):
        return "slid on its feet"
    if isinstance(fall, LiftOff):
        return "lifted off its contact"
    if isinstance(fall, Turn):
        return "was held by its ring's contact kept on the inner line"
    if isinstance(fall, Swivel):
        return "was held square in a hook or ring by the model"
    return "hung on a lean's limit" if isinstance(fall, Lean) else "slid off"


def _suspects(model: Model, result: Solution) -> list[int]:
    """The joints to turn over where the result does not hang at rest: where
    something falls or leans on a stop, those joints, then the others on the
    same primitive of the environment (of two eye hooks on one door rod,
    turning the one that does not lean may be what lets the other hang); where
    nothing does (not at rest, E503, or in the environment, E508), or what
    fails is not on the environment (a basket's handle lifting off its eye
    hook, E512, whose eye rings on the door are turned the wrong way), those
    that hang a part on the environment."""
    failing = list(dict.fromkeys(fall.joint for fall in result.falls))

    def places(joints: Iterable[Joint]) -> set[tuple[int, str]]:
        return {
            (side.part, side.primitive.name)
            for joint in joints
            for side in (joint.a, joint.b)
            if model.parts[side.part].environment
        }

    on_the_world = places(model.joints[j] for j in failing) or places(model.joints)
    beside = [
        joint.index
        for joint in model.joints
        if any((side.part, side.primitive.name) in on_the_world for side in (joint.a, joint.b))
    ]
    return list(dict.fromkeys(failing + beside))


# connections turned over at most, each a whole solve (a hoop on 12 ceiling hooks has 12 suspects)
TURNS_TRIED = 4


def _suspect_connections(model: Model, result: Solution, aligned: bool) -> list[Connection]:
    """The suspects' connections (`_suspects`), in that order, TURNS_TRIED at
    most: those whose alignment the program wrote (`aligned`) or those it
    leaves open (which the solver may turn over)."""
    connections = [
        model.joints[j].connection
        for j in _suspects(model, result)
        if model.joints[j].connection.aligned == aligned
    ]
    return connections[:TURNS_TRIED]


# degrees: a plain hook or ring turned less than this on its rod rests square
SQUARE_DEG = 1.0


def _loops_would_turn(model: Model, result: Solution) -> str | None:
    """Why a result of a hack with loops, in a model whose plain hooks and rings
    are held square on what they go round, needs them to turn about the line of
    their contact (`_with_loops_turning`): "E514" where a rod held square
    carries what a contact at a point cannot, "E423" where the loops close
    only with two parts in one place (a turned hook may close them apart);
    None where neither. A tree that rests against something is loops closed
    through that contact: a newcomer's hanger, its hook round a car seat's
    upright headrest post and its side against the seat back, was `not at
    rest` (E514) where the real hook turns on the post. A tree that rests on
    nothing hangs with the weight's line through each contact, and a turn
    there carries nothing (a rod held in a ring's side by a written setting
    stays E514: what holds it there is the setting, not the turn)."""
    if model.turning_on_contact or not (model.closures or result.contacts):
        return None
    if any(isinstance(fall, Swivel) for fall in result.falls):
        return "E514"
    if result.status == "infeasible" and any(d.code == "E423" for d in result.diagnostics):
        return "E423"
    return None


# what N508 says a square model needed, by the code `_loops_would_turn` gives
SQUARE_NEEDED = {
    "E514": "the hack needed a contact to carry what a point cannot (E514)",
    "E423": "its loops closed only with two parts in one place (E423)",
}


def _with_loops_turning(
    model: Model, options: SolveOptions, loop_start: Array | None, result: Solution
) -> Solution | None:
    """A hack with loops (or a tree resting on something, which that contact
    closes into loops) whose `result` needs its plain hooks and rings to turn
    about the line of their contact (`_loops_would_turn` says why): solved again (the
    whole `solve`) with every plain hook and ring round a rod, or on another
    hook or ring, free to (`model._turning_on_its_contact`), from the loops'
    closing start with those turns square (it closes them still; step 1 alone
    let a stick's loop come open), with the loops' play kept; that result
    where it hangs at rest, N508 saying which turned most (none where all rest
    square: the square model's start was at fault). None where it does not
    hang at rest either, where `result` needs no turn, or where nothing in it
    could turn so."""
    needed = _loops_would_turn(model, result)
    if needed is None:
        return None
    turning = build_model(model.program, turning_on_contact=True)
    if len(turning.variables) == len(model.variables):
        return None  # no plain hook or ring on what it goes round: the same model, the same answer
    if loop_start is not None:
        loop_start = _same_values(model, turning, loop_start)
        if model.closure_play:
            turning = turning.with_play(loop_start)
    options.report("solving again with hooks and rings turning on what they go round")
    result = solve(turning, options, loop_start)
    if result.status != "solved":
        return None
    turns = _contact_turns(model, turning, result.x)
    angle, joint, loop, on = max(turns, key=lambda turn: turn[0], default=(0.0, None, "", ""))
    if joint is None or angle < SQUARE_DEG:
        return result
    note = Diagnostic(
        Severity.NOTE,
        "N508",
        f"turned: `{loop}` rests turned {angle:.0f} degrees about the line of its contact with `{on}`; "
        f"held square, as the reference holds plain hooks and rings, {SQUARE_NEEDED[needed]}",
        joint.connection.span,
        "build it so: the hook or ring lies turned on what it goes round as the result shows (--dofs "
        "lists each turn, the connection's `phi`)",
    )
    return replace(result, diagnostics=(note, *result.diagnostics))


def _same_values(model: Model, other: Model, x: Array) -> Array:
    """x of `model` as a DoF vector of `other`, a model of the same program
    with more DoFs: each DoF of the same connection, side and name as in x,
    the others at their defaults."""
    at = {(v.joint, v.side, v.dof.name): value for v, value in zip(model.variables, x, strict=True)}
    return np.array([at.get((v.joint, v.side, v.dof.name), v.dof.default) for v in other.variables])


def _contact_turns(model: Model, turning: Model, x: Array) -> list[tuple[float, Joint, str, str]]:
    """(degrees from square, connection, the hook or ring, what it turns on) of
    each turn `turning` gave a plain hook or ring that `model` holds square, at
    x (of `turning`)."""
    return [
        (
            abs(float(x[i]) - turning.variables[i].dof.default),
            joint,
            str(joint.endpoint(side)),
            str(joint.endpoint(other)),
        )
        for square, joint in zip(model.joints, turning.joints, strict=True)
        for before, side, other in ((square.a, joint.a, joint.b), (square.b, joint.b, joint.a))
        if before.primitive.variant != side.primitive.variant
        for i in side.dof_indices
        if turning.variables[i].dof.name == "phi"
    ]


def _turned(model: Model, connection: Connection) -> Model:
    """The design with `connection` turned over (`flip` toggled)."""
    turned = replace(connection, flip=not connection.flip)
    program = replace(
        model.program,
        connections=tuple(turned if c is connection else c for c in model.program.connections),
    )
    return build_model(program, model.turning_on_contact)


def _solved_turned(
    turned: Model, options: SolveOptions, connection: Connection, why: str = "it does not hang at rest"
) -> Solution | None:
    """The design turned over at `connection` (`_turned`), if it solves; None
    otherwise. Where it falls apart from its first start it is tried from the
    next seeds' too (FALL_RETRIES), as `solve` tries a design: its first start
    may be at fault (three chains from ceiling hooks with one turned over fell
    apart from two starts and hung level from the third)."""
    for seed in range(options.seed, options.seed + 1 + FALL_RETRIES):
        if time.monotonic() > options.deadline:
            return None
        again = f", from seed {seed}" if seed != options.seed else ""
        options.report(f"{why}; trying {connection.a} -- {connection.b} turned over{again}")
        other = _solve_once(turned, replace(options, seed=seed), None)
        if other.status == "solved":
            return other
        turning = _with_loops_turning(turned, replace(options, seed=seed), None, other)  # as `solve` does
        if turning is not None:
            return turning
        if not other.falls:
            return None  # it holds together but not at rest: retried only where it falls, as a design is
    return None


def _aligned(model: Model, options: SolveOptions, result: Solution) -> Solution | None:
    """A hack that does not hang at rest (held only by a lean's limit, E509; not
    at rest, E503; inside the environment, E508; or needing a contact to
    pull from every start, E512), where the program leaves the
    alignment of a suspect connection (`_suspects`) open (neither `flip` nor
    `noflip`): the solver chooses it. The first of them that hangs at rest
    turned over gives the result, with N507 saying so; None if none does."""
    for connection in _suspect_connections(model, result, aligned=False):
        turned = _solved_turned(_turned(model, connection), options, connection)
        if turned is not None:
            note = _aligned_note(connection, turned, _failure(result))
            return replace(turned, diagnostics=(note, *turned.diagnostics))
    return None


def _aligned_nearer(model: Model, options: SolveOptions, result: Solution) -> Solution:
    """A hack that hangs at rest where its parts cannot bring the target to the
    requested position (W505: their lengths fall short or over), and where
    the program leaves open the alignment of a connection that hangs a part
    on the environment (`_suspects`): turned over, the lengths change (an eye
    hook's hook opens up instead of down), and it may hang nearer, as a
    builder whose basket hangs short and askew turns its eye hook over. A
    turn is solved only where a short step 1 (`_fitted_position`) brings the
    target nearer the requested position by more than a builder's eye
    (`reach.REACH_MM`): a chain 400 mm short stays short either way round.
    The turned design that hangs at rest nearest the request, where it is
    nearer than `result` by more than ALIGNED_NEARER_MM, with N507 saying
    so; else `result`. Not where only the rotation is out of reach: how the
    target is held sets that."""
    position, rotation = result.target_errors()
    best: tuple[Connection, Solution] | None = None
    nearest = position + rotation - ALIGNED_NEARER_MM
    for connection in _suspect_connections(model, result, aligned=False):
        turned_model = _turned(model, connection)
        if _fitted_position(turned_model, options) >= result.out_of_reach_mm - reach.REACH_MM:
            continue
        turned = _solved_turned(turned_model, options, connection, "it hangs out of the request's reach")
        if turned is None:
            continue
        error = sum(turned.target_errors())
        if error < nearest:
            best, nearest = (connection, turned), error
    if best is None:
        return result
    connection, turned = best
    failure = f"hangs {position:.0f} mm and {rotation:.0f} degrees from it, out of its reach (W505)"
    return replace(turned, diagnostics=(_aligned_note(connection, turned, failure), *turned.diagnostics))


def _fitted_position(model: Model, options: SolveOptions) -> float:
    """How far (mm) a short step 1 (its first start, reach.REACH_EVALUATIONS)
    brings the target from its requested position: a screen (a full step 1
    cost the chain of 100 S-hooks 0.46 s, this one 0.16)."""
    goal = target_mod.goal_of(model)
    step1, starts = step_one(model, options.seed, None, options.deadline)
    pairs = contact_pairs(model, lambda _: None)
    fit = fit_target(step1, goal, [next(starts)], pairs, reach.REACH_EVALUATIONS)
    return target_mod.errors(goal, target_mod.achieved(goal, model.part_frames(step1.full(fit.v))))[0]


def _jammed_rings(model: Model, result: Solution) -> list[Connection]:
    """The connections, in a hack with loops, where a toss ring rests with its
    twist about the contact on its jam (`primitives.is_ring_twist`), whose
    alignment the program leaves open (TURNS_TRIED at most)."""
    if not model.closures:
        return []
    jammed = [
        joint.connection
        for joint in model.joints
        if not joint.connection.aligned
        and any(
            i in result.at_bound and is_ring_twist(side.primitive.variant, dof.name)
            for side in (joint.a, joint.b)
            for i, dof in zip(side.dof_indices, side.primitive.dofs, strict=True)
        )
    ]
    return jammed[:TURNS_TRIED]


def _untwisted(model: Model, options: SolveOptions, result: Solution, jammed: list[Connection]) -> Solution:
    """A hack with loops that rests with a toss ring twisted on its jam at the
    connections `jammed` (`_jammed_rings`): a ring meets a wire one way round or the other, the same
    ring turned half round the contact's line, but in a loop the two close it
    differently, one of them only with rings twisted as far as their wires
    let them. A builder lets a ring hang untwisted; so each such connection is
    turned over, and the turned design that rests at rest lowest, lower than
    `result` by more than UNTWISTED_J, is the result, with N507 saying so (a
    basket on two toss rings with a bottle in it rested tilted 6 degrees with
    all four twists on their jams, 0.265 J above its level rest turned over).
    Else `result`."""
    best: tuple[Connection, Solution] | None = None
    lowest = result.energy - UNTWISTED_J
    for connection in jammed:
        turned = _solved_turned(
            _turned(model, connection), options, connection, "a ring rests twisted on its jam"
        )
        if turned is not None and turned.energy < lowest:
            best, lowest = (connection, turned), turned.energy
    if best is None:
        return result
    connection, turned = best
    higher = result.energy - turned.energy
    failure = f"rests {higher:.3f} J higher, a toss ring twisted on its contact as far as it goes"
    return replace(turned, diagnostics=(_aligned_note(connection, turned, failure), *turned.diagnostics))


# joules: a turned design that rests lower than this is a lower rest, not the same one
UNTWISTED_J = 1e-3


# a design turned over is kept where it hangs nearer the request than this (mm, with
# degrees counted as mm, as `_rank` adds them): less is the same place
ALIGNED_NEARER_MM = 1.0


def _with_flip_advice(model: Model, options: SolveOptions, result: Solution) -> Solution:
    """A hack that does not hang at rest (`_suspects`) on a connection whose
    alignment the program wrote (`flip` or `noflip`): the result stays the
    program's own, and if that connection turned the other way hangs at rest,
    the error says so (E509 at that connection; else the first error's help
    names it), with how near the request it would hang."""
    for connection in _suspect_connections(model, result, aligned=True):
        turned = _solved_turned(_turned(model, connection), options, connection)
        if turned is None:
            continue
        position, rotation = turned.target_errors()
        written = "without `flip`" if connection.flip else "with `flip`"
        hangs = (
            f"written {written} hangs the hack at rest, {position:.0f} mm and {rotation:.0f} degrees "
            "from the request"
        )
        return replace(result, diagnostics=_advised(result.diagnostics, connection, hangs))
    return result


def _advised(
    diagnostics: tuple[Diagnostic, ...], connection: Connection, hangs: str
) -> tuple[Diagnostic, ...]:
    """The diagnostics with `hangs` (what the connection turned over does) as the
    help of its E509, or where it has none, of the first error (naming it)."""
    if any(d.code == "E509" and d.span == connection.span for d in diagnostics):
        return tuple(
            replace(d, help=f"this connection {hangs}")
            if d.code == "E509" and d.span == connection.span
            else d
            for d in diagnostics
        )
    first = next((d for d in diagnostics if d.is_error), None)
    named = f"`{connection.a} -- {connection.b}` (line {connection.span.line}) {hangs}"
    return tuple(replace(d, help=named) if d is first else d for d in diagnostics)


def _failure(result: Solution) -> str:
    """Why the default way round does not hang, for N507."""
    if any(isinstance(fall, Lean) for fall in result.falls):
        return "rests only on a lean's stop (E509)"
    first = next((d.code for d in result.diagnostics if d.is_error), result.status)
    return f"does not hang at rest ({first})"


def _aligned_note(connection: Connection, turned: Solution, failure: str) -> Diagnostic:
    """N507: the solver turned a connection whose alignment the program left open."""
    position, rotation = turned.target_errors()
    return Diagnostic(
        Severity.NOTE,
        "N507",
        f"aligned: `{connection.a} -- {connection.b}` turned over (as `flip` writes it): so the hack "
        f"hangs at rest, {position:.0f} mm and {rotation:.0f} degrees from the request; the default way "
        f"round {failure}",
        connection.span,
        "build it turned over; write `flip` to say so, or `noflip` to keep the default way round and see "
        "what it does",
    )


def _solve_once(model: Model, options: SolveOptions, loop_start: Array | None) -> Solution:
    goal = target_mod.goal_of(model)
    masses, centres = _mass_table(model)
    notes: list[Diagnostic] = []

    step1, starts = step_one(model, options.seed, loop_start, options.deadline)
    pairs = contact_pairs(model, options.report)
    if options.start is not None and len(options.start) == len(model.variables):
        fit = _continued(step1, goal, options.start, pairs)
    else:
        options.report("step 1: bringing the target to its frame")
        fit = fit_target(step1, goal, starts, pairs)
    x = step1.full(fit.v)
    crowded = None if fit.late or loop_start is None else _crowded(step1, fit.v, loop_start)
    if crowded is not None:  # no start closes the loops with the parts kept apart
        frames = model.part_frames(x)
        return Solution(
            "infeasible", model, x, frames, masses, goal, _energy(frames, masses, centres),
            closure_residual_mm(model, x), None, (), (), (crowded,),
        )  # fmt: skip
    # step 1 moves parts without their masses: only its frames can break
    _require_finite(
        model, x, np.zeros_like(masses), np.zeros_like(centres), "step 1 (bringing the target to its frame)"
    )
    fitted = target_mod.errors(goal, target_mod.achieved(goal, model.part_frames(x)))
    out_of_reach_mm = 0.0  # where the parts cannot bring the target to its requested position (W505)
    if fit.late:
        notes.append(_late(options))
    elif not step1.out_of_time() and reach.out_of_reach(fitted):
        options.report("step 1: the target is out of reach; finding what limits it")
        loose, loose_position = reach.loosened(step1, goal, x)
        out_of_reach_mm = fitted[0] if reach.position_out_of_reach(fitted[0], loose_position) else 0.0
        # a family's member keeps its notes as codes: the explanation is not written
        explained = reach.diagnose(step1, goal, x, loose, loose_position) if options.explain else None
        notes.append(explained or reach.unexplained(model, goal, x))

    settled = Settled(x, None, (), ())
    if options.gravity:
        options.report("step 2: settling under gravity")
        _require_finite(model, x, masses, centres, "step 2 (settling under gravity)")
        # out of time: step 1's result as it is, not verified at rest (W502 says why)
        settled = (
            Settled(x, np.inf, (), ())
            if step1.out_of_time()
            else _settle(
                step1,
                x,
                masses,
                centres,
                goal,
                pairs.dense(fit.untangled),
                leaning=fit.untangled,
                tell=_told(options, "step 2"),
            )
        )
        if fit.runner_up is not None and not step1.out_of_time():
            options.report("step 2: settling from another start")
            start = step1.full(fit.runner_up)
            # a plain settle to compare; the stability test and the turn only if it wins
            other = _settle(
                step1, start, masses, centres, goal, settled.pairs or pairs, False, settled.leaning
            )
            settled, disagreement = _pick(
                model, goal, settled, other, lambda s: _energy(model.part_frames(s.x), masses, centres)
            )
            if settled is other:
                settled = _settle(
                    step1, start, masses, centres, goal, other.pairs or pairs, leaning=other.leaning
                )
            if disagreement is not None:
                notes.append(disagreement)
        if options.aim and not step1.out_of_time():
            settled, aimed = _aimed(step1, settled, masses, centres, goal, settled.pairs or pairs, options)
            notes.extend(aimed)
        if not settled.falls and not _at_rest(settled) and np.isfinite(settled.equilibrium or 0.0):
            notes.append(
                error(
                    "E503",
                    "not at rest: where the solver stopped, a force of "
                    f"{100 * (settled.equilibrium or 0.0):.1f} % of the assembly's weight "
                    "is still unbalanced",
                    model.program.targets[0].span,
                    _not_at_rest_help(options, step1.out_of_time()),
                )
            )
        if step1.out_of_time() and not fit.late:
            notes.append(_late(options))
        _require_finite(model, settled.x, masses, centres, "step 2 (settling under gravity)")
    x = settled.x
    frames = model.part_frames(x)
    if options.gravity and not settled.falls and not settled.contacts:  # nothing leans on the world
        away = reach.hangs_away(model, goal, x)
        if away:
            turned = target_mod.errors(goal, target_mod.achieved(goal, frames))[1]
            if not out_of_reach_mm and turned <= reach.REACH_DEG:
                # W505 said only the rotation kept step 1 (gravity off) from the request; hanging,
                # it is turned as asked and rests beside or below it for what W506 or W511 says
                notes = [n for n in notes if n.code != "W505"]
            notes.extend(away)
    if not reach.out_of_reach(target_mod.errors(goal, target_mod.achieved(goal, frames))):
        # it hangs within reach of the request: step 1 (gravity off) missed a reach the parts
        # have, and W505's "they reach only so far" would be false (a basket on a ring and an
        # S-hook from a ceiling hook, aimed to 0.0 mm, was said to stay 28 mm away)
        notes = [n for n in notes if n.code != "W505"]
        out_of_reach_mm = 0.0
    looked = settled.pairs or pairs  # the contact as the settle ended with it
    through = crossings(model, x, looked)
    overlaps = _overlaps(model, x, looked, masses)
    falls = _judged_beside(model, settled.falls, overlaps)
    diagnostics = [*notes, *(fall_diagnostic(model, f) for f in falls)]
    gap = closure_residual_mm(model, x)
    if gap > LOOP_KEPT_MM:
        diagnostics.append(
            error(
                "E506",
                f"a loop is open by {gap:.3g} mm where the solver stopped: the parts cannot be where shown",
                model.program.targets[0].span,
                "a solver fault, not the design's (the check closed every loop): try another --seed, "
                "and report the program",
            )
        )
    standing_through = [c for c in through if _standing_between(model, c[0], c[1]) is not None]
    on_one_spot = _stood_on_one_spot(model, x)
    in_one_place = coinciding(model, x, looked)
    if on_one_spot:  # identical objects stood on one spot coincide: no point of one is inside the other
        diagnostics.append(_one_spot_diagnostic(model, *on_one_spot[0]))
    elif in_one_place:
        diagnostics.append(_one_place_diagnostic(model, *in_one_place[0]))
    elif standing_through:  # the connection holds them so: what the two are is the message, not the walls
        stood, carrier, _ = standing_through[0]
        deepest = max(
            (d for p, o, d in check(model, x, looked).overlaps(looked, 0.0) if {p, o} == {stood, carrier}),
            default=0.0,
        )
        diagnostics.append(_overlap_diagnostic(model, x, looked, stood, carrier, deepest))
    elif through and (not overlaps or overlaps[0][2] <= CROSSING_WARNED_MM):
        # thin walls through each other: how far they cross says it, their depth would not
        diagnostics.append(_through_diagnostic(model, *through[0]))
    elif overlaps:
        diagnostics.append(_overlap_diagnostic(model, x, looked, *overlaps[0]))
    else:
        warned = _crossings(model, x, looked)
        diagnostics.extend(_crossing_diagnostic(model, *crossing) for crossing in warned[:1])
    if any(not isinstance(fall, RESTLESS) for fall in falls):
        status = "falls_apart"
    elif falls:
        status = "not_at_rest"  # held by a lean's stop, or feet that slide: not a state of rest
    else:
        apart = not (overlaps or through or on_one_spot or in_one_place)
        held = _at_rest(settled) and gap <= LOOP_KEPT_MM and apart
        status = "solved" if held else "not_at_rest"
    return Solution(
        status,
        model,
        x,
        frames,
        masses,
        goal,
        _energy(frames, masses, centres),
        closure_residual_mm(model, x),
        settled.equilibrium,
        settled.at_bound,
        falls,
        tuple(diagnostics),
        settled.forces,
        settled.contacts,
        out_of_reach_mm,
        tuple((part, other) for part, other, _ in overlaps if model.parts[other].environment),
    )


def _not_at_rest_help(options: SolveOptions, out_of_time: bool) -> str:
    """E503's help: more time only where a time limit ended the settle."""
    retry = (
        f"allow more time (--time-limit, {options.time_limit:g} s now) or try another --seed"
        if out_of_time and options.time_limit is not None
        else "try another --seed (the settle stopped short of a rest)"
    )
    return (
        f"the hack would move on from the result shown: {retry}; if it persists, the design has no "
        "resting place near this start (`fabhal render` shows where it stopped)"
    )


def _crowded(step1: Problem, v: Array, closed: Array) -> Diagnostic | None:
    """E423 where no start of step 1 keeps the loops closed and the parts that
    share a rod, tube, edge or hook apart (its best `v` breaks one or the other),
    and the check's closure (`closed`: it closes the loops without that rule)
    has two such parts closer than their widths allow: the design as connected
    cannot be built."""
    model = step1.model
    if not model.closures or not step1.spacing or feasible(step1, v):
        return None
    rules = spacing_constraints(model, closed)  # in the closure's own order: distances >= 0
    apart = spacing_values(rules, closed)
    k = int(np.argmin(apart))
    if apart[k] > -1e-6:
        return None  # the loops close with the parts apart: not this rule's to say
    rule = rules[k]
    first, second = (model.joints[model.variables[i].joint] for i in (rule.first, rule.second))
    shared = model.variables[rule.first].name.rsplit(".", 1)[0]
    return error(
        "E423",
        f"the loops close only with `{first.connection.a}` and `{second.connection.a}` "
        f"{rule.gap + apart[k]:.0f} mm apart along `{shared}`, closer than they fit ({rule.gap:.0f} mm)",
        second.connection.span,
        "two parts on one rod, tube, edge or hook cannot share a place: connect one of them elsewhere, "
        "or give the loop another part so it closes with them apart"
        + written_settings_hint(model.lines_setting(j for loop in model.loops for j in loop.joints)),
    )


def _continued(step1: Problem, goal: target_mod.TargetGoal, start: Array, pairs: Pairs) -> Fit:
    """A given configuration as step 1's answer: its free DoFs, within their
    ranges, what crosses in it taken apart (`steps.taken_apart`)."""
    low, high = step1.bounds()
    return taken_apart(step1, goal, np.clip(start[step1.free], low, high), pairs)


def _aimed(
    step1: Problem,
    settled: Settled,
    masses: Array,
    centres: Array,
    goal: target_mod.TargetGoal,
    pairs: Pairs,
    options: SolveOptions,
) -> tuple[Settled, list[Diagnostic]]:
    """The settled result with the builder's choices aimed (fabhal/solve/aim.py)
    if that ranks first (`_rank`) and leaves no part inside another, with a note
    saying what was chosen; else the result as it was. The aim weighs the
    contact springs that acted in the settled result."""
    model = step1.model
    chosen = aim_mod.choices(step1)
    # a result that falls apart is not aimed from (one that leans on a stop is: aiming may
    # find the settings where nothing leans)
    falls = any(not isinstance(fall, RESTLESS) for fall in settled.falls)
    if not len(chosen) or falls or not np.all(np.isfinite(settled.x)):
        return settled, []
    options.report("step 3: aiming the settings that stay put, for where the hack hangs")
    weight = _weight(masses)
    springs = _springs(model, pairs, settled.leaning)
    energy = with_contacts(model, potential(model, masses, centres), springs, weight)
    best = settled
    for _ in range(AIM_ROUNDS if not model.closures else 1):
        start = step1.full(aim_mod.aim(step1, best.x, energy, goal, weight, chosen))
        moved = np.abs((start - best.x)[step1.free] * step1.scale).max(initial=0.0)
        if not np.all(np.isfinite(start)) or moved < CHOICE_TOLD_MM or step1.out_of_time():
            break  # nothing worth settling again
        nearer = _target_distance(model, goal, best.x) - _target_distance(model, goal, start)
        if not best.falls and nearer < aim_mod.AIM_GAIN_MM:
            # the aim itself came no nearer: settled from there it would not either (from a
            # result that leans on a stop, reaching rest is the gain, not nearness)
            break
        aimed = _settle(
            step1,
            start,
            masses,
            centres,
            goal,
            best.pairs or pairs,
            leaning=best.leaning,
            tell=_told(options, "step 3"),
            rival=best,
        )
        ranks = [_rank(goal, model.part_frames(s.x), s) for s in (aimed, best)]
        inside = bool(
            _overlaps(model, aimed.x, aimed.pairs or pairs, masses)
            or crossings(model, aimed.x, aimed.pairs or pairs)
        )
        if ranks[0] >= ranks[1] or inside:
            break
        best = aimed
    if best is settled:
        return settled, []
    return best, [_choice_note(step1, chosen, settled, best.x, goal)]


def _target_distance(model: Model, goal: target_mod.TargetGoal, x: Array) -> float:
    """The target's residual at x (mm, degrees weighted as in step 1's fit)."""
    return float(np.linalg.norm(target_mod.residual(goal, target_mod.achieved(goal, model.part_frames(x)))))


# aim, settle, and aim again from where it settled: the aim's proposal is not at rest
# (its forces are only weighed against the target), and where the settle then takes it
# depends on small differences (the clip light M: 1 or 9 degrees off, by a settle's
# starting Hessian); aimed again from there, both land within a degree of each other.
# Without loops only: there a round costs a few settles (the Hessians are closed form,
# fabhal/solve/energy.py); with loops the aim differences a gradient per DoF (the
# reading nook: 1.4 s) and on the gallery's loops a second round never gained
AIM_ROUNDS = 2
# a choice that moved its connection less than this (mm; degrees as mm) is not worth telling
CHOICE_TOLD_MM = 1.0
CHOICES_TOLD = 4  # settings named in N506's message (the rest in its help)


def _choice_note(
    step1: Problem,
    chosen: aim_mod.Index,
    before: Settled,
    after: Array,
    goal: target_mod.TargetGoal,
) -> Diagnostic:
    """N506: which choices aiming changed, to what, and what that gained."""
    model = step1.model
    lengths = mm_per_unit(model)
    changed = [int(step1.free[k]) for k in chosen]
    moved = {i: abs(after[i] - before.x[i]) * lengths[i] for i in changed}
    # the settings that moved most first; the note names CHOICES_TOLD of them, the help the rest
    changed = sorted((i for i in changed if moved[i] > CHOICE_TOLD_MM), key=lambda i: -moved[i])
    position, rotation = target_mod.errors(goal, target_mod.achieved(goal, model.part_frames(after)))
    was = target_mod.errors(goal, target_mod.achieved(goal, model.part_frames(before.x)))
    step1_left = (
        f"where step 1 left them: {was[0]:.0f} mm, {was[1]:.0f} degrees"
        if not before.falls and _at_rest(before)
        else "where step 1 left them it does not hang at rest"
    )

    def told(dofs: list[int]) -> str:
        by_connection: dict[int, list[str]] = {}
        for i in dofs:
            by_connection.setdefault(model.variables[i].joint, []).append(
                aim_mod.setting_text(model, i, after[i], lengths[i])
            )
        return "; ".join(
            f"`{model.joints[j].connection.a} -- {model.joints[j].connection.b}` {', '.join(texts)}"
            for j, texts in by_connection.items()
        )

    named, rest = changed[:CHOICES_TOLD], changed[CHOICES_TOLD:]
    more = f"; and {len(rest)} more (below)" if rest else ""
    span = model.joints[model.variables[changed[0]].joint].connection.span if changed else goal.source.span
    return Diagnostic(
        Severity.NOTE,
        "N506",
        f"aimed: {told(named) or 'choices kept'}{more}; there the target hangs {position:.0f} mm and "
        f"{rotation:.0f} degrees from the request ({step1_left})",
        span,
        (f"also {told(rest)}; " if rest else "")
        + "these are set when building and stay put (a clip's grip, a `fixed` connection, where "
        "friction holds a part on a rod): build them so; --two-step keeps step 1's"
        + (
            f"; to keep one in the program, write it on its line: {_written(model, changed[0], after)}"
            if changed
            else ""
        ),
    )


def _written(model: Model, i: int, x: Array) -> str:
    """DoF i's value as the program would write it (docs/language.md, `set`)."""
    variable = model.variables[i]
    value = aim_mod.within_a_turn(variable.dof, float(x[i]))
    return f"`set ({variable.name}: {value:.6g})` (--dofs lists every setting)"


@dataclass(frozen=True)
class Settled:
    """Step 2's result: where the assembly comes to rest, and how well it is at rest."""

    x: Array
    equilibrium: float | None  # KKT residual, relative to the weight; None without gravity
    at_bound: tuple[int, ...]
    falls: tuple[Failure, ...]
    forces: Array | None = None  # (J, 3) N each connection carries there (see Solution)
    contacts: tuple[Contact, ...] = ()
    # the movable parts whose contact springs acted between them (`_settle`)
    leaning: frozenset[frozenset[int]] = frozenset()
    pairs: Pairs | None = None  # the contact pairs, as the settle refined them


def _wrenches(
    problem: Problem,
    x: Array,
    masses: Array,
    centres: Array,
    slides: list[Slide],
    contacts: tuple[Contact, ...],
    also_free: tuple[Array, Array, Array] | None = None,
) -> Wrenches:
    """What every connection carries at x: load along a motion is carried where
    the motion does not move in `problem` (held, pinned), rests on an end of its
    range, or is a slide friction holds; every other motion is free, and so are
    `also_free` (`forces.about_the_wire`). What the environment's contacts carry
    is taken off first."""
    model = problem.model
    moving = set(problem.free.tolist())
    fixed = {i for i in range(len(model.variables)) if i not in moving}
    ends = {int(problem.free[k]) for k in _resting_ends(problem, x)} | stopped_turns(model.turn_limits, x)
    loads = contact_loads(model, contacts) if contacts else None
    carrying = fixed | ends | set(slide_dofs(slides))
    slack = EQUILIBRIUM_TOLERANCE * float(weight_newtons(masses).sum())  # N left unbalanced at rest
    return connection_wrenches(model, x, masses, centres, carrying, loads, slack, also_free)


def _held_by_the_model(
    problem: Problem,
    x: Array,
    masses: Array,
    centres: Array,
    slides: list[Slide],
    contacts: tuple[Contact, ...],
    wrenches: Wrenches,
) -> tuple[Turn | Swivel, ...]:
    """What the model's connections hold at x that real contacts could not:
    welded rings that would turn about their wires (`falls.Turn`, E513) and
    rods that plain hooks or rings hold square that would turn on their
    contacts (`falls.Swivel`, E514). Each is found first in `wrenches`, the
    statics as the model has it (a ring's moment about its wire over |f| w,
    `falls.turns_about_wires`; a rod's contact carrying along the wire or
    about the line of the contact, `falls.swivels`), then confirmed where the
    statics with those turns left free (`forces.about_the_wire`,
    `forces.about_the_normal`) no longer balance the parts within the
    settle's slack (where they do, some split of a loop's load needs none:
    at rest). On the gallery none is found in the model's own statics, and
    the second statics is not made (it cost a clip light's solve 6-9 ms). A
    rod hanging in the bottom of a loop carries its load through the
    contact; one wedged across a loop's side, both contacts pushing
    sideways, cannot. Not judged where a rod's contact sits at a closed end
    of the rod: in the corner where a basket's handle bends down the loop's
    wire touches the grip and the bend, more than the one contact modelled
    (as a lean there is not, E509)."""
    model = problem.model
    newtons = float(weight_newtons(masses).sum())

    def unbalanced(free: tuple[Array, Array, Array]) -> bool:
        freed = _wrenches(problem, x, masses, centres, slides, contacts, free)
        return freed.imbalance > EQUILIBRIUM_TOLERANCE * newtons

    rings = welded_rings(model)
    turns = turns_about_wires(model, x, rings, wrenches, newtons) if rings else ()
    if turns and not unbalanced(about_the_wire(model, x, rings)):
        turns = ()
    loops = [loop for loop in square_loops(model) if not _at_a_closed_end(problem, x, loop.rod)]
    swivelling = swivels(model, x, loops, wrenches, newtons) if loops else ()
    if swivelling and not unbalanced(about_the_normal(model, x, loops)):
        swivelling = ()
    return (*turns, *swivelling)


def _settle(
    step1: Problem,
    x: Array,
    masses: Array,
    centres: Array,
    goal: target_mod.TargetGoal,
    pairs: Pairs,
    thorough: bool = True,
    leaning: frozenset[frozenset[int]] = frozenset(),
    tell: Callable[[str], None] | None = None,
    rival: Settled | None = None,
) -> Settled:
    """`_settle_with` the contact springs against the environment and between the
    movable parts that `leaning` pairs; then settled again from the same start
    (up to CONTACT_ROUNDS in all) with more contact where the result shows it
    is needed. Where two other movable parts are more than OVERLAP_KEPT_MM
    inside each other, or their walls cross (`crossings`: thin walls pass
    between the settle's points, and only the wall's millimetres show as
    depth), their springs are switched on too (the one then leans on the
    other, which carries it); crossing walls with every one of the check's
    points (`Pairs.dense`). Where the check's finer points
    (fabhal/solve/contacts.py `check`) find a part inside what its springs act
    against, between its settle's points (an edge, a wire), the check's points
    there join them (`Pairs.refined`). Not parts already inside each other at
    the start: placed so (two objects stood on one spot), no motion led there,
    and the springs would push them apart any way (E508 says it). Springs
    between movable parts are switched on only where needed: on everywhere,
    grazing contacts in a loop made the settles crawl (the reading nook: 5000
    evaluations instead of 300). The result carries the refined pairs; `tell`
    hears why a round is repeated (a settle of the caddy takes seconds).
    Where the last round still misses contact, the assembly settles once more
    from its result with that contact too (a local correction, not a round
    of its own: from the start again it would find more elsewhere; the
    caddy's S-hook then lay 1.0 mm in a seat, E508).
    A round whose first settle already misses contact goes on to the next
    without its stability test, turn and friction rounds, which the next
    round, from the start again, would throw away (the caddy's first two
    rounds: 0.7 s of 4.2).
    A settle made to be compared with a `rival` ends after a round that falls
    apart or leans on a stop where the rival does not: it will not be kept,
    and the finer rounds, which only add contact, are the slow ones (the
    reading nook's aimed settle: 0.13 s, then 1.2 s to fall again)."""
    model = step1.model
    placed_inside = _parts_inside(model, x, pairs, masses)
    placed_through: frozenset[frozenset[int]] | None = None  # looked for only if needed: 0.05 s

    def more_contact(at: Array) -> tuple[frozenset[frozenset[int]], dict[int, Array], Pairs]:
        """Where a round's result at `at` needs more contact: the parts found
        inside each other (or crossing), where the check's points found a part
        inside what its springs act against, and the pairs refined there."""
        nonlocal placed_through
        through = passing_through(model, at, pairs)
        if through:
            if placed_through is None:
                placed_through = passing_through(model, x, pairs)
            through -= placed_inside | placed_through
        inside = (_parts_inside(model, at, pairs, masses) - placed_inside) | through
        missed = _missed(model, at, pairs, leaning | inside)
        return inside, missed, pairs.refined(missed).dense(through)

    for repeat in range(2, CONTACT_ROUNDS + 2):
        springs = _springs(model, pairs, leaning)
        begun = None
        if rival is None and repeat <= CONTACT_ROUNDS:
            # a round whose first settle already misses contact is settled again with it,
            # from the start: its stability test, turn and friction would be thrown away
            begun = _first_settle(step1, x, masses, centres, springs)
            if begun is not None:
                two, first = begun
                inside, missed, refined = more_contact(two.problem.full(first.x))
                if not (inside <= leaning and refined.size() == pairs.size()) and not step1.out_of_time():
                    if tell is not None:
                        tell(_contact_round_note(model, inside - leaning, missed, pairs, repeat))
                    pairs, leaning = refined, leaning | inside
                    continue
        settled = _settle_with(step1, x, masses, centres, goal, springs, thorough, leaning, begun)
        inside, missed, refined = more_contact(settled.x)
        if (inside <= leaning and refined.size() == pairs.size()) or step1.out_of_time():
            break
        if rival is not None and settled.falls and not rival.falls:
            break  # it will not be kept (`_rank`)
        if tell is not None and repeat <= CONTACT_ROUNDS:  # another round follows
            tell(_contact_round_note(model, inside - leaning, missed, pairs, repeat))
        pairs, leaning = refined, leaning | inside
    else:  # the rounds ran out with contact still missed: it acts once more, from where they ended
        if tell is not None:
            tell(f"settling once more from where round {CONTACT_ROUNDS} ended, with the contact found there")
        springs = _springs(model, pairs, leaning)
        settled = _settle_with(step1, settled.x, masses, centres, goal, springs, False, leaning)
    return replace(settled, pairs=pairs)


def _contact_round_note(
    model: Model, new_leaning: frozenset[frozenset[int]], missed: dict[int, Array], pairs: Pairs, repeat: int
) -> str:
    """Why `_settle` settles again: the parts it found inside each other, which now
    lean on each other, and where the check's points found a part inside what
    its springs act against."""
    names = [p.name for p in model.parts]
    leans = sorted(listed([names[i] for i in sorted(both)]) for both in new_leaning)
    inside: dict[str, list[str]] = {}
    for k in sorted(missed):
        if pairs.bodies(k) in new_leaning:
            continue  # said as leaning: their springs come on with the check's points there
        inside.setdefault(names[int(pairs.obstacles[k])], []).append(names[int(pairs.parts[k])])
    why = [f"{both} leaning on each other" for both in leans] + [
        f"finer contact where {listed(parts)} lay inside `{obstacle}`" for obstacle, parts in inside.items()
    ]
    more = f"; and {len(why) - ROUND_REASONS_TOLD} more" if len(why) > ROUND_REASONS_TOLD else ""
    return (
        f"settling again, round {repeat} of at most {CONTACT_ROUNDS}: "
        + "; ".join(why[:ROUND_REASONS_TOLD])
        + more
    )


def _told(options: SolveOptions, stage: str) -> Callable[[str], None]:
    """`options.report` of what a stage is doing, with the stage's name."""
    return lambda doing: options.report(f"{stage}: {doing}")


def _parts_inside(model: Model, x: Array, pairs: Pairs, masses: Array) -> frozenset[frozenset[int]]:
    """The movable parts whose settle's points are more than OVERLAP_KEPT_MM
    inside each other at x, in pairs."""
    return frozenset(frozenset((part, other)) for part, other, _ in _in_each_other(model, x, pairs, masses))


def _judged_beside(
    model: Model, falls: tuple[Failure, ...], overlaps: list[tuple[int, int, float]]
) -> tuple[Failure, ...]:
    """The failures still judged where parts lie deeper than OVERLAP_KEPT_MM in
    each other (`overlaps`): such a part is pushed by springs far past any real
    contact's give (a roll 10 mm in a rod: 217 N on a 3 N hack), so no contact
    "would have to pull", nor carry what a point cannot, under such loads: the
    E512s and E514s they made hid the E508 that says why. Nor does a part
    pushed off an end from deeper than CROSSING_WARNED_MM in another (through
    it: the springs push some 25 times the weight) come off (E501); a part
    that falls from nearer the surface (an S-hook sliding off a post's end 1 mm
    in the mug it carries), or elsewhere, still falls."""
    if not overlaps:
        return falls
    inside = {model.parts[i].name for *pair, depth in overlaps if depth > CROSSING_WARNED_MM for i in pair}
    forced = (LiftOff, Turn, Swivel)
    return tuple(
        fall
        for fall in falls
        if not isinstance(fall, forced) and not (isinstance(fall, Fall) and fall.part in inside)
    )


def _in_each_other(model: Model, x: Array, pairs: Pairs, masses: Array) -> list[tuple[int, int, float]]:
    """(part, other movable part, depth mm) where the settle's points are more
    than OVERLAP_KEPT_MM inside."""
    return [
        (c.part, c.rests_on, c.depth)
        for c in contacts_at(model, x, pairs, _weight(masses))
        if c.depth > OVERLAP_KEPT_MM and not model.parts[c.rests_on].environment
    ]


def _missed(model: Model, x: Array, pairs: Pairs, leaning: frozenset[frozenset[int]]) -> dict[int, Array]:
    """Where the check's points find a part inside what its springs act against
    (the environment, the parts it leans on) between the settle's points: per
    pair, the check's points found inside (`Checked.deep`)."""
    checked = check(model, x, pairs)
    return {
        k: inside
        for k, inside in checked.deep.items()
        if model.parts[int(pairs.obstacles[k])].environment or pairs.bodies(k) in leaning
    }


def _overlaps(model: Model, x: Array, pairs: Pairs, masses: Array) -> list[tuple[int, int, float]]:
    """(part, obstacle, depth mm) deeper than OVERLAP_KEPT_MM inside, deepest first:
    in the environment by the check's points; parts in each other by the
    settle's, or by the check's deeper than CROSSING_WARNED_MM (the check's find
    the reading nook's wire rings crossing its links by up to 2.8 mm, and their
    springs made its settle crawl: docs/physics.md; `_crossings`)."""
    fine = check(model, x, pairs).overlaps(pairs, OVERLAP_KEPT_MM)
    in_world = [overlap for overlap in fine if model.parts[overlap[1]].environment]
    through = _between_parts(model, fine, deeper=True)
    found = {frozenset(overlap[:2]) for overlap in through}
    coarse = [
        overlap for overlap in _in_each_other(model, x, pairs, masses) if frozenset(overlap[:2]) not in found
    ]
    return sorted(in_world + through + coarse, key=lambda overlap: -overlap[2])


def _crossings(model: Model, x: Array, pairs: Pairs) -> list[tuple[int, int, float]]:
    """(part, other movable part, depth mm) that the check's points find crossing
    by more than OVERLAP_KEPT_MM and at most CROSSING_WARNED_MM, deepest first
    (W508), where `_overlaps` found nothing: the settle's points passed either
    side of a wire."""
    return _between_parts(model, check(model, x, pairs).overlaps(pairs, OVERLAP_KEPT_MM), deeper=False)


def _between_parts(
    model: Model, overlaps: list[tuple[int, int, float]], deeper: bool
) -> list[tuple[int, int, float]]:
    """Of `overlaps` (part, obstacle, depth), those between two movable parts
    deeper than CROSSING_WARNED_MM (through each other: E508), or not (W508)."""
    return [
        overlap
        for overlap in overlaps
        if not model.parts[overlap[1]].environment and (overlap[2] > CROSSING_WARNED_MM) == deeper
    ]


def _springs(model: Model, pairs: Pairs, leaning: frozenset[frozenset[int]]) -> Pairs:
    """The pairs whose contact springs act in a settle: against the environment,
    and between the movable parts `leaning` pairs."""
    return pairs.against({i for i, part in enumerate(model.parts) if part.environment}, leaning)


@dataclass(frozen=True)
class _StepTwo:
    """Step 2's problem from step 1's configuration (held DoFs stay, the rest and
    the floors' slides move), its energy under gravity with the contact springs
    (`gravity`), the slides friction acts on, and the energy with their friction
    from the normal forces where the parts were placed (`energy`, `resistance`)."""

    problem: Problem
    gravity: Energy
    slides: list[Slide]
    energy: Energy
    resistance: Array


def _second_step(step1: Problem, x: Array, masses: Array, centres: Array, pairs: Pairs) -> _StepTwo:
    """Step 2 from step 1's `x`, with the contact springs of `pairs` (`_StepTwo`)."""
    model = step1.model
    held = {i for j in model.joints if j.held for i in j.a.dof_indices + j.b.dof_indices}
    moving = {int(i) for i in step1.free if i not in held} | model.floor_slides()  # gravity slides those
    movable = np.array(sorted(moving), dtype=int)
    step2 = Problem(model, movable, x.copy(), step1.spacing, step1.deadline)
    gravity = with_contacts(model, potential(model, masses, centres), pairs, _weight(masses))
    slides = [slide for slide in friction_slides(model) if set(slide.dofs) <= moving]
    energy, resistance = _friction_at(step2, gravity, slides, pairs, masses, centres, x, x)
    return _StepTwo(step2, gravity, slides, energy, resistance)


def _friction_at(
    step2: Problem,
    gravity: Energy,
    slides: list[Slide],
    pairs: Pairs,
    masses: Array,
    centres: Array,
    origin: Array,
    at: Array,
) -> tuple[Energy, Array]:
    """The energy with friction on `slides` (from where the parts were placed,
    `origin`) from the normal forces of the contacts at `at`; the resistances."""
    model = step2.model
    contacts = contacts_at(model, at, pairs, _weight(masses))
    normal = normal_forces(model, at, _wrenches(step2, at, masses, centres, slides, contacts), slides)
    resistance = FRICTION * normal / 1000.0  # N -> joules per mm of sliding
    return with_friction(model, gravity, slides, resistance, origin), resistance


def _first_settle(
    step1: Problem, x: Array, masses: Array, centres: Array, pairs: Pairs
) -> tuple[_StepTwo, Result] | None:
    """Step 2 from `x` and its first settle, as `_settle_with` begins; None
    where nothing moves."""
    two = _second_step(step1, x, masses, centres, pairs)
    if not len(two.problem.free):
        return None
    return two, settle(two.problem, two.energy, x[two.problem.free], SETTLE_TOLERANCE * _weight(masses))


def _settle_with(
    step1: Problem,
    x: Array,
    masses: Array,
    centres: Array,
    goal: target_mod.TargetGoal,
    pairs: Pairs,
    thorough: bool,
    leaning: frozenset[frozenset[int]],
    begun: tuple[_StepTwo, Result] | None = None,
) -> Settled:
    """Step 2 from step 1's `x`: held DoFs stay, the rest settle under gravity (with
    friction from where they start and the contact springs of `pairs`), stably,
    turned towards the request among equally low configurations, then verified
    at rest. Not `thorough`: settled and verified only, without the stability
    test and the turn (for comparing). `begun`: step 2 and its first settle,
    made already from `x` (`_first_settle`)."""
    model = step1.model
    two, first = begun if begun is not None else (_second_step(step1, x, masses, centres, pairs), None)
    step2, gravity, slides = two.problem, two.gravity, two.slides
    movable = step2.free
    weight = _weight(masses)
    origin = x

    def with_friction_at(at: Array) -> tuple[Energy, Array]:
        return _friction_at(step2, gravity, slides, pairs, masses, centres, origin, at)

    energy, resistance = two.energy, two.resistance
    at_rest = SETTLE_TOLERANCE * weight
    if not len(movable):
        pass  # nothing to settle: verified where it stands
    elif thorough:
        x, curvature = _settle_stably(step2, energy, x, at_rest, weight, first)
        if not step2.out_of_time():
            x = _turn_towards_target(step2, energy, goal, x, at_rest, TARGET_PULL * weight, curvature)
    else:
        x = step2.full((first if first is not None else settle(step2, energy, x[movable], at_rest)).x)
    for _ in range(FRICTION_ROUNDS):  # until friction agrees with the forces where it settled
        if not slides or step2.out_of_time():
            break
        updated_energy, updated = with_friction_at(x)
        if np.abs(updated - resistance).max() <= FRICTION_AGREEMENT * FRICTION * weight:
            break
        energy, resistance = updated_energy, updated
        x = step2.full(settle(step2, energy, x[movable], at_rest).x)
    holding = _friction_left(model, slides, resistance, x, origin)
    equilibrium, at_bound, falls = _verify(step2, energy, x, masses, holding)
    for _ in range(POLISH_ROUNDS):  # a long loop's flat valley may need more iterations
        if equilibrium <= EQUILIBRIUM_TOLERANCE or not len(movable) or step2.out_of_time():
            break
        x = step2.full(settle(step2, energy, x[movable], at_rest).x)
        equilibrium, at_bound, falls = _verify(step2, energy, x, masses, holding)
    contacts = contacts_at(model, x, pairs, weight)
    wrenches = _wrenches(step2, x, masses, centres, slides, contacts)
    tipping = (*topples(model, x, wrenches, set(at_bound)), *tips_off_its_feet(model, x, wrenches, weight))
    lifts = lifts_off(model, x, wrenches, masses)
    held = _held_by_the_model(step2, x, masses, centres, slides, contacts, wrenches)
    return Settled(
        x,
        equilibrium,
        at_bound,
        (*falls, *tipping, *lifts, *held),
        wrenches.forces,
        contacts,
        leaning,
    )


def _friction_left(
    model: Model, slides: list[Slide], resistance: Array, x: Array, origin: Array
) -> dict[int, float]:
    """The static friction (joules per mm) each slide can still give beyond what
    the settle's friction term already exerts at x: all of it where the slide has
    not moved, none once it slides (the term then pulls with its full resistance);
    by DoF (a floor's two DoFs share theirs)."""
    lengths = mm_per_unit(model)
    holding = {}
    for slide, limit in zip(slides, resistance, strict=True):
        index = list(slide.dofs)
        moved = float(np.linalg.norm((x[index] - origin[index]) * lengths[index]))
        exerted = moved / np.sqrt(moved**2 + FRICTION_SMOOTHING_MM**2)
        holding.update(dict.fromkeys(slide.dofs, limit * (1.0 - exerted)))
    return holding


def _at_rest(settled: Settled | Solution) -> bool:
    """Verified at rest (always, without gravity: nothing to settle)."""
    return settled.equilibrium is None or settled.equilibrium <= EQUILIBRIUM_TOLERANCE


def _pick(
    model: Model,
    goal: target_mod.TargetGoal,
    first: Settled,
    second: Settled,
    energy: Callable[[Settled], float],
) -> tuple[Settled, Diagnostic | None]:
    """Of two settled results from different starts, the rule: one that holds
    (does not fall apart, is at rest) over one that does not; then the one whose
    target hangs nearest the request (mm, and degrees counted as mm, as step 1
    measures); then the lower energy. N505 when they hang apart."""

    ranks = [_rank(goal, model.part_frames(result.x), result, energy(result)) for result in (first, second)]
    (chosen, chosen_rank), (other, other_rank) = sorted(
        zip((first, second), ranks, strict=True), key=lambda pair: pair[1]
    )
    a = target_mod.achieved(goal, model.part_frames(chosen.x))
    b = target_mod.achieved(goal, model.part_frames(other.x))
    apart, turned = target_mod.errors(replace(goal, requested=b), a)
    if (apart <= DISAGREE_MM and turned <= DISAGREE_DEG) or chosen.falls:  # both fall: E501 says it
        return chosen, None
    near, near_deg = target_mod.errors(goal, a)
    far, far_deg = target_mod.errors(goal, b)
    if other.falls:
        why = "the other falls apart"
    elif other_rank[1] and not chosen_rank[1]:
        why = "the other is not at rest"
    else:
        why = (
            f"it hangs nearer the request ({near:.0f} mm, {near_deg:.0f} degrees off; "
            f"the other {far:.0f} mm, {far_deg:.0f} degrees)"
        )
    return chosen, Diagnostic(
        Severity.NOTE,
        "N505",
        f"starts disagree: from two starts the hack settles {apart:.0f} mm and {turned:.0f} degrees apart; "
        f"the solver went on from one of them because {why}",
        model.program.targets[0].span,
        "how the parts are first hung decides where a builder's hack comes to rest: hang them as the "
        "result shows (docs/errors.md, N505, gives the rule)",
    )


def _rank(
    goal: target_mod.TargetGoal, frames: Array, result: Settled | Solution, energy: float = 0.0
) -> tuple[bool, bool, float, float]:
    """The order of preference between settled results: one that holds (does not
    fall apart), then one at rest, then the target nearest the request (mm, and
    degrees counted as mm, to 0.1), then the lower energy."""
    position, rotation = target_mod.errors(goal, target_mod.achieved(goal, frames))
    return bool(result.falls), not _at_rest(result), round(position + rotation, 1), energy


def _require_finite(model: Model, x: Array, masses: Array, centres: Array, step: str) -> None:
    """Raise NumericFailure naming the first part whose frame, mass or centre is not a number."""
    frames = model.part_frames(x) if np.all(np.isfinite(x)) else np.full((len(model.parts), 4, 4), np.nan)
    finite = np.isfinite(frames).all(axis=(1, 2)) & np.isfinite(masses) & np.isfinite(centres).all(axis=1)
    if not finite.all():
        raise NumericFailure(step, model.parts[int(np.argmin(finite))].name)


def _energy(frames: Array, masses: Array, centres: Array) -> float:
    weights = weight_newtons(masses) / 1000.0  # joules per mm of height
    heights = np.einsum("pj,pj->p", frames[:, 2, :3], centres) + frames[:, 2, 3]
    return float(weights @ heights)


def step_one(
    model: Model, seed: int, loop_start: Array | None = None, deadline: float = float("inf")
) -> tuple[Problem, Iterator[Array]]:
    """Step 1's problem (the DoFs that are not pinned, parts sharing a primitive
    kept apart) and its starts over those DoFs: the spread-out defaults (with
    loops: closed), then (with loops) the parts hung and the loops closed round
    the target at its request, where that reaches it (fabhal/solve/hanging.py),
    then seeded random points (with loops: those that close).
    The random starts are made as they are asked for: closing a random start's
    loops costs as much as a short fit, and a fit that succeeds needs no more
    starts; the first is always asked for, and decides the order of parts along
    a shared rod where only the check's closure keeps them apart."""
    x0 = model.x_default()
    low, high = model.bounds()
    written = list(model.written)
    low[written] = high[written] = x0[written]  # spread the others around what the program set
    spacing = spacing_constraints(model, spread(spacing_constraints(model, x0), x0, low, high))
    x0 = spread(spacing, x0, low, high)
    free = np.array([i for i in range(len(model.variables)) if i not in model.pinned], dtype=int)
    first = _first_start(model, x0, spacing, loop_start, seed, deadline) if model.closures else x0
    if loop_start is not None and spacing and float(spacing_values(spacing, first).min()) <= -1e-6:
        # no closure keeps the parts apart in the spread's order along their rod; the check's
        # keeps them apart in an order of its own (a mug's handle on a rod and on the S-hook
        # beside it there): that order it is
        in_its_order = spacing_constraints(model, loop_start)
        if float(spacing_values(in_its_order, loop_start).min()) > -1e-6:
            spaced = sorted({i for c in spacing for i in (c.first, c.second)})
            spacing, first = in_its_order, loop_start
            x0[spaced] = loop_start[spaced]

    def starts() -> Iterator[Array]:
        yield first
        if model.closures:
            masses, centres = _mass_table(model)
            hung = hanging_start(
                model, x0, free, potential(model, masses, centres), target_mod.goal_of(model),
                mm_per_unit(model)[free], seed, deadline,
            )  # fmt: skip
            if hung is not None:
                yield hung
        yield from _random_starts(model, x0, seed, deadline)

    return Problem(model, free, x0.copy(), spacing, deadline), _distinct(starts(), free)


def _random_starts(model: Model, x0: Array, seed: int, deadline: float) -> Iterator[Array]:
    """EXTRA_STARTS seeded random points in the DoFs' ranges (pinned DoFs kept);
    with loops, those whose loops close within RANDOM_CLOSE_EVALUATIONS, closed."""
    rng = np.random.default_rng(seed)
    low, high = model.bounds()
    for _ in range(EXTRA_STARTS):
        random = rng.uniform(np.where(np.isfinite(low), low, 0.0), np.where(np.isfinite(high), high, 360.0))
        random[list(model.pinned)] = x0[list(model.pinned)]
        if model.closures:
            closing = close_loops(
                model, seed, starts=1, x0=random, evaluations=RANDOM_CLOSE_EVALUATIONS, deadline=deadline
            )
            if not closing.closed:
                continue  # fitting from an open start would close its loops all over again
            random = closing.x
        yield random


def _first_start(
    model: Model, x0: Array, spacing: list[Spacing], loop_start: Array | None, seed: int, deadline: float
) -> Array:
    """Step 1's first start with loops: the check's closed loops when they keep
    the spacing; else those loops with the shared primitives' parts spread out
    and closed again from there (a few Newton steps: only the spread DoFs
    moved); else closed from the spread defaults."""
    if loop_start is not None:
        if not spacing or float(spacing_values(spacing, loop_start).min()) > -1e-6:
            return loop_start
        spaced = sorted({i for c in spacing for i in (c.first, c.second)})
        shifted = loop_start.copy()
        shifted[spaced] = x0[spaced]
        closing = close_loops(
            model, seed, starts=1, x0=shifted, evaluations=RANDOM_CLOSE_EVALUATIONS, deadline=deadline
        )
        if closing.closed and float(spacing_values(spacing, closing.x).min()) > -1e-6:
            return closing.x
        if time.monotonic() > deadline:
            return loop_start  # closed, if not yet spaced: the best start there is time for
    return close_loops(model, seed, x0=x0, deadline=deadline).x


def _distinct(starts: Iterable[Array], free: Array) -> Iterator[Array]:
    """The starts over the free DoFs without repeats: closing the loops from a
    random point often lands on a configuration already tried, and fitting it
    again gains nothing."""
    kept: list[Array] = []
    for start in starts:
        v = start[free]
        if all(np.abs(v - other).max() > 1e-6 for other in kept):
            kept.append(v)
            yield v


def _settle_stably(
    problem: Problem,
    energy: Energy,
    x: Array,
    at_rest: float,
    weight: float,
    first: Result | None = None,
) -> tuple[Array, Array | None]:
    """Settle (unless `first` is that settle, made already); if the result is
    an unstable balance (the energy curves down along the constraints),
    settle again from a nudge each way along the steepest way down and keep
    the lowest energy. The nudged settles start near the first result, so
    BFGS starts from the first settle's matrix; it is returned too."""
    model, free = problem.model, problem.free
    low, high = problem.bounds()
    first = first if first is not None else settle(problem, energy, x[free], at_rest)
    best = problem.full(first.x)
    best_energy = energy(best)[0]
    if problem.out_of_time():
        return best, first.curvature
    values, directions = problem.curvature(energy, first.x)
    if not len(values) or values[0] >= -UNSTABLE_CURVATURE * weight or problem.out_of_time():
        return best, first.curvature
    way_down = directions[:, 0]
    way_down = way_down * NUDGE_MM / float(np.abs(way_down * problem.scale).max())
    for sign in (1.0, -1.0):
        start = np.clip(first.x + sign * way_down, low, high)
        candidate = problem.full(settle(problem, energy, start, at_rest, first.curvature).x)
        value = energy(candidate)[0]
        if _closed(model, candidate) and value < best_energy - 1e-12:
            best, best_energy = candidate, value
    return best, first.curvature


def _turn_towards_target(
    problem: Problem,
    energy: Energy,
    goal: target_mod.TargetGoal,
    x: Array,
    at_rest: float,
    strength: float,
    curvature: Array | None,
) -> Array:
    """Of the configurations as low as the settled one (a free turn about the
    vertical), the one nearest the requested frame: settle with a weak pull
    towards it, then again without it, so the result is at rest under gravity
    alone. Kept only if its loops are closed and it is no higher than the
    force left at rest lifts over TURN_SLACK_MM (a bird feeder turned 93
    degrees back towards its request came out 3e-8 J higher, the unpulled
    settle stopping a hair short of the bottom, and was refused at 1e-9 J)."""
    pull = with_target_pull(problem.model, energy, goal, strength)
    pulled = settle(problem, pull, x[problem.free], at_rest, curvature)
    turned = problem.full(settle(problem, energy, pulled.x, at_rest, pulled.curvature).x)
    higher = energy(turned)[0] - energy(x)[0]
    return turned if _closed(problem.model, turned) and higher <= at_rest * TURN_SLACK_MM else x


# see _turn_towards_target: a twentieth of a millimetre of the force left at rest (at 1 mm
# a turn of the one-eye-hook soap basket passed that the aim then took 12 mm further off)
TURN_SLACK_MM = 0.05


def _closed(model: Model, x: Array) -> bool:
    """Every loop closed to 1e-6 mm (always, without loops)."""
    return not model.closures or closure_residual_mm(model, x) < 1e-6


def _late(options: SolveOptions) -> Diagnostic:
    return warning(
        "W502",
        f"stopped at the time limit ({options.time_limit:g} s) with the best result so far",
        None,
        "allow more time with --time-limit",
    )


def _mass_table(model: Model) -> tuple[Array, Array]:
    masses = np.zeros(len(model.parts))
    centres = np.zeros((len(model.parts), 3))
    for i, part in enumerate(model.parts):
        if part.environment:
            continue
        properties = mass_properties(part.spec)
        masses[i] = properties.mass_g or 0.0
        centres[i] = properties.center_of_mass
    return masses, centres


def _verify(
    problem: Problem,
    energy: Energy,
    x: Array,
    masses: Array,
    holding: dict[int, float],
) -> tuple[float, tuple[int, ...], tuple[Fall | Lean, ...]]:
    """KKT check at the settled point: stationarity on the DoFs inside their
    ranges; on those resting on an end, the sign of the push decides whether an
    open connection comes apart, and a slide pushed off its end comes apart only
    when the push beats what friction holds (`holding`: joules per mm of sliding,
    by DoF); a lean (a hook tilted on its rod) pushed against the model's stop
    is held by nothing real (`Lean`). Forces are per mm of motion, over the
    total weight."""
    model = problem.model
    free = problem.free
    weight = _weight(masses)
    per_mm = problem.scale
    gradient = energy(x)[1][free] / per_mm / weight
    resting = _resting_ends(problem, x)
    rows = []
    if model.closures:
        rows.append(problem.closure_jacobian(x[free]))
    if problem.has_limits():
        values = problem.limit_values(x[free])
        rows.append(problem.limit_jacobian()[values < 1e-6])
    inside = np.array([k for k in range(len(free)) if k not in resting], dtype=int)
    constraint = np.vstack(rows) / per_mm if rows else None  # the same change of variables as the gradient

    def unbalanced(gradient: Array) -> Array:
        if constraint is None or not len(inside):
            return gradient.copy()
        return unbalanced_force(gradient, constraint, inside)

    force = unbalanced(gradient)
    stationarity = float(np.abs(force[inside]).max()) if len(inside) else 0.0
    falls: list[Fall | Lean] = []
    for k, end in resting.items():
        i = int(free[k])
        dof = model.variables[i].dof
        outward = force[k] > 0 if end == "min" else force[k] < 0
        held = holding.get(i, 0.0) / weight if outward else 0.0  # static friction, before it slides
        pushed = abs(force[k]) - held > EQUILIBRIUM_TOLERANCE
        if not outward and pushed:
            stationarity = max(stationarity, abs(force[k]))  # would move back inside: not at rest
        is_open = dof.low_open if end == "min" else dof.high_open
        joint = model.joints[model.variables[i].joint]
        # on the very tip of an open end that no friction holds, what is not pushed back
        # inside comes off at the slightest sway, even unpushed (a hook's tip at its lowest)
        on_the_tip = is_open and i not in holding and not (pushed and not outward)
        if ((outward and pushed and is_open) or on_the_tip) and not _stopped_past(
            problem, energy, x, k, end, unbalanced, weight
        ):
            falls.append(Fall(joint.index, i, end, falling_part(model, joint, model.variables[i].side)))
        elif (
            outward and not dof.ends_hold and abs(force[k]) > LEAN_CARRIES and not _in_a_corner(problem, x, i)
        ):
            part = model.parts[model.side_of(i).part].name
            falls.append(Lean(joint.index, i, end, float(abs(force[k])), part))
    at_bound = tuple(sorted(int(free[k]) for k in resting))
    return stationarity, at_bound, tuple(falls)


def _stopped_past(
    problem: Problem,
    energy: Energy,
    x: Array,
    k: int,
    end: str,
    unbalanced: Callable[[Array], Array],
    weight: float,
) -> bool:
    """Whether free DoF `k`, resting on an open `end`, would be pushed back
    inside (by more than the tolerance) before the part on it has gone past
    that end by its own half width (`half_width`: an S-hook's wire radius, 2
    mm), so that it still rings what it is on: what it touches stops it there
    (the contact springs push back), and it does not come off at that end (an
    S-hook slid to the foot of a headrest post stands on the seat). Nothing
    past a hook's tip does."""
    model = problem.model
    i = int(problem.free[k])
    joint = model.joints[model.variables[i].joint]
    on = model.side_of(i)
    guest = joint.b if joint.a is on else joint.a
    beyond = x.copy()
    beyond[i] += (-1.0 if end == "min" else 1.0) * half_width(joint, guest) / problem.scale[k]
    force = unbalanced(energy(beyond)[1][problem.free] / problem.scale / weight)[k]
    inward = force < 0 if end == "min" else force > 0
    return bool(inward and abs(force) > EQUILIBRIUM_TOLERANCE)


def _in_a_corner(problem: Problem, x: Array, lean: int) -> bool:
    """Whether the side of a lean (DoF `lean`) sits at a closed end of its rod:
    in the corner where a basket's handle bends down, which stops the lean as
    a real end does (a hook pushed into the bend of a U-handle)."""
    side = problem.model.side_of(lean)
    return side.dof_indices[0] != lean and _at_a_closed_end(problem, x, side)


def _at_a_closed_end(problem: Problem, x: Array, side: Side) -> bool:
    """Whether a rod's side sits at a closed end of the rod (its slide `t` on
    an end that holds)."""
    model = problem.model
    slide = side.dof_indices[0]
    dof = model.variables[slide].dof
    if dof.name != "t":
        return False
    end = end_of(*model.bounds(), slide, x)
    return (end == "min" and not dof.low_open) or (end == "max" and not dof.high_open)


def _resting_ends(problem: Problem, x: Array) -> dict[int, str]:
    """The problem's free DoFs (by position in `free`) resting on an end of
    their range: "min" or "max"."""
    low, high = problem.model.bounds()
    ends = {k: end_of(low, high, int(i), x) for k, i in enumerate(problem.free)}
    return {k: end for k, end in ends.items() if end is not None}


def _weight(masses: Array) -> float:
    """The assembly's weight in joules per mm of height (masses in grams)."""
    return max(float(weight_newtons(masses).sum()) / 1000.0, 1e-12)


def _overlap_diagnostic(
    model: Model, x: Array, pairs: Pairs, part_index: int, other_index: int, depth: float
) -> Diagnostic:
    part, other = (model.parts[i] for i in (part_index, other_index))
    stands = _standing_between(model, part_index, other_index)
    if stands is not None:
        floor_side = next((s.floor for s in model.standing if s.joint == stands.index), None)
        if floor_side is None:  # on round feet: the surface is the floor
            floor_side = "a" if stands.a.primitive.kind == "surface" else "b"
        floor, thing = (stands.a, stands.b) if floor_side == "a" else (stands.b, stands.a)
        stood, on = stands.endpoint(thing), stands.endpoint(floor)
        if _below_the_floor(model, x, pairs, floor, frozenset((part_index, other_index))):
            name = model.parts[thing.part].name
            others = [
                f"`{name}.{p.name}`"
                for p in model.parts[thing.part].spec.primitives
                if p.kind == "surface" and p.name != thing.primitive.name
            ]
            instead = f"stand it by {' or '.join(others)}" if others else "stand it by another surface"
            return error(
                "E508",
                f"`{stood}` is not the underside of `{name}`: stood on `{on}` by it, the part is "
                f"{depth:.1f} mm inside `{model.parts[floor.part].name}`",
                stands.connection.span,
                "a part stands on a floor by a surface on its underside; this one lies inside the part "
                f"(a basket's `surface` is the floor of its inside, for what stands in it): {instead}, "
                "or hang it",
            )
        return error(
            "E508",
            f"`{model.parts[thing.part].name}` does not fit where it stands on `{on}`: "
            f"`{part.name}` is {depth:.1f} mm inside `{other.name}` there",
            stands.connection.span,
            "a standing object must fit between its floor and whatever spans it (a handle across a "
            "basket) or beside it: stand a smaller one, or use a carrier it fits in",
        )
    return error(
        "E508",
        f"`{part.name}` is {depth:.1f} mm inside `{other.name}` where the solver stopped: "
        "the parts cannot be where shown",
        model.program.targets[0].span,
        "the connections hold them where they would pass through each other: give them room (another "
        "place on what holds them, a longer part), or try another --seed",
    )


def _below_the_floor(model: Model, x: Array, pairs: Pairs, floor: Side, both: frozenset[int]) -> bool:
    """Whether the check's points found inside, between the standing pair `both`,
    all lie at or below the floor's face (a millimetre's give): the object's own
    body below the surface it stands by, not something higher up (a handle)."""
    frames = model.part_frames(x)
    face = model.connector_frame(floor, x, frames)
    heights = []
    for k, inside in check(model, x, pairs).deep.items():
        if pairs.bodies(k) != both:
            continue
        pair = pairs.pairs[k]
        world = inside @ frames[pair.part][:3, :3].T + frames[pair.part][:3, 3]
        heights.append((world - face[:3, 3]) @ face[:3, 2])
    found = np.concatenate(heights) if heights else np.zeros(0)
    return bool(len(found)) and float(found.max()) <= 1.0


def _stood_on_one_spot(model: Model, x: Array) -> list[tuple[Standing, Standing, float]]:
    """(an object standing, another, depth mm) of two objects standing on one
    floor whose bases overlap there by more than OVERLAP_KEPT_MM. Step 1 stands
    every object in its floor's middle, so two of them on one floor stand on
    one spot; two alike then coincide, and the contact check, which looks for
    points of one inside the other, finds every point on the other's surface
    (0.3 mm in): two soap bottles on one shelf came back `solved`. Their bases
    are rectangles in the floor's plane (the object's surface's length along
    its connector frame's x, its width along y)."""
    frames = model.part_frames(x)
    by_floor: dict[tuple[int, str], list[Standing]] = {}
    for standing in model.standing:
        floor, _ = model.standing_sides(standing)
        by_floor.setdefault((floor.part, floor.primitive.name), []).append(standing)
    found = []
    for objects in by_floor.values():
        for first, second in itertools.combinations(objects, 2):
            placed = [model.connector_frame(model.standing_sides(s)[1], x, frames) for s in (first, second)]
            depth = rectangles_overlap(
                np.array([frame[:3, 3] for frame in placed]),
                np.array([[frame[:3, 0], frame[:3, 1]] for frame in placed]),
                np.array([(s.base[1] / 2.0, s.base[0] / 2.0) for s in (first, second)]),
            )
            if depth > OVERLAP_KEPT_MM:
                found.append((first, second, depth))
    return found


def _one_spot_diagnostic(model: Model, first: Standing, second: Standing, depth: float) -> Diagnostic:
    """At the connection of the one of the two that is not the target (the
    solver stands the target where it is asked for, the rest in the middle)."""
    target = model.program.targets[0].part
    sides = [model.standing_sides(s) for s in (first, second)]
    names = [model.parts[thing.part].name for _, thing in sides]
    k = 0 if names[1] == target else 1
    joint, (floor, _) = model.joints[(first, second)[k].joint], sides[k]
    on = joint.endpoint(floor)
    return error(
        "E508",
        f"`{names[k]}` stands on `{on}` where `{names[1 - k]}` stands: their bases overlap by {depth:.1f} mm",
        joint.connection.span,
        f"the solver stands an object in the middle of its floor (the target where it is asked for): say "
        f"where `{names[k]}` stands, on this line, e.g. `set ({on}.t2: 0.8)` (t1 and t2 run from 0 to 1 "
        "across the floor; `--dofs` lists them), or stand it on another floor",
    )


def _one_place_diagnostic(model: Model, part_index: int, other_index: int) -> Diagnostic:
    part, other = (model.parts[i].name for i in (part_index, other_index))
    return error(
        "E508",
        f"`{part}` and `{other}` are in one place where the solver stopped: the surface of the one lies on "
        "the other's all round",
        model.program.targets[0].span,
        "the connections hold both at one spot (two rings written at one place on a hook): say where "
        "each is held apart (`--dofs` lists the settings; `set (...)` on a connection's line), or hang "
        "one from another hook or through a link",
    )


def _standing_between(model: Model, part_index: int, other_index: int) -> Joint | None:
    """The connection that stands one of the two parts on the other's surface
    (not `fixed`: glued or pinned, they are not tested together), if any."""
    both = {part_index, other_index}
    return next((j for j in model.joints if j.stands and {j.a.part, j.b.part} == both), None)


def _through_diagnostic(model: Model, part_index: int, other_index: int, span: float) -> Diagnostic:
    part, other = (model.parts[i] for i in (part_index, other_index))
    return error(
        "E508",
        f"`{part.name}` passes through `{other.name}` where the solver stopped (their walls cross over "
        f"{span:.0f} mm): the parts cannot be where shown",
        model.program.targets[0].span,
        "the solver could not take them apart: give them room (hang them further apart, another place "
        "on what holds them), or try another --seed",
    )


def _crossing_diagnostic(model: Model, part_index: int, other_index: int, depth: float) -> Diagnostic:
    part, other = (model.parts[i] for i in (part_index, other_index))
    return warning(
        "W508",
        f"`{part.name}` crosses `{other.name}` by {depth:.1f} mm where the solver stopped (found by "
        "the fine check, between the points its contacts act at)",
        model.program.targets[0].span,
        f"the real parts push each other aside by about {depth:.0f} mm and what hangs from them moves "
        "with them: build it and look; give them room (another place on what holds them) to be sure",
    )


__all__ = ["Fall", "Lean", "NumericFailure", "Slip", "Solution", "SolveOptions", "Topple", "solve"]
