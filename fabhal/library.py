"""Part definitions -> validated part types; part types + arguments -> resolved parts.

The library is whatever `part` and `material` definitions the loaded modules
hold: the standard library (`stdlib_parts/`), imports, and the program itself.
Every defect in a definition is a diagnostic at the line that has it.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

from fabhal import primitives
from fabhal.diagnostics import Diagnostic, FabhalError, error
from fabhal.evaluate import Value, evaluate, number
from fabhal.load import LoadedProgram
from fabhal.primitives import KINDS, Primitive, make_primitive
from fabhal.source import Span
from fabhal.syntax import ast
from fabhal.syntax.hints import did_you_mean, suggestion

# `Rod(...)` etc. make a one-primitive part (for environments)
BARE_PRIMITIVES = {kind.capitalize(): kind for kind in KINDS}


@dataclass(frozen=True)
class Material:
    name: str
    density: float  # g/cm3
    description: str | None
    span: Span


@dataclass(frozen=True)
class PartParameter:
    name: str
    low: float | None
    high: float | None
    default: float | None
    span: Span

    def range_text(self) -> str:
        return f"{self.low:g} .. {self.high:g}" if self.low is not None and self.high is not None else "any"


@dataclass(frozen=True)
class PartType:
    """A part definition, checked; instantiate it with `Library.instantiate`."""

    name: str
    description: str | None
    parameters: tuple[PartParameter, ...]
    definition: ast.PartDef
    mesh: Path | None
    material: str | None

    @property
    def span(self) -> Span:
        return self.definition.span

    def primitive_names(self) -> list[str]:
        return [i.name for i in self.definition.items if isinstance(i, ast.PrimitiveDecl)]


@dataclass(frozen=True)
class PartSpec:
    """A part type with its arguments bound: every number evaluated."""

    type_name: str
    arguments: Mapping[str, float]
    primitives: tuple[Primitive, ...]
    mesh: Path | None
    density: float | None  # g/cm3 of its material
    mass_override: float | None  # grams, from a `mass` line

    def primitive(self, name: str) -> Primitive | None:
        return next((p for p in self.primitives if p.name == name), None)


@dataclass(frozen=True)
class Library:
    parts: Mapping[str, PartType]
    materials: Mapping[str, Material]

    def instantiate(
        self, type_name: str, args: Mapping[str, tuple[Value | str, Span]], span: Span
    ) -> PartSpec:
        """Bind arguments (checked against the parameters' ranges) and evaluate the part."""
        part_type = self.parts[type_name]
        env = _bind_arguments(part_type, args, span, self.parts)
        problems: list[Diagnostic] = []
        spec = _evaluate_part(part_type, env, self.materials, problems)
        if problems or spec is None:
            raise FabhalError(problems)
        return spec


def bare_primitive(
    kind: str, name: str, args: Mapping[str, tuple[Value | str, Span]], span: Span
) -> PartSpec:
    """A one-primitive part, e.g. `Rod(length: 500, radius: 2)`; its primitive is called `name`."""
    problems: list[Diagnostic] = []
    arguments = tuple(ast.Argument(key, _literal(value, s), s) for key, (value, s) in args.items())
    decl = ast.PrimitiveDecl(kind, name, arguments, None, span, span)
    primitive = _evaluate_primitive(decl, {}, problems)
    if problems or primitive is None:
        raise FabhalError(problems)
    return PartSpec(kind.capitalize(), MappingProxyType({}), (primitive,), None, None, None)


def _literal(value: Value | str, span: Span) -> ast.Expr:
    if isinstance(value, str):  # a part type's name: evaluating it reports "not a number" at the span
        return ast.Name(value, span)
    return ast.Boolean(value, span) if isinstance(value, bool) else ast.Number(float(value), "", span)


# ---------------------------------------------------------------- building


def build_library(program: LoadedProgram) -> tuple[Library, list[Diagnostic]]:
    """Collect and check every material and part definition of the loaded modules."""
    problems: list[Diagnostic] = []
    materials = _collect_materials(program.modules, problems)
    parts: dict[str, PartType] = {}
    for module in program.modules:
        directory = program.paths[module.file].parent if module.file in program.paths else Path.cwd()
        for statement in module.statements:
            if not isinstance(statement, ast.PartDef):
                continue
            if statement.name in parts or statement.name in BARE_PRIMITIVES:
                where = parts[statement.name].span if statement.name in parts else None
                first = f" (first defined at {where.file}:{where.line})" if where else ""
                problems.append(
                    error(
                        "E207",
                        f"part `{statement.name}` is defined twice{first}",
                        statement.span,
                        "rename one",
                    )
                )
                continue
            part_type = _check_part(statement, module.file, directory, materials, problems)
            if part_type is not None:
                parts[statement.name] = part_type
    return Library(MappingProxyType(parts), MappingProxyType(materials)), problems


def _collect_materials(modules: Iterable[ast.Module], problems: list[Diagnostic]) -> dict[str, Material]:
    materials: dict[str, Material] = {}
    for module in modules:
        for statement in module.statements:
            if not isinstance(statement, ast.MaterialDef):
                continue
            args = {a.name: a for a in statement.args}
            unknown = [a for a in statement.args if a.name != "density"]
            for a in unknown:
                problems.append(
                    error(
                        "E210",
                        f"a material has only a `density`, not `{a.name}`",
                        a.span,
                        "write `material NAME(density: GRAMS_PER_CM3)`",
                    )
                )
            if "density" not in args:
                problems.append(
                    error(
                        "E210",
                        f"material `{statement.name}` has no density",
                        statement.span,
                        "write e.g. `material oak(density: 0.75)` (g/cm3)",
                    )
                )
                continue
            try:
                density = number(args["density"].value, {})
            except FabhalError as exc:
                problems.extend(exc.diagnostics)
                continue
            if density <= 0:
                problems.append(
                    error(
                        "E210",
                        f"density == {density:g}, but must be positive (g/cm3)",
                        args["density"].span,
                        "steel is 7.85, wood about 0.6, plastics 0.9 to 1.4 g/cm3",
                    )
                )
                continue
            if statement.name in materials:
                problems.append(
                    error(
                        "E210",
                        f"material `{statement.name}` is defined twice",
                        statement.span,
                        "keep one definition, or give this one another name",
                    )
                )
                continue
            materials[statement.name] = Material(
                statement.name, density, statement.description, statement.span
            )
    return materials


def _check_part(
    definition: ast.PartDef,
    file: str,
    directory: Path,
    materials: Mapping[str, Material],
    problems: list[Diagnostic],
) -> PartType | None:
    """Validate a part definition by evaluating it at its parameters' defaults."""
    parameters = _parameters(definition, problems)
    mesh_lines = [i for i in definition.items if isinstance(i, ast.MeshLine)]
    material_lines = [i for i in definition.items if isinstance(i, ast.MaterialLine)]
    mesh = directory / mesh_lines[0].path if mesh_lines else None
    if mesh_lines and mesh is not None and not mesh.is_file():
        problems.append(
            error(
                "E205",
                f'mesh file "{mesh_lines[0].path}" not found',
                mesh_lines[0].span,
                f"mesh paths are relative to the file that defines the part ({file})",
            )
        )
        mesh = None
    material = material_lines[0].name if material_lines else None
    if material is None:
        problems.append(
            error(
                "E212",
                f"part `{definition.name}` names no material",
                definition.span,
                f"add a line such as `material plastic`; known: {', '.join(materials)}",
            )
        )
    elif material not in materials:
        suggestion = did_you_mean(material, materials)
        listed = ", ".join(materials)
        help_text = f"did you mean `{suggestion}`?" if suggestion else f"known materials: {listed}"
        problems.append(error("E206", f"unknown material `{material}`", material_lines[0].span, help_text))
        material = None
    part_type = PartType(definition.name, definition.description, parameters, definition, mesh, material)
    defaults = {p.name: p.default for p in parameters if p.default is not None}
    if len(defaults) == len(parameters):
        _evaluate_part(part_type, defaults, materials, problems)
    return part_type


def _parameters(definition: ast.PartDef, problems: list[Diagnostic]) -> tuple[PartParameter, ...]:
    parameters = []
    for p in definition.params:
        try:
            low = number(p.low, {}) if p.low is not None else None
            high = number(p.high, {}) if p.high is not None else None
            default = number(p.default, {}) if p.default is not None else None
        except FabhalError as exc:
            problems.extend(exc.diagnostics)
            continue
        if low is not None and high is not None and low > high:
            problems.append(
                error("E213", f"the range {low:g} .. {high:g} is empty", p.span, "write low .. high")
            )
        elif default is not None and low is not None and high is not None and not low <= default <= high:
            problems.append(
                error(
                    "E213",
                    f"default {p.name} == {default:g} is outside {low:g} .. {high:g}",
                    p.span,
                    f"choose a default from {low:g} to {high:g}",
                )
            )
        parameters.append(PartParameter(p.name, low, high, default, p.span))
    return tuple(parameters)


def _bind_arguments(
    part_type: PartType,
    args: Mapping[str, tuple[Value | str, Span]],
    span: Span,
    parts: Mapping[str, PartType],
) -> dict[str, float]:
    problems: list[Diagnostic] = []
    known = {p.name: p for p in part_type.parameters}
    env: dict[str, float] = {}
    for name, (value, arg_span) in args.items():
        if name not in known:
            help_text = suggestion(
                name, known, f"`{part_type.name}` takes {{choices}}", f"`{part_type.name}` takes no arguments"
            ) + _with_parameter(parts, name, part_type.name)
            problems.append(
                error("E211", f"`{part_type.name}` has no parameter `{name}`", arg_span, help_text)
            )
            continue
        parameter = known[name]
        if isinstance(value, (bool, str)):
            shown = "true/false" if isinstance(value, bool) else f"the part type `{value}`"
            problems.append(
                error("E211", f"`{name}` is a number, not {shown}", arg_span, f"write `{name}: NUMBER`")
            )
            continue
        low, high = parameter.low, parameter.high
        if low is not None and high is not None and not low <= value <= high:
            problems.append(
                error(
                    "E211",
                    f"{name} == {value:g}, but `{part_type.name}` allows {low:g} .. {high:g}",
                    arg_span,
                    f"give `{name}` a value from {low:g} to {high:g}",
                )
            )
            continue
        env[name] = float(value)
    for parameter in part_type.parameters:
        if parameter.name not in env and parameter.name not in args:
            if parameter.default is None:
                problems.append(
                    error(
                        "E211",
                        f"`{part_type.name}` needs a value for `{parameter.name}`",
                        span,
                        f"write `{part_type.name}({parameter.name}: ...)`",
                    )
                )
            else:
                env[parameter.name] = parameter.default
    if problems:
        raise FabhalError(problems)
    return env


def _with_parameter(parts: Mapping[str, PartType], parameter: str, like: str) -> str:
    """A pointer to the library parts that do take `parameter` (a variant of `like`,
    such as ParamTurnbuckle for Turnbuckle, first), or nothing."""
    having = sorted(
        (t for t in parts.values() if any(p.name == parameter for p in t.parameters)),
        key=lambda t: (like.lower() not in t.name.lower(), t.name),
    )
    if not having:
        return ""
    best = having[0]
    (param,) = [p for p in best.parameters if p.name == parameter]
    shown = f" ({param.low:g} .. {param.high:g})" if param.low is not None and param.high is not None else ""
    others = f"; also {', '.join(f'`{t.name}`' for t in having[1:4])}" if len(having) > 1 else ""
    return f"; `{best.name}` takes `{parameter}`{shown}: `{best.name}({parameter}: ...)`{others}"


def _evaluate_part(
    part_type: PartType,
    env: Mapping[str, float],
    materials: Mapping[str, Material],
    problems: list[Diagnostic],
) -> PartSpec | None:
    evaluated: list[Primitive] = []
    seen: dict[str, ast.PrimitiveDecl] = {}
    before = len(problems)
    mass_override: float | None = None
    for item in part_type.definition.items:
        if isinstance(item, ast.MassLine):
            mass_override = _mass(item, env, problems)
        if not isinstance(item, ast.PrimitiveDecl):
            continue
        if item.name in seen:
            first = seen[item.name].span
            problems.append(
                error(
                    "E204",
                    f"primitive `{item.name}` is defined twice in `{part_type.name}` "
                    f"(first at line {first.line})",
                    item.span,
                    "give each primitive of a part its own name",
                )
            )
            continue
        seen[item.name] = item
        primitive = _evaluate_primitive(item, env, problems)
        if primitive is not None:
            evaluated.append(primitive)
    if not seen:
        problems.append(
            error(
                "E214",
                f"part `{part_type.name}` has no connector primitives",
                part_type.span,
                "add at least one line such as `rod rod(radius: 4, length: 60)`",
            )
        )
    if len(problems) > before:
        return None
    material = materials.get(part_type.material) if part_type.material is not None else None
    density = material.density if material is not None else None
    return PartSpec(
        part_type.name, MappingProxyType(dict(env)), tuple(evaluated), part_type.mesh, density, mass_override
    )


def _mass(item: ast.MassLine, env: Mapping[str, float], problems: list[Diagnostic]) -> float | None:
    try:
        grams = number(item.value, env)
    except FabhalError as exc:
        problems.extend(exc.diagnostics)
        return None
    if grams <= 0:
        problems.append(
            error(
                "E203",
                f"mass == {grams:g}, but must be positive (grams)",
                item.span,
                "write the part's weight in grams, or remove the line to compute it from mesh and material",
            )
        )
        return None
    return grams


def _evaluate_primitive(
    decl: ast.PrimitiveDecl, env: Mapping[str, float], problems: list[Diagnostic]
) -> Primitive | None:
    if decl.kind not in KINDS:
        suggestion = did_you_mean(decl.kind, KINDS)
        listed = ", ".join(KINDS)
        help_text = f"did you mean `{suggestion}`?" if suggestion else f"the kinds are {listed}"
        problems.append(error("E201", f"unknown primitive kind `{decl.kind}`", decl.kind_span, help_text))
        return None
    spec = KINDS[decl.kind]
    params: dict[str, float] = {}
    flags: dict[str, bool] = {}
    arg_spans: dict[str, Span] = {}
    before = len(problems)
    for arg in decl.args:
        arg_spans[arg.name] = arg.span
        try:
            value = evaluate(arg.value, env)
        except FabhalError as exc:
            problems.extend(exc.diagnostics)
            continue
        param_spec = spec.param(arg.name)
        if param_spec is not None:
            if isinstance(value, bool):
                problems.append(
                    error(
                        "E209",
                        f"`{arg.name}` is a number ({param_spec.unit})",
                        arg.span,
                        f"write `{arg.name}: NUMBER`",
                    )
                )
            else:
                params[arg.name] = float(value)
        elif spec.flag(arg.name) is not None:
            if not isinstance(value, bool):
                problems.append(
                    error(
                        "E209",
                        f"`{arg.name}` is true or false, not a number",
                        arg.span,
                        f"`{arg.name}: true`",
                    )
                )
            else:
                flags[arg.name] = value
        else:
            names = [p.name for p in spec.params] + [f.name for f in spec.flags]
            suggestion = did_you_mean(arg.name, names)
            help_text = (
                f"did you mean `{suggestion}`?" if suggestion else f"a {decl.kind} takes {', '.join(names)}"
            )
            problems.append(
                error("E208", f"a {decl.kind} has no parameter `{arg.name}`", arg.span, help_text)
            )
    if len(problems) > before:
        return None
    for parameter, message in primitives.check_params(decl.kind, params):
        code = "E202" if parameter is None else "E203"
        span = arg_spans.get(parameter, decl.span) if parameter else decl.span
        fix = (
            _param_help(decl.kind)
            if parameter is None
            else primitives.param_fix(decl.kind, parameter, params[parameter])
        )
        problems.append(error(code, message, span, fix))
    if len(problems) > before:
        return None
    try:
        position = _vector(decl.placement.position if decl.placement else None, env)
        rotation = _vector(decl.placement.rotation if decl.placement else None, env)
    except FabhalError as exc:
        problems.extend(exc.diagnostics)
        return None
    return make_primitive(decl.name, decl.kind, params, flags, position, rotation)


def _param_help(kind: str) -> str:
    spec = KINDS[kind]
    return f"a {kind} takes " + ", ".join(f"{p.name} ({p.unit})" for p in spec.params if not p.optional)


def _vector(vector: ast.Vector | None, env: Mapping[str, float]) -> tuple[float, float, float]:
    if vector is None:
        return (0.0, 0.0, 0.0)
    return (number(vector.x, env), number(vector.y, env), number(vector.z, env))
