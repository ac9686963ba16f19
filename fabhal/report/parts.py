"""The part library as data for people (rich tables) and tools (JSON)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from fabhal.library import Library, PartSpec, PartType
from fabhal.meshes import FRAME_OUTSIDE_SAID_MM, MassProperties, mass_properties
from fabhal.primitives import Primitive, is_ring_twist
from fabhal.syntax import ast

if TYPE_CHECKING:
    from rich.console import RenderableType


def _round(values: tuple[float, ...] | list[float], digits: int = 3) -> list[float]:
    return [round(float(v), digits) + 0.0 for v in values]  # + 0.0 turns -0.0 into 0.0


def primitive_summary(part_type: PartType) -> str:
    decls = [i for i in part_type.definition.items if isinstance(i, ast.PrimitiveDecl)]
    return ", ".join(f"{d.name} ({d.kind})" for d in decls)


def list_json(library: Library) -> list[dict[str, Any]]:
    return [
        {
            "name": t.name,
            "description": t.description,
            "primitives": t.primitive_names(),
            "parameters": [p.name for p in t.parameters],
            "file": t.span.file,
            "line": t.span.line,
        }
        for t in sorted(library.parts.values(), key=lambda t: t.name)
    ]


def primitive_json(primitive: Primitive) -> dict[str, Any]:
    return {
        "name": primitive.name,
        "kind": primitive.kind,
        "variant": primitive.variant,
        "parameters": dict(primitive.params),
        "flags": dict(primitive.flags),
        "single_connection": primitive.single_connection,
        "frame": {"pos": _round(primitive.position), "rot": _round(primitive.rotation)},
        "dofs": [
            {
                "name": d.name,
                "min": d.low,
                "max": d.high,
                "default": d.default,
                "tag": d.tag.value,
                "open_at_min": d.low_open,
                "open_at_max": d.high_open,
                "only_in_loops": is_ring_twist(primitive.variant, d.name),
            }
            for d in primitive.dofs
        ],
    }


def detail_json(part_type: PartType, spec: PartSpec, mass: MassProperties) -> dict[str, Any]:
    return {
        "name": part_type.name,
        "description": part_type.description,
        "file": part_type.span.file,
        "line": part_type.span.line,
        "parameters": [
            {"name": p.name, "min": p.low, "max": p.high, "default": p.default} for p in part_type.parameters
        ],
        "material": part_type.material,
        "mesh": part_type.mesh.name if part_type.mesh else None,
        "mass_g": None if mass.mass_g is None else round(mass.mass_g, 3),
        "mass_source": mass.source,
        "volume_mm3": round(mass.volume_mm3, 1),
        "center_of_mass": _round(mass.center_of_mass),
        "bounding_box": {"min": _round(mass.bounds[0]), "max": _round(mass.bounds[1])},
        "frame_outside_mm": round(mass.frame_outside_mm, 1),
        "primitives": [primitive_json(p) for p in spec.primitives],
    }


def detail(part_type: PartType, spec: PartSpec) -> dict[str, Any]:
    return detail_json(part_type, spec, mass_properties(spec))


# ---------------------------------------------------------------- rich renderings


def list_table(library: Library) -> RenderableType:
    from rich.table import Table

    table = Table(title=f"FabHaL part library ({len(library.parts)} parts)", show_lines=False)
    table.add_column("part", style="bold cyan", no_wrap=True)
    table.add_column("primitives")
    table.add_column("description")
    for part_type in sorted(library.parts.values(), key=lambda t: t.name):
        name = part_type.name
        if part_type.parameters:
            name += "(" + ", ".join(p.name for p in part_type.parameters) + ")"
        table.add_row(name, primitive_summary(part_type), part_type.description or "")
    return table


def _numbers(values: list[float]) -> str:
    return "(" + ", ".join(f"{v:g}" for v in values) + ")"


def detail_renderables(info: dict[str, Any]) -> list[RenderableType]:
    from rich.table import Table
    from rich.text import Text

    head = Text()
    head.append(info["name"], style="bold cyan")
    head.append(f"  {info['file']}:{info['line']}\n", style="dim")
    head.append(f"{info['description'] or ''}\n\n")
    for p in info["parameters"]:
        head.append(f"parameter {p['name']}: {p['min']:g} .. {p['max']:g}, default {p['default']:g}\n")
    mass = "unknown" if info["mass_g"] is None else f"{info['mass_g']:g} g"
    head.append(f"material {info['material']}, mass {mass} (from the {info['mass_source']})\n")
    head.append(f"centre of mass {_numbers(info['center_of_mass'])} mm, ")
    box = info["bounding_box"]
    head.append(f"bounding box {_numbers(box['min'])} .. {_numbers(box['max'])} mm\n")
    if info["frame_outside_mm"] > FRAME_OUTSIDE_SAID_MM:
        head.append(
            f"its own frame lies {info['frame_outside_mm']:g} mm outside it (where its mesh was modelled): "
            "`at (...)` and `target` place that point, not the part; a target on a primitive is on it\n"
        )
    head.append(f"mesh {info['mesh'] or '(drawn from its primitives)'}")

    table = Table(title="connector primitives (frames in the part frame; DoFs per connection)")
    for column in ("primitive", "kind", "shape", "frame", "degrees of freedom"):
        table.add_column(column)
    for p in info["primitives"]:
        shape = ", ".join(f"{k} {v:g}" for k, v in p["parameters"].items())
        flags = [k for k, v in p["flags"].items() if v]
        if flags:
            shape += "; " + ", ".join(flags)
        frame = f"at {_numbers(p['frame']['pos'])}\nrot {_numbers(p['frame']['rot'])}"
        dofs = "\n".join(
            f"{d['name']} {d['min']:g}..{d['max']:g} ({d['default']:g}) {d['tag']}"
            + (" (loops only)" if d["only_in_loops"] else "")
            for d in p["dofs"]
        )
        kind = p["kind"] if p["variant"].lower() == p["kind"] else f"{p['kind']} ({p['variant']})"
        table.add_row(p["name"], kind, shape, frame, dofs)
    return [head, table]
