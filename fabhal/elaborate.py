"""Program statements -> a flat program: parameters bound, loops unrolled,
sub-assemblies expanded, every name resolved to a part instance and primitive.

Part names in the flat program are the program's own: `s1`, `tb[2]`, and
`chain.s[1]` for part `s[1]` inside the sub-assembly instance `chain`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from fabhal.diagnostics import Diagnostic, FabhalError, error, warning
from fabhal.evaluate import Value, evaluate, number
from fabhal.library import BARE_PRIMITIVES, Library, PartSpec, bare_primitive
from fabhal.load import LoadedProgram
from fabhal.primitives import jam_of, turning_to_the_jam
from fabhal.source import Span
from fabhal.syntax import ast
from fabhal.syntax.format import format_ref
from fabhal.syntax.hints import did_you_mean, suggestion

Vec3 = tuple[float, float, float]

# Passes of `for` loops in one program, all loops together, and values in one
# `param` domain: generous for any hack (the largest gallery loop makes 7 links),
# small enough that a typo such as `1 .. 100000` is an error, not a hang.
LOOP_PASS_LIMIT = 2000
DOMAIN_VALUE_LIMIT = 10000


@dataclass(frozen=True)
class PartInstance:
    name: str
    type_name: str
    spec: PartSpec
    environment: bool
    position: Vec3
    rotation: Vec3
    span: Span


@dataclass(frozen=True)
class Endpoint:
    """A primitive of a part instance, as written at `span`."""

    part: str
    primitive: str
    span: Span

    def __str__(self) -> str:
        # a bare-primitive environment (`environment bar = Rod(...)`) names its primitive like itself
        return self.part if self.part == self.primitive else f"{self.part}.{self.primitive}"


@dataclass(frozen=True)
class Setting:
    """A DoF of one side of a connection held at a written value (`set (...)`)."""

    side: str  # "a" or "b"
    dof: str
    value: float
    span: Span


@dataclass(frozen=True)
class Connection:
    a: Endpoint
    b: Endpoint
    flip: bool
    fixed: bool
    span: Span
    fixed_span: Span | None = None
    # the alignment is the program's (`flip` or `noflip` written): the solver may not turn it over
    aligned: bool = False
    settings: tuple[Setting, ...] = ()  # the builder's written settings: held there, never chosen


@dataclass(frozen=True)
class Target:
    part: str
    primitive: str | None  # None: the part's own frame
    position: Vec3
    rotation: Vec3
    span: Span


@dataclass(frozen=True)
class FlatProgram:
    file: str
    parts: tuple[PartInstance, ...]
    connections: tuple[Connection, ...]
    targets: tuple[Target, ...]
    parameters: Mapping[str, Value | str]

    def part(self, name: str) -> PartInstance:
        return next(p for p in self.parts if p.name == name)


@dataclass
class _Scope:
    """Names visible while elaborating one program or sub-assembly body."""

    prefix: str  # "" for the program, "chain." inside sub-assembly `chain`
    values: dict[str, Value | str] = field(default_factory=dict)  # parameters, loop variables
    parts: dict[str, PartInstance] = field(default_factory=dict)  # by local name
    aliases: dict[str, Endpoint] = field(default_factory=dict)
    assemblies: dict[str, dict[str, Endpoint]] = field(default_factory=dict)  # instance -> ports
    ports: dict[str, Endpoint] = field(default_factory=dict)
    declared_at: dict[str, Span] = field(default_factory=dict)
    # names whose declaration failed (already reported): their uses say nothing more
    broken: set[str] = field(default_factory=set)

    def numbers(self) -> dict[str, Value]:
        return {k: v for k, v in self.values.items() if not isinstance(v, str)}


class _Elaborator:
    def __init__(self, program: LoadedProgram, library: Library, bindings: Mapping[str, str]):
        self.program = program
        self.library = library
        self.bindings = dict(bindings)
        self.problems: list[Diagnostic] = []
        self.parts: list[PartInstance] = []
        self.connections: list[Connection] = []
        self.targets: list[Target] = []
        self.assembly_defs = {
            s.name: s for m in program.modules for s in m.statements if isinstance(s, ast.AssemblyDef)
        }
        self.later: dict[str, Span] = {}  # top-level names, to tell "used before declared" from "unknown"
        self.loop_passes = 0
        self.expanding: list[str] = []  # the assemblies being expanded, outermost first

    # ---- entry

    def run(self, main: ast.Module) -> FlatProgram:
        for module in self.program.modules:
            if module is not main:
                self._warn_ignored(module)
        scope = _Scope("")
        self.later = _declared_names(main.statements)
        self._block(main.statements, scope, top_level=True)
        for name in self.bindings:
            if name not in scope.values:
                self.problems.append(
                    error(
                        "E310", f"-D {name}=...: the program has no `param {name}`", None, _params_help(scope)
                    )
                )
        return FlatProgram(
            main.file,
            tuple(self.parts),
            tuple(self.connections),
            tuple(self.targets),
            MappingProxyType(dict(scope.values)),
        )

    def _warn_ignored(self, module: ast.Module) -> None:
        ignored = (ast.PartDef, ast.AssemblyDef, ast.MaterialDef, ast.ImportStmt)
        for statement in module.statements:
            if not isinstance(statement, ignored):
                self.problems.append(
                    warning(
                        "W301",
                        "an imported file's program statements are ignored",
                        statement.span,
                        "imports bring in `part`, `material` and `assembly` definitions only",
                    )
                )
                return

    # ---- statements

    def _block(self, statements: tuple[ast.Statement, ...], scope: _Scope, top_level: bool = False) -> None:
        for statement in statements:
            try:
                self._statement(statement, scope, top_level)
            except FabhalError as exc:
                self.problems.extend(exc.diagnostics)

    def _statement(self, statement: ast.Statement, scope: _Scope, top_level: bool) -> None:
        if isinstance(statement, ast.ParamDecl):
            self._param(statement, scope)
        elif isinstance(statement, ast.EnvironmentDecl):
            self._forbid_in_assembly(statement, scope, "an environment")
            self._instance(statement.name, statement.call, scope, statement.placement, environment=True)
        elif isinstance(statement, ast.InstanceDecl):
            self._instance(statement.name, statement.call, scope, None, environment=False)
        elif isinstance(statement, ast.AliasDecl):
            key = self._key(statement.name, scope)
            if key in scope.parts or key in scope.assemblies:
                raise FabhalError([_duplicate(key, statement.name.span, scope.declared_at[key])])
            scope.aliases[key] = self._endpoint(statement.ref, scope)
        elif isinstance(statement, ast.ConnectStmt):
            a, b = self._endpoints(statement.a, statement.b, scope)
            fixed = next((o.span for o in statement.options if o.name == "fixed"), None)
            if statement.flip and statement.noflip:
                raise FabhalError([_both_alignments(statement)])
            aligned = statement.flip or statement.noflip
            settings = self._settings(statement, (a, b), scope)
            self.connections.append(
                Connection(a, b, statement.flip, statement.fixed, statement.span, fixed, aligned, settings)
            )
        elif isinstance(statement, ast.TargetStmt):
            self._forbid_in_assembly(statement, scope, "a target")
            self._target(statement, scope)
        elif isinstance(statement, ast.ForLoop):
            self._loop(statement, scope)
        elif isinstance(statement, ast.PortDecl):
            if not scope.prefix:
                raise FabhalError(
                    [error("E309", "`port` belongs inside an `assembly`", statement.span, "remove it")]
                )
            scope.ports[statement.name] = self._endpoint(statement.ref, scope)
        # part, assembly and material definitions and imports were handled by earlier stages

    def _settings(
        self, statement: ast.ConnectStmt, sides: tuple[Endpoint, Endpoint], scope: _Scope
    ) -> tuple[Setting, ...]:
        """The connection's written settings, each checked: a side of this
        connection, a DoF its primitive has, a value in its range, once."""
        found: list[Setting] = []
        problems: list[Diagnostic] = []
        for written in statement.settings:
            try:
                setting = self._setting(written, statement, sides, scope)
            except FabhalError as exc:
                problems.extend(exc.diagnostics)
                continue
            if any((s.side, s.dof) == (setting.side, setting.dof) for s in found):
                problems.append(
                    error("E315", f"`{_setting_name(written)}` is set twice", written.span, "keep one value")
                )
            found.append(setting)
        if problems:
            raise FabhalError(problems)
        return tuple(found)

    def _setting(
        self,
        written: ast.DofSetting,
        statement: ast.ConnectStmt,
        sides: tuple[Endpoint, Endpoint],
        scope: _Scope,
    ) -> Setting:
        endpoint = self._endpoint(written.side, scope)
        labels = [
            label
            for label, side in zip("ab", sides, strict=True)
            if (side.part, side.primitive) == (endpoint.part, endpoint.primitive)
        ]
        if not labels:
            as_written = " or ".join(f"`{format_ref(ref)}`" for ref in (statement.a, statement.b))
            raise FabhalError(
                [
                    error(
                        "E315",
                        f"`{format_ref(written.side)}` is not a side of this connection",
                        written.span,
                        f"name a DoF of one of its sides as written: {as_written}, then `.DOF`",
                    )
                ]
            )
        side, other_side = sides if labels[0] == "a" else sides[::-1]
        primitive, other = (self.part(end.part).spec.primitive(end.primitive) for end in (side, other_side))
        assert primitive is not None and other is not None  # the endpoints were resolved
        # a flex angle's, a rod's tilt's or a ring's spin's range ends at its stop (as the model's)
        dofs = {d.name: turning_to_the_jam(d, jam_of(d, primitive, other)) for d in primitive.dofs}
        if written.dof not in dofs:
            suggestion = did_you_mean(written.dof, dofs)
            listed = ", ".join(f"`{name}`" for name in dofs) or "none"
            help_text = f"did you mean `{suggestion}`?" if suggestion else f"its DoFs: {listed}"
            if primitive.kind == "hole" and written.dof == "spin":
                help_text += (
                    "; a ring turns about its own wire only where its part says `spin: true` "
                    "(the library's LevelHulaHoop)"
                )
            message = f"{primitive.kind} `{side}` has no DoF `{written.dof}`"
            raise FabhalError([error("E315", message, written.span, help_text)])
        dof = dofs[written.dof]
        value = evaluate(written.value, scope.numbers())
        if not dof.periodic and not dof.low <= value <= dof.high:
            raise FabhalError(
                [
                    error(
                        "E315",
                        f"`{_setting_name(written)}` is {value:g}, outside its range "
                        f"{dof.low:g} .. {dof.high:g}",
                        written.value.span,
                        "t runs along the primitive from 0 to 1; angles are degrees; a flex angle's or a "
                        "rod's tilt's range ends where a wire jams, a ring's spin where its far side meets "
                        "the hook (`fabhal solve --dofs` shows each DoF's range)",
                    )
                ]
            )
        return Setting(labels[0], written.dof, float(value), written.span)

    def part(self, name: str) -> PartInstance:
        return next(p for p in self.parts if p.name == name)

    def _forbid_in_assembly(self, statement: ast.Statement, scope: _Scope, what: str) -> None:
        if scope.prefix:
            raise FabhalError(
                [
                    error(
                        "E309",
                        f"{what} cannot be part of an `assembly`",
                        statement.span,
                        "declare it in the program that uses the assembly",
                    )
                ]
            )

    def _param(self, decl: ast.ParamDecl, scope: _Scope) -> None:
        candidates = _domain_values(decl.domain, scope)
        if not candidates:
            raise FabhalError(
                [
                    error(
                        "E310",
                        f"the domain of `{decl.name}` is empty",
                        decl.domain.span,
                        "a range runs upwards, `LOW .. HIGH` with LOW at most HIGH, e.g. `1 .. 4`",
                    )
                ]
            )
        # bound even when rejected below, so one bad value is one diagnostic, not a cascade
        scope.values[decl.name] = candidates[0]
        span = decl.span
        if decl.name in self.bindings:
            value: Value | str = _parse_binding(self.bindings[decl.name])
            where = f"-D {decl.name}={self.bindings[decl.name]}"
        elif decl.default is not None:
            value = _domain_item(decl.default, scope)
            where, span = f"{decl.name} == {_show(value)}", decl.default.span
        else:
            raise FabhalError(
                [
                    error(
                        "E310",
                        f"parameter `{decl.name}` has no value",
                        decl.span,
                        f"give it a default (`param {decl.name} in ... = VALUE`) "
                        f"or run with -D {decl.name}=VALUE",
                    )
                ]
            )
        _require_in_domain(decl, value, candidates, where, span)
        scope.values[decl.name] = value

    def _loop(self, loop: ast.ForLoop, scope: _Scope) -> None:
        low, high = _whole(loop.low, scope), _whole(loop.high, scope)
        self.loop_passes += max(0, high - low + 1)
        if self.loop_passes > LOOP_PASS_LIMIT:
            raise FabhalError(
                [
                    error(
                        "E312",
                        f"too many loop passes: this loop runs {high - low + 1:,} times, and all of the "
                        f"program's loops together may run at most {LOOP_PASS_LIMIT:,}",
                        loop.low.span.to(loop.high.span),
                        "check the loop's bounds: a hack of more than a few hundred parts is beyond "
                        "what FabHaL solves",
                    )
                ]
            )
        saved = scope.values.get(loop.variable)
        for i in range(low, high + 1):
            scope.values[loop.variable] = float(i)
            self._block(loop.body, scope)
        if saved is None:
            scope.values.pop(loop.variable, None)
        else:
            scope.values[loop.variable] = saved

    # ---- declarations

    def _key(self, lvalue: ast.Lvalue, scope: _Scope) -> str:
        if lvalue.index is None:
            return lvalue.name
        return f"{lvalue.name}[{_whole(lvalue.index, scope)}]"

    def _instance(
        self,
        lvalue: ast.Lvalue,
        call: ast.Call,
        scope: _Scope,
        placement: ast.Placement | None,
        environment: bool,
    ) -> None:
        key = self._key(lvalue, scope)
        if key in scope.declared_at:
            raise FabhalError([_duplicate(key, lvalue.span, scope.declared_at[key])])
        scope.declared_at[key] = lvalue.span
        try:
            type_name = _callee(call, scope)
            args = {a.name: (self._argument(a, scope), a.span) for a in call.args}
            if type_name in self.assembly_defs and type_name not in self.library.parts:
                scope.assemblies[key] = self._assembly(
                    self.assembly_defs[type_name], scope.prefix + key, args, call
                )
                return
            spec = self._spec(type_name, key, args, call, environment)
            position = _vector(placement.position if placement else None, scope)
            rotation = _vector(placement.rotation if placement else None, scope)
            instance = PartInstance(
                scope.prefix + key, type_name, spec, environment, position, rotation, lvalue.span
            )
            scope.parts[key] = instance
            self.parts.append(instance)
        except FabhalError:
            scope.broken.add(key)  # the error says what is wrong; its later uses stay quiet
            raise

    def _argument(self, argument: ast.Argument, scope: _Scope) -> Value | str:
        """A number, or a part type passed by name to a sub-assembly (`ring: RingM`)."""
        value = argument.value
        if isinstance(value, ast.Name) and value.name not in scope.values:
            if value.name in self.library.parts or value.name in self.assembly_defs:
                return value.name
        if isinstance(value, ast.Name) and isinstance(scope.values.get(value.name), str):
            return scope.values[value.name]
        return evaluate(value, scope.numbers())

    def _spec(
        self,
        type_name: str,
        key: str,
        args: dict[str, tuple[Value | str, Span]],
        call: ast.Call,
        environment: bool,
    ) -> PartSpec:
        if type_name in self.library.parts:
            return self.library.instantiate(type_name, args, call.span)
        if type_name in BARE_PRIMITIVES:
            if not environment:
                raise FabhalError(
                    [
                        error(
                            "E311",
                            f"a bare `{type_name}(...)` can only be an environment",
                            call.span,
                            f"write `environment {key} = {type_name}(...) at (x, y, z)`, or use a library "
                            "part that moves (`fabhal parts` lists them)",
                        )
                    ]
                )
            return bare_primitive(BARE_PRIMITIVES[type_name], key, args, call.span)
        known = [*self.library.parts, *self.assembly_defs, *BARE_PRIMITIVES]
        suggestion = did_you_mean(type_name, known)
        help_text = f"did you mean `{suggestion}`?" if suggestion else "`fabhal parts` lists the library"
        raise FabhalError([error("E301", f"unknown part type `{type_name}`", call.span, help_text)])

    def _assembly(
        self,
        definition: ast.AssemblyDef,
        prefix: str,
        args: dict[str, tuple[Value | str, Span]],
        call: ast.Call,
    ) -> dict[str, Endpoint]:
        if definition.name in self.expanding:
            chain = " -> ".join([*self.expanding[self.expanding.index(definition.name) :], definition.name])
            raise FabhalError(
                [
                    error(
                        "E313",
                        f"the assembly `{definition.name}` contains itself ({chain})",
                        call.span,
                        "an assembly cannot be made of itself; repeat parts with a `for` loop instead",
                    )
                ]
            )
        inner = _Scope(prefix + ".")
        known = {p.name: p for p in definition.params}
        for name, (value, span) in args.items():
            if name not in known:
                suggestion = did_you_mean(name, known)
                listed = ", ".join(f"`{p}`" for p in known)
                help_text = (
                    f"did you mean `{suggestion}`?"
                    if suggestion
                    else (f"it takes {listed}" if known else f"`{definition.name}` takes no arguments")
                )
                raise FabhalError(
                    [error("E211", f"`{definition.name}` has no parameter `{name}`", span, help_text)]
                )
            inner.values[name] = value
        for p in definition.params:
            if p.name not in inner.values:
                if p.default is None:
                    raise FabhalError(
                        [
                            error(
                                "E211",
                                f"`{definition.name}` needs a value for `{p.name}`",
                                call.span,
                                f"write `{definition.name}({p.name}: ...)`",
                            )
                        ]
                    )
                inner.values[p.name] = self._argument(ast.Argument(p.name, p.default, p.span), inner)
            bound = inner.values[p.name]
            if p.low is not None and p.high is not None and not isinstance(bound, (str, bool)):
                low, high = number(p.low, {}), number(p.high, {})
                if not low <= bound <= high:
                    raise FabhalError(
                        [
                            error(
                                "E211",
                                f"{p.name} == {bound:g}, but `{definition.name}` allows {low:g} .. {high:g}",
                                call.span,
                                f"give `{p.name}` a value from {low:g} to {high:g}",
                            )
                        ]
                    )
        saved_later = self.later
        self.later = _declared_names(definition.body)
        self.expanding.append(definition.name)
        try:
            self._block(definition.body, inner)
        finally:
            self.expanding.pop()
            self.later = saved_later
        return inner.ports

    # ---- references

    def _endpoints(self, a: ast.Ref, b: ast.Ref, scope: _Scope) -> tuple[Endpoint, Endpoint]:
        """Both sides, reporting the problems of both."""
        found: list[Endpoint] = []
        problems: list[Diagnostic] = []
        for ref in (a, b):
            try:
                found.append(self._endpoint(ref, scope))
            except FabhalError as exc:
                problems.extend(exc.diagnostics)
        if len(found) < 2:
            raise FabhalError(problems)
        return found[0], found[1]

    def _endpoint(self, ref: ast.Ref, scope: _Scope) -> Endpoint:
        key = self._key(ref.base, scope)
        if key in scope.aliases:
            endpoint = scope.aliases[key]
            if ref.primitive is not None:
                raise FabhalError(
                    [
                        error(
                            "E306",
                            f"`{key}` already names the primitive `{endpoint}`",
                            ref.span,
                            f"write `{key}` alone",
                        )
                    ]
                )
            return Endpoint(endpoint.part, endpoint.primitive, ref.span)
        if key in scope.assemblies:
            ports = scope.assemblies[key]
            if ref.primitive in ports:
                port = ports[ref.primitive]
                return Endpoint(port.part, port.primitive, ref.span)
            suggestion = did_you_mean(ref.primitive or "", ports)
            listed = ", ".join(f"`{p}`" for p in ports) or "none"
            help_text = f"did you mean `{suggestion}`?" if suggestion else f"its ports: {listed}"
            what = f"no port `{ref.primitive}`" if ref.primitive else "ports; name one"
            raise FabhalError([error("E304", f"sub-assembly `{key}` has {what}", ref.span, help_text)])
        if key in scope.broken:
            raise FabhalError([])  # its declaration's error already says what is wrong
        if key not in scope.parts:
            raise FabhalError([self._unknown_name(key, ref.base.span, scope)])
        instance = scope.parts[key]
        names = [p.name for p in instance.spec.primitives]
        if ref.primitive is None:
            if len(names) == 1:
                return Endpoint(instance.name, names[0], ref.span)
            raise FabhalError(
                [
                    error(
                        "E305",
                        f"which primitive of `{key}` ({instance.type_name})?",
                        ref.span,
                        f"write `{key}.NAME`; its primitives: {', '.join(names)}",
                    )
                ]
            )
        if ref.primitive not in names:
            suggestion = did_you_mean(ref.primitive, names)
            listed = ", ".join(names)
            help_text = f"did you mean `{suggestion}`? " if suggestion else ""
            raise FabhalError(
                [
                    error(
                        "E304",
                        f"`{key}` ({instance.type_name}) has no primitive `{ref.primitive}`",
                        ref.span,
                        f"{help_text}its primitives: {listed}",
                    )
                ]
            )
        return Endpoint(instance.name, ref.primitive, ref.span)

    def _unknown_name(self, key: str, span: Span, scope: _Scope) -> Diagnostic:
        base = key.split("[")[0]
        later = self.later.get(base)
        if later is not None and (later.line, later.column) > (span.line, span.column):
            return error(
                "E307",
                f"`{key}` is used before it is declared (line {later.line})",
                span,
                "move the declaration above its first use",
            )
        # a name whose declaration failed is still the user's: `mugg` near `mug = Mugg()`
        known = [*scope.parts, *scope.aliases, *scope.assemblies, *sorted(scope.broken)]
        help_text = suggestion(
            key,
            known,
            "declared so far: {choices}",
            "declare a part first, e.g. `s1 = DoubleHook()`",
            quoted=False,
        )
        return error("E302", f"unknown name `{key}`", span, help_text)

    def _target(self, statement: ast.TargetStmt, scope: _Scope) -> None:
        key = self._key(statement.ref.base, scope)
        if statement.ref.primitive is None and key in scope.parts:
            part, primitive = scope.parts[key].name, None
        else:
            endpoint = self._endpoint(statement.ref, scope)
            part, primitive = endpoint.part, endpoint.primitive
        position = _vector(statement.placement.position, scope)
        rotation = _vector(statement.placement.rotation, scope)
        self.targets.append(Target(part, primitive, position, rotation, statement.span))


# ---------------------------------------------------------------- helpers


def _both_alignments(statement: ast.ConnectStmt) -> Diagnostic:
    second = next(o for o in reversed(statement.options) if o.name in ("flip", "noflip"))
    return error(
        "E314",
        "`flip` and `noflip` on one connection",
        second.span,
        "`flip` turns the connection over, `noflip` keeps the default way round: write one of them, "
        "or neither to let the solver choose",
    )


def _duplicate(key: str, span: Span, first: Span) -> Diagnostic:
    return error(
        "E303",
        f"`{key}` is already declared (line {first.line})",
        span,
        "choose another name; to make several of a part, use `name[i]` in a `for` loop",
    )


def _declared_names(statements: tuple[ast.Statement, ...]) -> dict[str, Span]:
    names: dict[str, Span] = {}
    for statement in statements:
        if isinstance(statement, (ast.InstanceDecl, ast.EnvironmentDecl, ast.AliasDecl)):
            names.setdefault(statement.name.name, statement.name.span)
        elif isinstance(statement, ast.ForLoop):
            for name, span in _declared_names(statement.body).items():
                names.setdefault(name, span)
    return names


def _callee(call: ast.Call, scope: _Scope) -> str:
    value = scope.values.get(call.callee)
    return value if isinstance(value, str) else call.callee  # `Ring()` where `param Ring in [RingS, ...]`


def _setting_name(written: ast.DofSetting) -> str:
    return f"{format_ref(written.side)}.{written.dof}"


def _whole(expr: ast.Expr, scope: _Scope) -> int:
    value = number(expr, scope.numbers())
    if value != int(value):
        raise FabhalError(
            [
                error(
                    "E308",
                    f"expected a whole number, found {value:g}",
                    expr.span,
                    f"write {math.floor(value):g} or {math.ceil(value):g}",
                )
            ]
        )
    return int(value)


def _vector(vector: ast.Vector | None, scope: _Scope) -> Vec3:
    if vector is None:
        return (0.0, 0.0, 0.0)
    env = scope.numbers()
    return (number(vector.x, env), number(vector.y, env), number(vector.z, env))


def _domain_item(expr: ast.Expr, scope: _Scope) -> Value | str:
    if isinstance(expr, ast.Name) and expr.name not in scope.values:
        return expr.name  # a part type, in a list domain such as [RingS, RingM]
    return evaluate(expr, scope.numbers())


def _domain_values(domain: ast.Domain, scope: _Scope) -> list[Value | str]:
    if isinstance(domain, ast.ListDomain):
        return [_domain_item(i, scope) for i in domain.items]
    if isinstance(domain, ast.RangeDomain):
        low, high = _whole(domain.low, scope), _whole(domain.high, scope)
        _limit_domain(high - low + 1, domain.low.span.to(domain.high.span))
        return [float(i) for i in range(low, high + 1)]
    start, stop = number(domain.start, scope.numbers()), number(domain.stop, scope.numbers())
    count = _whole(domain.count, scope)
    if count < 1:
        raise FabhalError(
            [
                error(
                    "E310",
                    "linspace needs a count of at least 1",
                    domain.count.span,
                    "write `linspace(START, STOP, COUNT)` with COUNT the number of values, e.g. 5",
                )
            ]
        )
    _limit_domain(count, domain.count.span)
    step = (stop - start) / (count - 1) if count > 1 else 0.0
    # to 12 significant digits: 7 x 2.285 is 15.995 as written, not 15.995000000000001
    return [float(f"{start + k * step:.12g}") for k in range(count)]


def _limit_domain(count: int, span: Span) -> None:
    if count > DOMAIN_VALUE_LIMIT:
        raise FabhalError(
            [
                error(
                    "E312",
                    f"too many values: this domain has {count:,}, at most {DOMAIN_VALUE_LIMIT:,} are allowed",
                    span,
                    "a family search tries every value: use `linspace(START, STOP, COUNT)` with a "
                    "smaller COUNT",
                )
            ]
        )


def _require_in_domain(
    decl: ast.ParamDecl, value: Value | str, candidates: list[Value | str], where: str, span: Span
) -> None:
    if not _in_domain(value, decl.domain, candidates):
        shown = ", ".join(_show(c) for c in candidates[:8]) + (", ..." if len(candidates) > 8 else "")
        raise FabhalError(
            [
                error(
                    "E310",
                    f"{where} is outside the domain of `{decl.name}`",
                    span,
                    f"`{decl.name}` takes one of: {shown}",
                )
            ]
        )


def _in_domain(value: Value | str, domain: ast.Domain, candidates: list[Value | str]) -> bool:
    if isinstance(domain, ast.LinspaceDomain) and isinstance(value, float):
        numbers = [float(c) for c in candidates if isinstance(c, float)]
        return min(numbers) - 1e-9 <= value <= max(numbers) + 1e-9
    if isinstance(value, float):
        return any(isinstance(c, float) and abs(c - value) < 1e-9 for c in candidates)
    return value in candidates


def _show(value: Value | str) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _parse_binding(text: str) -> Value | str:
    try:
        value = float(text)
    except ValueError:
        return text
    return value if math.isfinite(value) else text  # `-D e=nan` is no number: not in any domain


def _params_help(scope: _Scope) -> str:
    names = [k for k in scope.values]
    return f"its parameters: {', '.join(names)}" if names else "this program declares no parameters"


def elaborate(
    program: LoadedProgram, library: Library, bindings: Mapping[str, str] | None = None
) -> tuple[FlatProgram | None, list[Diagnostic]]:
    """Flatten the main module; returns None as the program when it has none."""
    if program.main is None:
        return None, []
    elaborator = _Elaborator(program, library, bindings or {})
    flat = elaborator.run(program.main)
    return flat, elaborator.problems


# Members of one family (`fabhal search`): enough for every param combination a
# user would solve (the clip-light study is 336), few enough that a runaway
# product of domains is a message, not minutes of enumerating.
FAMILY_MEMBER_LIMIT = 100_000


def binding_text(value: Value | str) -> str:
    """A param value as `-D NAME=VALUE` writes it; reads back as the same float."""
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return repr(value) if isinstance(value, float) else str(value)


def family(
    program: LoadedProgram, pinned: Mapping[str, str] | None = None
) -> tuple[list[dict[str, str]], list[Diagnostic]]:
    """Every combination of values of the program's top-level `param`s, in the
    order they are declared (the last varies fastest), as bindings in the form
    `-D` takes. A domain may use the params above it (`param k in 1 .. n`):
    it is evaluated for each of their values. `pinned` params take only their
    given value (checked when each member is elaborated)."""
    if program.main is None:
        return [], []
    pinned = dict(pinned or {})
    decls = [s for s in program.main.statements if isinstance(s, ast.ParamDecl)]
    members: list[dict[str, str]] = []
    try:
        _extend_family(decls, _Scope(""), {}, pinned, members)
    except FabhalError as exc:
        return [], list(exc.diagnostics)
    unknown = sorted(set(pinned) - {d.name for d in decls})
    if unknown:
        names = ", ".join(d.name for d in decls) or "none"
        missing = f"-D {unknown[0]}=...: the program has no `param {unknown[0]}`"
        return [], [error("E310", missing, None, f"its parameters: {names}")]
    return members, []


def _extend_family(
    decls: list[ast.ParamDecl],
    scope: _Scope,
    chosen: dict[str, str],
    pinned: Mapping[str, str],
    members: list[dict[str, str]],
) -> None:
    if not decls:
        if len(members) >= FAMILY_MEMBER_LIMIT:
            raise FabhalError([_too_many_members()])
        members.append(dict(chosen))
        return
    decl, rest = decls[0], decls[1:]
    values = _domain_values(decl.domain, scope)
    if decl.name in pinned:  # one value, said once if it is outside, not once per member
        value = _parse_binding(pinned[decl.name])
        _require_in_domain(decl, value, values, f"-D {decl.name}={pinned[decl.name]}", decl.span)
        values = [value]
    for value in values:
        scope.values[decl.name] = value
        chosen[decl.name] = pinned.get(decl.name) or binding_text(value)
        _extend_family(rest, scope, chosen, pinned, members)
    scope.values.pop(decl.name, None)
    chosen.pop(decl.name, None)


def _too_many_members() -> Diagnostic:
    return error(
        "E312",
        f"this family has more than {FAMILY_MEMBER_LIMIT:,} members",
        None,
        "fix some params with -D NAME=VALUE, use fewer values in a `linspace`, or solve a random "
        "subset with --sample N",
    )
