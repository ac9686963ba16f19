"""A solve result for tools (the JSON object of `fabhal solve --json`) and for people."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from fabhal.diagnostics import Diagnostic, to_json
from fabhal.kinematics.frames import matrix_euler
from fabhal.model import Model
from fabhal.primitives import Dof
from fabhal.solve import Solution
from fabhal.solve.aim import builder_settings, setting_text
from fabhal.solve.steps import mm_per_unit

if TYPE_CHECKING:
    from rich.console import RenderableType


class SolveOutcome(Protocol):
    """What a solve run produced (fabhal.api.SolveResult has these)."""

    @property
    def status(self) -> str: ...
    @property
    def solution(self) -> object | None: ...
    @property
    def seed(self) -> int: ...
    @property
    def timing(self) -> Mapping[str, float]: ...
    @property
    def diagnostics(self) -> Sequence[Diagnostic]: ...


def _numbers(values: Any, digits: int = 4) -> list[float]:
    return [round(float(v), digits) + 0.0 for v in values]


def _frame(matrix: np.ndarray) -> dict[str, list[float]]:
    return {"pos": _numbers(matrix[:3, 3]), "rot": _numbers(matrix_euler(matrix))}


def to_dict(result: SolveOutcome, program: str) -> dict[str, Any]:
    """Exactly the object the solve command documents."""
    solution: Solution | None = result.solution  # type: ignore[assignment]
    out: dict[str, Any] = {"status": result.status, "program": program, "seed": result.seed}
    if solution is None:
        out.update({"target": None, "parts": {}, "connections": [], "energy": None, "residual": None})
    else:
        out.update(_solution(solution))
    out["diagnostics"] = [to_json(d) for d in result.diagnostics]
    out["timing"] = {k: round(v, 4) for k, v in result.timing.items()}
    return out


def _within_range(dof: Dof, value: float) -> float:
    """A turn that goes all the way round (a spin, a ring's theta) as the angle in
    its range [low, high): the solver may leave it at 449.8 or -90, meaning 89.8 or 270."""
    if not dof.periodic:
        return value
    wrapped = dof.low + (value - dof.low) % (dof.high - dof.low)
    return dof.low if round(wrapped, 6) >= dof.high else wrapped  # 359.9999999 is 0


def _solution(solution: Solution) -> dict[str, Any]:
    model = solution.model
    goal = solution.goal
    position_error, rotation_error = solution.target_errors()
    target = {
        "part": goal.source.part,
        "primitive": goal.source.primitive,
        "requested": _frame(goal.requested),
        "achieved": _frame(solution.target_frame()),
        "position_error_mm": round(position_error, 4),
        "rotation_error_deg": round(rotation_error, 4),
    }
    parts = {
        part.name: {
            "type": part.type_name,
            **_frame(solution.frames[i]),
            "matrix": [_numbers(row, 6) for row in solution.frames[i]],
            "mass_g": round(float(solution.masses[i]), 3),
        }
        for i, part in ((i, model.parts[i]) for i in model.as_written())
    }
    connections = []
    resting = set(solution.at_bound)
    settings = builder_settings(model)
    for joint in model.joints:
        dofs: dict[str, float] = {}
        at_bound: list[str] = []
        set_once: list[str] = []
        for side, end in ((joint.a, joint.connection.a), (joint.b, joint.connection.b)):
            for i, dof in zip(side.dof_indices, side.primitive.dofs, strict=True):
                name = f"{end}.{dof.name}"
                dofs[name] = round(_within_range(dof, float(solution.x[i])), 6) + 0.0
                if i in resting:
                    at_bound.append(name)
                if i in settings:
                    set_once.append(name)
        connection: dict[str, Any] = {
            "a": str(joint.connection.a),
            "b": str(joint.connection.b),
            "flip": joint.connection.flip,
            "dofs": dofs,
            "at_bound": at_bound,
            # the builder's settings (a clip's grip, a `fixed` connection, where friction
            # holds a part): set when building, then they stay put (N506 when aimed)
            "settings": set_once,
        }
        if solution.forces is not None:  # N, what a exerts on b (world axes), and its size
            connection["force_n"] = _numbers(solution.forces[joint.index])
            connection["carries_n"] = round(float(np.linalg.norm(solution.forces[joint.index])), 4)
        connections.append(connection)
    contacts = [  # where the environment holds a part by touching it (fabhal/solve/contacts.py)
        {
            "part": model.parts[contact.part].name,
            "rests_on": model.parts[contact.rests_on].name,
            "point": _numbers(contact.point, 2),
            "force_n": _numbers(contact.force),
            "carries_n": round(float(np.linalg.norm(contact.force)), 4),
            "depth_mm": round(contact.depth, 4),
        }
        for contact in solution.contacts
    ]
    return {
        "target": target,
        "parts": parts,
        "connections": connections,
        "dofs": dof_rows(solution),
        "contacts": contacts,
        "energy": round(solution.energy, 6),
        "residual": float(f"{solution.residual:.3g}"),
    }


def dof_rows(solution: Solution) -> list[dict[str, Any]]:
    """Every degree of freedom of the design: its connection, range, where it
    settled (as a builder would set it) and what decides it: `written` (the
    program sets it: `set (...)`), `set once` (a clip's grip, a `fixed`
    connection, a place friction holds: the builder's setting, aimed),
    `other side` (a loop's turn about the line of its contact where the other
    side's turn, about the same line, carries both: it stays square), `stays`
    (the model keeps it where it is: a hook bent open round its rod neither
    turns nor tilts on it, a ring's spin where no hook holds it) or `settles`
    (gravity moves it); `at_end`: resting on an end of its range."""
    model = solution.model
    settings, resting, lengths = builder_settings(model), set(solution.at_bound), mm_per_unit(model)
    carried = {turn.second for turn in model.turn_limits if turn.folded}
    kept = set(model.pinned) - carried - model.floor_slides()  # written DoFs say so first
    rows = []
    for i, variable in enumerate(model.variables):
        dof = variable.dof
        value = _within_range(dof, float(solution.x[i]))
        if dof.periodic and round(value) >= dof.high:  # 359.9 degrees round is 0
            value = dof.low
        connection = model.joints[variable.joint].connection
        rows.append(
            {
                "name": variable.name,
                "connection": f"{connection.a} -- {connection.b}",
                "range": [dof.low, dof.high],
                "turns_freely": dof.periodic,
                "value": round(value, 6) + 0.0,
                "as_built": setting_text(model, i, value, float(lengths[i])),
                "role": _role(i, model.written, settings, carried, kept),
                "at_end": i in resting,
            }
        )
    return rows


def _role(i: int, written: frozenset[int], settings: set[int], carried: set[int], kept: set[int]) -> str:
    """What decides DoF i (`dof_rows`)."""
    if i in written:
        return "written"
    if i in settings:
        return "set once"
    if i in carried:
        return "other side"
    return "stays" if i in kept else "settles"


# ---------------------------------------------------------------- for people

_STATUS_STYLE = {
    "solved": "bold green",
    "falls_apart": "bold red",
    "not_at_rest": "bold red",
    "infeasible": "bold red",
    "out_of_time": "bold red",
    "error": "bold red",
}
_STATUS_TEXT = {
    "solved": "solved",
    "falls_apart": "falls apart",
    "not_at_rest": "not solved: the result is not at rest",
    "infeasible": "infeasible: a loop cannot close",
    "out_of_time": "not solved: the time limit ended before the loops were closed",
    "error": "not solved: the program has errors",
}


def renderables(result: SolveOutcome, program: str) -> list[RenderableType]:
    from rich.table import Table
    from rich.text import Text

    head = Text()
    head.append(f"{program}: ", style="bold")
    head.append(_STATUS_TEXT[result.status], style=_STATUS_STYLE[result.status])
    solution: Solution | None = result.solution  # type: ignore[assignment]
    if solution is None:
        return [head]
    position_error, rotation_error = solution.target_errors()
    goal = solution.goal
    head.append(
        f"\ntarget {goal.source.part}" + (f".{goal.source.primitive}" if goal.source.primitive else "")
    )
    head.append(f" is {position_error:.1f} mm and {rotation_error:.1f} degrees from where it was asked to be")
    head.append(f"\nloops closed to {solution.residual:.1e} mm; potential energy {solution.energy:.3f} J")
    if solution.equilibrium is not None and np.isfinite(solution.equilibrium):
        head.append(f"; at rest to {solution.equilibrium:.1e} of its weight")
    elif solution.equilibrium is not None:
        head.append("; not settled under gravity (no time left)")
    timing = result.timing
    head.append(
        f"\n{timing['parse_s'] + timing['check_s'] + timing['solve_s']:.2f} s "
        f"(parse {timing['parse_s']:.2f}, check {timing['check_s']:.2f}, solve {timing['solve_s']:.2f})",
        style="dim",
    )
    table = Table(title="where each part ends up (world frame: mm, degrees)")
    for column in ("part", "type", "position", "rotation", "mass"):
        table.add_column(column, justify="right" if column == "mass" else "left")
    for i in solution.model.as_written():
        part = solution.model.parts[i]
        frame = _frame(solution.frames[i])
        mass = "fixed" if part.environment else f"{solution.masses[i]:.1f} g"
        table.add_row(part.name, part.type_name, _triple(frame["pos"]), _triple(frame["rot"]), mass)
    what = "a part, what holds it" + (" and the force between them" if solution.forces is not None else "")
    chain = Text(f"how it hangs (each line: {what})\n", style="bold")
    if solution.forces is not None and any(d.code == "E508" for d in solution.diagnostics):
        # springs deep in a part push far beyond a real contact (a roll 10 mm in a rod: 124 N)
        chain.append("  (parts lie inside each other here, E508: the forces are not the hack's)\n")
    for depth, line in hanging_lines(solution.model, solution.forces):
        chain.append("  " * (depth + 1) + line + "\n")
    for contact in solution.contacts:
        resting, holder = (solution.model.parts[i].name for i in (contact.part, contact.rests_on))
        chain.append(
            f"  {resting}  rests against  {holder}  at {_triple(_numbers(contact.point, 1))}"
            f"  ({float(np.linalg.norm(contact.force)):.2f} N)\n"
        )
    return [head, table, chain]


def dofs_table(solution: Solution) -> RenderableType:
    """`fabhal solve --dofs`: the design's degrees of freedom, one row each."""
    from rich.table import Table

    table = Table(title="degrees of freedom (angles in degrees, t along a primitive from 0 to 1)")
    for column in ("connection", "dof", "range", "settled", "as built", "decided by"):
        table.add_column(column)
    for row in dof_rows(solution):
        low, high = row["range"]
        extent = "turns freely" if row["turns_freely"] else f"{low:g} .. {high:g}"
        role = row["role"] + (", at an end" if row["at_end"] else "")
        table.add_row(row["connection"], row["name"], extent, f"{row['value']:.3g}", row["as_built"], role)
    return table


def hanging_lines(model: Model, forces: np.ndarray | None = None) -> list[tuple[int, str]]:
    """The connection tree depth first, as (depth, text) lines: each part under
    what holds it; then the connections that close loops (depth 0). With
    `forces` ((J, 3) N per connection), each line says what its connection carries."""

    def carried(joint: int) -> str:
        return "" if forces is None else f"  ({float(np.linalg.norm(forces[joint])):.2f} N)"

    below: dict[int, list[tuple[int, str]]] = {}  # part -> (child part, line), in program order
    for edge in model.tree:
        joint = model.joints[edge.joint]
        parent, child = model.placed_sides(edge)
        line = f"{joint.endpoint(child)}  <-  {joint.endpoint(parent)}{carried(edge.joint)}"
        below.setdefault(parent.part, []).append((child.part, line))
    lines: list[tuple[int, str]] = []

    def visit(part: int, depth: int) -> None:
        for child, line in below.get(part, []):
            lines.append((depth, line))
            visit(child, depth + 1)

    for i in model.as_written():
        if model.parts[i].environment:
            visit(i, 0)
    for j in model.closures:
        connection = model.joints[j].connection
        lines.append((0, f"{connection.a}  ==  {connection.b}  (closes a loop){carried(j)}"))
    return lines


def _triple(values: list[float]) -> str:
    return "(" + ", ".join(f"{v:.1f}" for v in values) + ")"
