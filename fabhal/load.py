"""Files -> parsed modules: the program, what it imports, and the part library.

`import "path.fhl"` resolves relative to the importing file, then to the
standard library, then to the installed gallery (so `import
"lib/s_hook_chain.fhl"`, a reusable sub-assembly, works from any directory).
The standard library (`stdlib_parts/*.fhl`) is always loaded, so
`DoubleHook()` needs no import. Importing a file twice (or in a cycle) loads
it once.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fabhal import resources
from fabhal.diagnostics import Diagnostic, FabhalError, error
from fabhal.resources import display_name
from fabhal.source import SourceFile
from fabhal.syntax import ast
from fabhal.syntax.parser import parse_source, parse_source_cached


class InputError(FabhalError):
    """The program file itself cannot be read (missing, unreadable, not UTF-8)."""


@dataclass(frozen=True)
class LoadedProgram:
    """The main module (None if it has syntax errors), every module it pulled in
    (library first), their sources, and what went wrong reading them."""

    main: ast.Module | None
    modules: tuple[ast.Module, ...]
    sources: dict[str, SourceFile]
    paths: dict[str, Path]  # display name -> file, to resolve paths written in a module
    diagnostics: tuple[Diagnostic, ...]


def read_source(path: Path) -> SourceFile:
    """Read a program file, turning OS and encoding failures into an InputError."""
    name = display_name(path)
    try:
        return SourceFile.read(path, name)
    except FileNotFoundError:
        raise InputError([error("E001", f"no such file: {name}", None, "check the path")]) from None
    except IsADirectoryError:
        raise InputError(
            [error("E001", f"{name} is a directory, not a .fhl file", None, "name a .fhl file inside it")]
        ) from None
    except PermissionError:
        raise InputError(
            [error("E001", f"cannot read {name}: permission denied", None, "check the file's permissions")]
        ) from None
    except UnicodeDecodeError as exc:
        raise InputError(
            [error("E002", f"{name} is not UTF-8 text (byte {exc.start})", None, "save the file as UTF-8")]
        ) from None
    except OSError as exc:
        raise InputError(
            [error("E001", f"cannot read {name}: {exc.strerror}", None, "check the path and the disk")]
        ) from None


class _Loader:
    def __init__(self, unsaved: dict[Path, str] | None = None) -> None:
        self.unsaved = unsaved or {}  # an editor's text of a file, in place of what is on disk
        self.modules: dict[Path, ast.Module] = {}
        self.sources: dict[str, SourceFile] = {}
        self.paths: dict[str, Path] = {}
        self.diagnostics: list[Diagnostic] = []

    def load(self, path: Path) -> ast.Module | None:
        path = path.resolve()
        if path in self.modules:
            return self.modules[path]
        source = (
            SourceFile(display_name(path), self.unsaved[path]) if path in self.unsaved else read_source(path)
        )
        self.sources[source.name] = source
        self.paths[source.name] = path
        try:
            in_library = path.parent == resources.stdlib_dir().resolve()
            module = parse_source_cached(source) if in_library else parse_source(source)
        except FabhalError as exc:
            self.diagnostics.extend(exc.diagnostics)
            return None
        self.modules[path] = module  # before its imports: a cycle then stops here
        for statement in module.statements:
            if isinstance(statement, ast.ImportStmt):
                self._load_import(path, statement)
        return module

    def _load_import(self, importer: Path, statement: ast.ImportStmt) -> None:
        candidates = import_candidates(importer, statement.path)
        for candidate in candidates:
            if candidate.is_file():
                try:
                    self.load(candidate)
                except InputError as exc:  # unreadable import: report it at the import line
                    self.diagnostics.append(
                        error(
                            "E003",
                            exc.diagnostics[0].message,
                            statement.span,
                            exc.diagnostics[0].help or "fix the imported file",
                        )
                    )
                return
        searched = ", ".join(display_name(c.parent) for c in candidates)
        self.diagnostics.append(
            error(
                "E003",
                f'cannot find "{statement.path}" to import',
                statement.span,
                f"looked in {searched}; a path is relative to the importing file, the part "
                "library or the gallery (`fabhal gallery` lists what it has)",
            )
        )


def import_candidates(importer: Path, written: str) -> list[Path]:
    """Where `import "written"` in `importer` is looked for, in order: beside
    the importing file, in the part library, in the gallery."""
    return [base / written for base in (importer.parent, resources.stdlib_dir(), resources.gallery_dir())]


def load_program(path: Path | None, text: str | None = None) -> LoadedProgram:
    """Parse `path` (if any), its imports and the standard library; raises
    InputError if `path` itself cannot be read. Syntax errors come back as
    diagnostics. `text`: the program as an editor holds it, unsaved (its
    imports are still found from `path`'s folder)."""
    unsaved = {path.resolve(): text} if path is not None and text is not None else {}
    loader = _Loader(unsaved)
    for library_file in sorted(resources.stdlib_dir().glob("*.fhl")):
        loader.load(library_file)
    main = loader.load(path) if path is not None else None
    return LoadedProgram(
        main, tuple(loader.modules.values()), loader.sources, loader.paths, tuple(loader.diagnostics)
    )
