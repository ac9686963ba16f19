"""The VS Code extension (editors/vscode/): its TextMate grammar tokenizes every
`.fhl` file in the repository with VS Code's own engine (vscode-textmate and
vscode-oniguruma from the npm registry, installed here once), and marks the
keywords, connection options and comments exactly where the Pygments lexer
(fabhal/syntax/lexer.py, whose keywords are the parser grammar's) does."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
from pygments.token import Comment, Keyword

from fabhal.syntax.lexer import FabhalLexer, grammar_keywords
from tests.conftest import REPO, all_fhl_files

EXTENSION = REPO / "editors" / "vscode"
GRAMMAR = EXTENSION / "syntaxes" / "fabhal.tmLanguage.json"
PACKAGES = ["vscode-textmate@9", "vscode-oniguruma@2"]


@pytest.fixture(scope="session")
def textmate(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with node_modules/vscode-textmate (and oniguruma), from the npm registry."""
    npm, node = shutil.which("npm"), shutil.which("node")
    if npm is None or node is None:
        pytest.skip("Node.js and npm are not installed: the TextMate engine runs on Node")
    folder = tmp_path_factory.mktemp("textmate")
    run = subprocess.run(
        [npm, "install", "--no-audit", "--no-fund", "--prefix", str(folder), *PACKAGES],
        capture_output=True,
        text=True,
        timeout=300,
    )
    if run.returncode != 0:
        pytest.skip(f"npm could not install {' '.join(PACKAGES)}: {run.stderr.strip()[-300:]}")
    return folder


def test_the_manifest_declares_the_language_and_its_grammar() -> None:
    manifest = json.loads((EXTENSION / "package.json").read_text())
    (language,) = manifest["contributes"]["languages"]
    (grammar,) = manifest["contributes"]["grammars"]
    assert language["extensions"] == [".fhl"] and grammar["language"] == language["id"]
    assert (EXTENSION / grammar["path"]).resolve() == GRAMMAR
    assert json.loads((EXTENSION / language["configuration"]).read_text())["comments"] == {"lineComment": "#"}
    assert json.loads(GRAMMAR.read_text())["scopeName"] == grammar["scopeName"] == "source.fhl"


def test_every_keyword_of_the_parser_grammar_is_in_the_textmate_grammar() -> None:
    repository = json.loads(GRAMMAR.read_text())["repository"]
    listed = repository["keyword"]["match"] + repository["option"]["match"]
    missing = [
        word for word in grammar_keywords() if f"|{word}|" not in listed.replace("(", "|").replace(")", "|")
    ]
    assert missing == []


def pygments_marks(text: str) -> set[tuple[int, int, str]]:
    """(line, column, kind) of each keyword and comment, as the Pygments lexer finds them."""
    marks, line, column = set(), 1, 0
    for kind, value in FabhalLexer().get_tokens(text):
        if kind in Keyword and kind is not Keyword.Constant:
            marks.add((line, column, "keyword"))
        elif kind in Comment:
            marks.add((line, column, "comment"))
        line, column = (
            (line + value.count("\n"), len(value.rsplit("\n", 1)[1]))
            if "\n" in value
            else (line, column + len(value))
        )
    return marks


def test_vscode_tokenizes_every_program_as_the_lexer_does(textmate: Path) -> None:
    files = all_fhl_files()
    run = subprocess.run(
        ["node", str(Path(__file__).parent / "tokenize.cjs"), str(GRAMMAR), *map(str, files)],
        cwd=textmate,
        env={
            "NODE_PATH": str(textmate / "node_modules"),
            "PATH": str(Path(shutil.which("node") or "").parent),
        },
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    tokens = json.loads(run.stdout)
    for path in files:
        marks = {
            (
                line,
                start,
                "keyword" if scope.startswith(("keyword.control", "storage.modifier")) else "comment",
            )
            for line, start, _, scope in tokens[str(path)]
            if scope.startswith(("keyword.control", "storage.modifier", "comment"))
        }
        assert marks == pygments_marks(path.read_text()), path
