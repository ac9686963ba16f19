"""The language server: pygls 2 over stdio, each feature answered by features.py
from the document as the editor holds it (checked again on every change)."""

from __future__ import annotations

from pathlib import Path

from lsprotocol import types
from pygls.lsp.server import LanguageServer
from pygls.uris import to_fs_path

from fabhal import __version__
from fabhal.lsp import features

server = LanguageServer("fabhal", __version__)


def _document(ls: LanguageServer, uri: str) -> features.Document:
    text = ls.workspace.get_text_document(uri).source
    return features.Document.of(Path(to_fs_path(uri) or uri), text)


def _publish(ls: LanguageServer, uri: str, version: int | None) -> None:
    found = features.diagnostics(_document(ls, uri))
    ls.text_document_publish_diagnostics(
        types.PublishDiagnosticsParams(uri=uri, diagnostics=found, version=version)
    )


@server.feature(types.TEXT_DOCUMENT_DID_OPEN)
def did_open(ls: LanguageServer, params: types.DidOpenTextDocumentParams) -> None:
    _publish(ls, params.text_document.uri, params.text_document.version)


@server.feature(types.TEXT_DOCUMENT_DID_CHANGE)
def did_change(ls: LanguageServer, params: types.DidChangeTextDocumentParams) -> None:
    _publish(ls, params.text_document.uri, params.text_document.version)


@server.feature(types.TEXT_DOCUMENT_HOVER)
def hover(ls: LanguageServer, params: types.HoverParams) -> types.Hover | None:
    return features.hover(_document(ls, params.text_document.uri), params.position)


@server.feature(types.TEXT_DOCUMENT_COMPLETION, types.CompletionOptions(trigger_characters=["."]))
def completion(ls: LanguageServer, params: types.CompletionParams) -> types.CompletionList:
    items = features.completion(_document(ls, params.text_document.uri), params.position)
    return types.CompletionList(is_incomplete=False, items=items)


@server.feature(types.TEXT_DOCUMENT_DEFINITION)
def definition(ls: LanguageServer, params: types.DefinitionParams) -> types.Location | None:
    return features.definition(_document(ls, params.text_document.uri), params.position)


@server.feature(types.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
def document_symbol(ls: LanguageServer, params: types.DocumentSymbolParams) -> list[types.DocumentSymbol]:
    return features.symbols(_document(ls, params.text_document.uri))


def main() -> None:
    server.start_io()
