"""`fabhal lsp` end to end over stdio (pytest-lsp starts it as a subprocess
and speaks the protocol to it): diagnostics as you type, hover, completion,
go-to-definition and document symbols on the mug hanger."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

pytest_lsp = pytest.importorskip("pytest_lsp", reason="pytest-lsp is installed by the [test] extra")
types = pytest.importorskip("lsprotocol.types", reason="lsprotocol comes with pygls, the [lsp] extra")

from pytest_lsp import ClientServerConfig, LanguageClient  # noqa: E402

from tests.conftest import REPO  # noqa: E402

PROGRAM = REPO / "programs" / "mug_hanger.fhl"
TEXT = PROGRAM.read_text()
URI = PROGRAM.as_uri()


@pytest_lsp.fixture(config=ClientServerConfig(server_command=[sys.executable, "-m", "fabhal", "lsp"]))
async def client(lsp_client: LanguageClient):  # type: ignore[no-untyped-def]
    await lsp_client.initialize_session(
        types.InitializeParams(capabilities=pytest_lsp.client_capabilities("visual-studio-code"))
    )
    yield
    await lsp_client.shutdown_session()


def position_of(text: str, needle: str, offset: int = 0) -> types.Position:
    """The position of `needle`'s first occurrence (plus `offset` characters)."""
    before = text[: text.index(needle) + offset]
    return types.Position(before.count("\n"), len(before.rsplit("\n", 1)[-1]))


def open_document(client: LanguageClient, text: str, version: int = 1) -> None:
    client.text_document_did_open(
        types.DidOpenTextDocumentParams(
            types.TextDocumentItem(uri=URI, language_id="fabhal", version=version, text=text)
        )
    )


@pytest.mark.asyncio
async def test_diagnostics_as_you_type_are_fabhal_checks(client: LanguageClient) -> None:
    """The clean program publishes nothing; a typo in a primitive (unsaved: the
    file on disk is untouched) publishes E304 at the span `fabhal check` gives,
    with its help; fixing it clears it again."""
    open_document(client, TEXT)
    await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    assert list(client.diagnostics[URI]) == []
    broken = TEXT.replace("connect mug.hook -- s3.hook2", "connect mug.hook -- s3.hookk2")
    client.text_document_did_change(
        types.DidChangeTextDocumentParams(
            types.VersionedTextDocumentIdentifier(uri=URI, version=2),
            [types.TextDocumentContentChangeWholeDocument(text=broken)],
        )
    )
    await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    (problem,) = client.diagnostics[URI]
    assert (problem.code, problem.source, problem.severity) == (
        "E304",
        "fabhal",
        types.DiagnosticSeverity.Error,
    )
    assert problem.range.start == position_of(broken, "s3.hookk2")  # 0-based, as LSP counts
    assert "has no primitive `hookk2`" in problem.message and "help: did you mean `hook2`?" in problem.message


@pytest.mark.asyncio
async def test_hover_tells_a_part_type_and_a_primitive(client: LanguageClient) -> None:
    open_document(client, TEXT)
    on_type = await client.text_document_hover_async(
        types.HoverParams(types.TextDocumentIdentifier(URI), position_of(TEXT, "DoubleHook()", 2))
    )
    assert on_type is not None and "**DoubleHook** (part)" in on_type.contents.value
    assert "`hook1`: hook" in on_type.contents.value and "mass " in on_type.contents.value
    on_primitive = await client.text_document_hover_async(
        types.HoverParams(types.TextDocumentIdentifier(URI), position_of(TEXT, "s3.hook2", 4))
    )
    assert on_primitive is not None
    assert on_primitive.contents.value.startswith("`s3.hook2` of **DoubleHook**: `hook2`: hook (")
    assert "DoFs: theta" in on_primitive.contents.value
    on_keyword = await client.text_document_hover_async(
        types.HoverParams(types.TextDocumentIdentifier(URI), position_of(TEXT, "connect chain.top", 2))
    )
    assert on_keyword is not None and on_keyword.contents.value.startswith(
        "`connect a.primitive -- b.primitive`"
    )


@pytest.mark.asyncio
async def test_completion_offers_primitives_after_a_dot_and_part_types_elsewhere(
    client: LanguageClient,
) -> None:
    text = TEXT + "connect mug.\n"
    open_document(client, text)
    end = types.Position(text.count("\n") - 1, len("connect mug."))
    after_dot = await client.text_document_completion_async(
        types.CompletionParams(types.TextDocumentIdentifier(URI), end)
    )
    # the Mug's primitives (its handle and its body), found while the line does not parse yet
    assert {item.label for item in after_dot.items} == {"hook", "tube"}
    anywhere = await client.text_document_completion_async(
        types.CompletionParams(types.TextDocumentIdentifier(URI), types.Position(text.count("\n"), 0))
    )
    labels = {item.label for item in anywhere.items}
    assert {"DoubleHook", "Mug", "SHookChain", "connect", "noflip", "set", "s3"} <= labels


@pytest.mark.asyncio
async def test_completion_offers_a_primitives_dofs_in_a_setting(client: LanguageClient) -> None:
    """In `set (s3.hook2.`: the DoFs a connection makes on the S-hook's hook
    (its place round the arc and its lean), with their ranges."""
    text = TEXT + "connect s3.hook2 -- rod set (s3.hook2.\n"
    open_document(client, text)
    end = types.Position(text.count("\n") - 1, len("connect s3.hook2 -- rod set (s3.hook2."))
    found = await client.text_document_completion_async(
        types.CompletionParams(types.TextDocumentIdentifier(URI), end)
    )
    assert {(item.label, item.detail) for item in found.items} == {
        ("theta", "0 .. 270"),
        ("phi", "45 .. 135"),
    }


@pytest.mark.asyncio
async def test_go_to_definition_of_a_part_type_an_assembly_an_import_and_a_name(
    client: LanguageClient,
) -> None:
    open_document(client, TEXT)
    document = types.TextDocumentIdentifier(URI)

    async def where(needle: str, offset: int) -> types.Location:
        found = await client.text_document_definition_async(
            types.DefinitionParams(document, position_of(TEXT, needle, offset))
        )
        assert isinstance(found, types.Location), needle
        return found

    part = await where("DoubleHook()", 1)
    lines = Path(part.uri.removeprefix("file://")).read_text().splitlines()
    assert lines[part.range.start.line].startswith("part DoubleHook")
    assembly = await where("SHookChain(n", 1)
    assert assembly.uri.endswith("/lib/s_hook_chain.fhl")
    imported = await where('import "lib', 3)
    assert imported.uri == (REPO / "programs" / "lib" / "s_hook_chain.fhl").as_uri()
    name = await where("connect s3.hook1", 9)
    assert name.uri == URI and name.range.start == position_of(TEXT, "s3  = DoubleHook()")


@pytest.mark.asyncio
async def test_document_symbols_list_the_program(client: LanguageClient) -> None:
    open_document(client, TEXT)
    found = await client.text_document_document_symbol_async(
        types.DocumentSymbolParams(types.TextDocumentIdentifier(URI))
    )
    names = [symbol.name for symbol in found]
    assert names == [
        "rod", "wall", "chain", "s3", "mug",
        "chain.top -- rod", "s3.hook1 -- chain.bottom", "mug.hook -- s3.hook2", "target mug.hook",
    ]  # fmt: skip


def test_every_keyword_has_a_hover_line() -> None:
    from fabhal.lsp.features import KEYWORDS
    from fabhal.syntax.lexer import grammar_keywords

    assert set(KEYWORDS) == set(grammar_keywords())
