"""What the language server answers, as functions of a document's text: the
diagnostics of `fabhal check`, hover on a part type, an assembly or a
primitive, completion, go-to-definition and the document's symbols."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lsprotocol import types

from fabhal import api
from fabhal.diagnostics import Diagnostic, Severity
from fabhal.library import Library
from fabhal.load import InputError, import_candidates, load_program
from fabhal.report.parts import detail
from fabhal.source import Span
from fabhal.syntax import ast
from fabhal.syntax.lexer import grammar_keywords

_SEVERITY = {
    Severity.ERROR: types.DiagnosticSeverity.Error,
    Severity.WARNING: types.DiagnosticSeverity.Warning,
    Severity.NOTE: types.DiagnosticSeverity.Information,
}
# what each keyword does, in a line (docs/language.md has the whole of it)
KEYWORDS = {
    "import": '`import "file.fhl"`: bring in that file\'s `part`, `assembly` and `material` definitions',
    "param": "`param NAME in DOMAIN = DEFAULT`: a design parameter; `fabhal search` tries every value",
    "in": "`param NAME in DOMAIN`: the values a parameter takes (`1 .. 4`, `linspace(...)`, `[A, B]`)",
    "linspace": "`linspace(START, STOP, COUNT)`: COUNT evenly spaced values, both ends included",
    "environment": "`environment NAME = Type(...) at (x, y, z)`: fixed scenery the hack hangs from",
    "connect": "`connect a.primitive -- b.primitive`: these two connectors touch; the solver finds how",
    "flip": "`flip`: the connection turned over (its alignment pinned the other way round)",
    "noflip": "`noflip`: the default way round, pinned (written with neither, the solver may turn it)",
    "fixed": "`fixed`: set once when building and then held (the solver aims it, N506)",
    "set": "`set (side.DOF: VALUE, ...)`: the builder's setting of a connection's DoF, held there "
    "(`fabhal solve --dofs` lists them)",
    "target": "`target part.primitive at (x, y, z) rot (a, b, c)`: where the held object should end up",
    "for": "`for i in LOW .. HIGH { ... }`: the block once per whole number i",
    "assembly": "`assembly Name(params) { ... port p = part.primitive }`: a reusable sub-assembly",
    "port": "`port NAME = part.primitive`: an assembly's open end, used as `instance.NAME`",
    "part": "`part Name(params) { mesh ... mass ... primitive ... }`: a part of the library",
    "mesh": '`mesh "file.obj"`: the part\'s shape (for contact, mass and pictures)',
    "mass": "`mass GRAMS`: the part's mass where its mesh cannot give it (say why in a comment)",
    "material": "`material NAME`: what the part is made of (its density gives the mass)",
    "at": "`at (x, y, z)`: a position, in mm",
    "rot": "`rot (a, b, c)`: a rotation, in degrees (docs/language.md: the Euler convention)",
}
_WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_MEMBER_BEFORE = re.compile(r"([A-Za-z_]\w*)(?:\[[^\]]*\])?\.(\w*)$")  # `s1.ho`, `tb[i].`
_DOF_BEFORE = re.compile(r"([A-Za-z_]\w*)(?:\[[^\]]*\])?\.(\w+)\.(\w*)$")  # `set (s1.hook2.th`


@dataclass(frozen=True)
class Document:
    """A program as the editor holds it, checked."""

    path: Path
    text: str
    check: api.CheckResult | None  # None: the file's folder cannot even be read
    # the program's structure (names, imports): the check's, or while a line does not
    # parse (mid-typing), that of the text without the lines that do not
    structure: api.CheckResult | None = None

    @classmethod
    def of(cls, path: Path, text: str) -> Document:
        try:
            check = api.check(load_program(path, text))
        except InputError:
            return cls(path, text, None)
        structure = check
        if check.program.main is None:
            broken = {d.span.line for d in check.diagnostics if d.span is not None and d.is_error}
            kept = [
                ("" if number in broken else line) for number, line in enumerate(text.split("\n"), start=1)
            ]
            structure = api.check(load_program(path, "\n".join(kept)))
        return cls(path, text, check, structure)

    @property
    def library(self) -> Library | None:
        return self.check.library if self.check is not None else None

    def statements(self) -> Iterator[ast.Statement]:
        """Every statement of the program, those inside `for` loops too."""
        main = self.structure.program.main if self.structure is not None else None
        yield from _walk(main.statements if main is not None else ())

    def assemblies(self) -> dict[str, ast.AssemblyDef]:
        if self.structure is None:
            return {}
        modules = self.structure.program.modules
        return {s.name: s for m in modules for s in m.statements if isinstance(s, ast.AssemblyDef)}

    def instance_type(self, name: str) -> str | None:
        """The part type (or assembly) a name of the program is made from."""
        for statement in self.statements():
            if isinstance(statement, ast.InstanceDecl | ast.EnvironmentDecl) and statement.name.name == name:
                return statement.call.callee
        return None

    def file_of(self, span: Span) -> Path | None:
        if self.structure is None:
            return None
        return self.structure.program.paths.get(span.file)


def _walk(statements: tuple[ast.Statement, ...]) -> Iterator[ast.Statement]:
    for statement in statements:
        yield statement
        if isinstance(statement, ast.ForLoop):
            yield from _walk(statement.body)


# ---------------------------------------------------------------- diagnostics


def diagnostics(document: Document) -> list[types.Diagnostic]:
    """`fabhal check`'s diagnostics in this file (the same codes, spans and help)."""
    if document.check is None:
        return []
    name = _own_name(document)
    return [_lsp_diagnostic(d) for d in document.check.diagnostics if d.span is None or d.span.file == name]


def _own_name(document: Document) -> str | None:
    if document.check is None:
        return None
    own = document.path.resolve()
    return next((name for name, path in document.check.program.paths.items() if path.resolve() == own), None)


def _lsp_diagnostic(diagnostic: Diagnostic) -> types.Diagnostic:
    message = diagnostic.message + (f"\nhelp: {diagnostic.help}" if diagnostic.help else "")
    return types.Diagnostic(
        range=_range(diagnostic.span)
        if diagnostic.span
        else types.Range(types.Position(0, 0), types.Position(0, 0)),
        message=message,
        severity=_SEVERITY[diagnostic.severity],
        code=diagnostic.code,
        source="fabhal",
    )


def _range(span: Span) -> types.Range:
    return types.Range(
        start=types.Position(span.line - 1, span.column - 1),
        end=types.Position(span.end_line - 1, span.end_column - 1),
    )


# ---------------------------------------------------------------- hover


def hover(document: Document, position: types.Position) -> types.Hover | None:
    """A part type, an assembly, or a primitive (`s1.hook2`): what it is."""
    line = _line(document.text, position.line)
    word = _word_at(line, position.character)
    if word is None or document.library is None:
        return None
    before = line[: word[1]]
    member = _MEMBER_BEFORE.search(before + word[0])
    if member and before.endswith("."):
        text = _primitive_hover(document, member.group(1), word[0])
    else:
        text = _type_hover(document, word[0]) or KEYWORDS.get(word[0])
    if text is None:
        return None
    span = types.Range(types.Position(position.line, word[1]), types.Position(position.line, word[2]))
    return types.Hover(contents=types.MarkupContent(types.MarkupKind.Markdown, text), range=span)


def _type_hover(document: Document, name: str) -> str | None:
    library = document.library
    assert library is not None
    if name in library.parts:
        part_type = library.parts[name]
        info = detail(part_type, library.instantiate(name, {}, part_type.span))
        mass = "unknown" if info["mass_g"] is None else f"{info['mass_g']:g} g"
        lines = [
            f"**{name}** (part): {info['description'] or ''}",
            "",
            f"mass {mass}, material {info['material']}",
        ]
        for parameter in info["parameters"]:
            lines.append(f"- parameter `{parameter['name']}`: {parameter['min']:g} .. {parameter['max']:g}")
        lines += ["", "primitives:"]
        lines += [f"- {_primitive_line(p)}" for p in info["primitives"]]
        return "\n".join(lines)
    assembly = document.assemblies().get(name)
    if assembly is not None:
        ports = [s.name for s in assembly.body if isinstance(s, ast.PortDecl)]
        params = ", ".join(p.name for p in assembly.params)
        head = f"**{name}** (assembly{f'; params {params}' if params else ''}): {assembly.description or ''}"
        return head + "\n\nports: " + (", ".join(f"`{p}`" for p in ports) or "none")
    return None


def _primitive_hover(document: Document, instance: str, primitive: str) -> str | None:
    library = document.library
    part_name = document.instance_type(instance)
    if library is None or part_name is None or part_name not in library.parts:
        return None
    part_type = library.parts[part_name]
    info = detail(part_type, library.instantiate(part_name, {}, part_type.span))
    found = next((p for p in info["primitives"] if p["name"] == primitive), None)
    return f"`{instance}.{primitive}` of **{part_name}**: {_primitive_line(found)}" if found else None


def _primitive_line(primitive: dict[str, Any]) -> str:
    shape = ", ".join(f"{k} {v:g}" for k, v in primitive["parameters"].items())
    dofs = ", ".join(f"{d['name']} {d['min']:g}..{d['max']:g}" for d in primitive["dofs"])
    return f"`{primitive['name']}`: {primitive['kind']} ({shape}); DoFs: {dofs or 'none'}"


# ---------------------------------------------------------------- completion


def completion(document: Document, position: types.Position) -> list[types.CompletionItem]:
    """After `name.`: that part's primitives (or the assembly's ports); after
    `name.primitive.` (a `set (...)`): the primitive's DoFs; elsewhere part
    types, assemblies, keywords and the program's names."""
    before = _line(document.text, position.line)[: position.character]
    dof = _DOF_BEFORE.search(before)
    if dof is not None:
        return _dofs(document, dof.group(1), dof.group(2))
    member = _MEMBER_BEFORE.search(before)
    if member is not None:
        return _members(document, member.group(1))
    items = [types.CompletionItem(k, kind=types.CompletionItemKind.Keyword) for k in grammar_keywords()]
    if document.library is not None:
        items += [
            types.CompletionItem(name, kind=types.CompletionItemKind.Class, detail=t.description or "part")
            for name, t in sorted(document.library.parts.items())
        ]
    items += [
        types.CompletionItem(name, kind=types.CompletionItemKind.Module, detail=a.description or "assembly")
        for name, a in sorted(document.assemblies().items())
    ]
    names = {
        s.name.name for s in document.statements() if isinstance(s, ast.InstanceDecl | ast.EnvironmentDecl)
    }
    items += [types.CompletionItem(n, kind=types.CompletionItemKind.Variable) for n in sorted(names)]
    return items


def _dofs(document: Document, instance: str, primitive: str) -> list[types.CompletionItem]:
    """The DoFs a connection makes on that primitive, with their ranges."""
    type_name = document.instance_type(instance)
    library = document.library
    if type_name is None or library is None or type_name not in library.parts:
        return []
    spec = library.instantiate(type_name, {}, library.parts[type_name].span)
    found = spec.primitive(primitive)
    if found is None:
        return []
    return [
        types.CompletionItem(
            d.name,
            kind=types.CompletionItemKind.Property,
            detail="turns freely" if d.periodic else f"{d.low:g} .. {d.high:g}",
        )
        for d in found.dofs
    ]


def _members(document: Document, instance: str) -> list[types.CompletionItem]:
    type_name = document.instance_type(instance)
    library = document.library
    if type_name is None or library is None:
        return []
    if type_name in library.parts:
        part_type = library.parts[type_name]
        spec = library.instantiate(type_name, {}, part_type.span)
        return [
            types.CompletionItem(
                p.name, kind=types.CompletionItemKind.Field, detail=f"{p.kind} of {type_name}"
            )
            for p in spec.primitives
        ]
    assembly = document.assemblies().get(type_name)
    ports = [s.name for s in assembly.body if isinstance(s, ast.PortDecl)] if assembly else []
    return [
        types.CompletionItem(p, kind=types.CompletionItemKind.Field, detail=f"port of {type_name}")
        for p in ports
    ]


# ---------------------------------------------------------------- definition


def definition(document: Document, position: types.Position) -> types.Location | None:
    """A part type's or assembly's definition, an import's file, a name's declaration."""
    line = _line(document.text, position.line)
    imported = re.match(r'\s*import\s+"([^"]+)"', line)
    if imported:
        target = _import_target(document.path, imported.group(1))
        origin = types.Range(types.Position(0, 0), types.Position(0, 0))
        return types.Location(target.as_uri(), origin) if target else None
    word = _word_at(line, position.character)
    if word is None or document.check is None:
        return None
    name, start, _ = word
    if start > 0 and line[start - 1] == ".":
        return None  # a primitive: defined inside its part, not worth a jump
    span = _definition_span(document, name)
    path = document.file_of(span) if span else None
    return types.Location(path.as_uri(), _range(span)) if span and path else None


def _definition_span(document: Document, name: str) -> Span | None:
    library = document.library
    if library is not None and name in library.parts:
        return library.parts[name].span
    assembly = document.assemblies().get(name)
    if assembly is not None:
        return assembly.span
    for statement in document.statements():
        if (
            isinstance(statement, ast.InstanceDecl | ast.EnvironmentDecl | ast.AliasDecl)
            and statement.name.name == name
        ):
            return statement.name.span
    return None


def _import_target(importer: Path, written: str) -> Path | None:
    """The file `import "written"` loads (the loader's own search)."""
    found = next((c for c in import_candidates(importer, written) if c.is_file()), None)
    return found.resolve() if found is not None else None


# ---------------------------------------------------------------- symbols


def symbols(document: Document) -> list[types.DocumentSymbol]:
    """The program's params, parts, environments, assemblies, connections and targets."""
    found = []
    for statement in document.statements():
        entry = _symbol(statement)
        if entry is not None:
            name, kind, detail_text = entry
            span = _range(statement.span)
            found.append(types.DocumentSymbol(name, kind, span, span, detail=detail_text))
    return found


def _symbol(statement: ast.Statement) -> tuple[str, types.SymbolKind, str] | None:
    if isinstance(statement, ast.ParamDecl):
        return statement.name, types.SymbolKind.Variable, "param"
    if isinstance(statement, ast.EnvironmentDecl):
        return statement.name.name, types.SymbolKind.Constant, f"environment {statement.call.callee}"
    if isinstance(statement, ast.InstanceDecl):
        return statement.name.name, types.SymbolKind.Object, statement.call.callee
    if isinstance(statement, ast.AssemblyDef | ast.PartDef):
        return (
            statement.name,
            types.SymbolKind.Class,
            "assembly" if isinstance(statement, ast.AssemblyDef) else "part",
        )
    if isinstance(statement, ast.ConnectStmt):
        return f"{_ref(statement.a)} -- {_ref(statement.b)}", types.SymbolKind.Event, "connect"
    if isinstance(statement, ast.TargetStmt):
        return f"target {_ref(statement.ref)}", types.SymbolKind.Field, "target"
    return None


def _ref(ref: ast.Ref) -> str:
    return ref.base.name + (f".{ref.primitive}" if ref.primitive else "")


# ---------------------------------------------------------------- text


def _line(text: str, number: int) -> str:
    lines = text.splitlines()
    return lines[number] if 0 <= number < len(lines) else ""


def _word_at(line: str, character: int) -> tuple[str, int, int] | None:
    for match in _WORD.finditer(line):
        if match.start() <= character <= match.end():
            return match.group(), match.start(), match.end()
    return None
