"""`advise lsp` driven end to end by pytest-lsp (pygls's client), a client this project did not
write. Run by tests/lsp.rs with ADVISE_BIN set to the binary under test."""

import asyncio
import os
import pathlib

import pytest
import pytest_lsp
from lsprotocol import types
from pytest_lsp import ClientServerConfig, LanguageClient

ADVISE = os.environ["ADVISE_BIN"]
CACHE = os.environ["ADVISE_LSP_CACHE"]

DOC = (
    "// café: a comment with non-ASCII text\n"
    "/// Creep along.\n"
    "operator creep(f = 0.5 in [0, 1]) for positioning on action where trans != 0 {\n"
    "  trans *= f\n"
    "  rott = 0\n"
    "}\n"
    "operator twice for positioning on action = creep then speed_up\n"
)
URI = "file:///lab/creep.adv"


@pytest_lsp.fixture(
    config=ClientServerConfig(
        server_command=[ADVISE, "lsp"],
        server_env={**os.environ, "XDG_CACHE_HOME": CACHE, "NO_COLOR": "1"},
    )
)
async def client(lsp_client: LanguageClient):
    await lsp_client.initialize_session(
        types.InitializeParams(capabilities=types.ClientCapabilities())
    )
    yield
    await lsp_client.shutdown_session()


def position(text, needle, delta=0):
    offset = text.index(needle) + delta
    line = text.count("\n", 0, offset)
    start = text.rfind("\n", 0, offset) + 1
    return types.Position(line=line, character=len(text[start:offset].encode("utf-16-le")) // 2)


async def ask(request, params):
    """A request, answered within ten seconds."""
    return await asyncio.wait_for(request(params), 10)


async def open_doc(client, text=DOC, uri=URI):
    client.text_document_did_open(
        types.DidOpenTextDocumentParams(
            text_document=types.TextDocumentItem(uri=uri, language_id="advise", version=1, text=text)
        )
    )
    await asyncio.wait_for(client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS), 10)


@pytest.mark.asyncio(loop_scope="function")
async def test_diagnostics_on_open_and_change(client: LanguageClient):
    await open_doc(client)
    (d,) = client.diagnostics[URI]
    assert d.code == "advise::check::unknown_dimension"
    assert d.severity == types.DiagnosticSeverity.Error
    assert d.range.start == position(DOC, "rott")
    assert d.range.end == position(DOC, "rott", 4)
    assert "did you mean `rot`" in d.message
    fixed = DOC.replace("rott", "rot")
    client.text_document_did_change(
        types.DidChangeTextDocumentParams(
            text_document=types.VersionedTextDocumentIdentifier(uri=URI, version=2),
            content_changes=[types.TextDocumentContentChangeWholeDocument(text=fixed)],
        )
    )
    await asyncio.wait_for(client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS), 10)
    assert list(client.diagnostics[URI]) == []
    # Closing a file with an error clears its diagnostics.
    client.text_document_did_change(
        types.DidChangeTextDocumentParams(
            text_document=types.VersionedTextDocumentIdentifier(uri=URI, version=3),
            content_changes=[types.TextDocumentContentChangeWholeDocument(text=DOC)],
        )
    )
    await asyncio.wait_for(client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS), 10)
    assert len(client.diagnostics[URI]) == 1
    client.text_document_did_close(
        types.DidCloseTextDocumentParams(text_document=types.TextDocumentIdentifier(uri=URI))
    )
    await asyncio.wait_for(client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS), 10)
    assert list(client.diagnostics[URI]) == []


@pytest.mark.asyncio(loop_scope="function")
async def test_hover(client: LanguageClient):
    await open_doc(client)
    hover = await ask(
        client.text_document_hover_async,
        types.HoverParams(
            text_document=types.TextDocumentIdentifier(uri=URI),
            position=position(DOC, "speed_up", 2),
        )
    )
    assert "speed_up(rate = 0.2 in [0, 4])  (on action)" in hover.contents.value
    assert "an operator for `positioning`" in hover.contents.value
    assert "Move faster along the same path" in hover.contents.value
    hover = await ask(
        client.text_document_hover_async,
        types.HoverParams(
            text_document=types.TextDocumentIdentifier(uri=URI),
            position=position(DOC, "trans *=", 1),
        )
    )
    assert "action dimension `trans` of `positioning`, in m/s" in hover.contents.value
    hover = await ask(
        client.text_document_hover_async,
        types.HoverParams(
            text_document=types.TextDocumentIdentifier(uri=URI),
            position=position(DOC, "f\n"),
        )
    )
    assert hover.contents.value == "parameter `f = 0.5 in [0, 1]`"


@pytest.mark.asyncio(loop_scope="function")
async def test_completion(client: LanguageClient):
    await open_doc(client)
    result = await ask(
        client.text_document_completion_async,
        types.CompletionParams(
            text_document=types.TextDocumentIdentifier(uri=URI),
            position=position(DOC, "trans *="),
        )
    )
    items = result if isinstance(result, list) else result.items
    labels = {(i.label, i.kind) for i in items}
    assert ("f", types.CompletionItemKind.Variable) in labels
    assert ("dist2", types.CompletionItemKind.Field) in labels
    assert ("no_turning", types.CompletionItemKind.Function) in labels
    assert ("where", types.CompletionItemKind.Keyword) in labels


@pytest.mark.asyncio(loop_scope="function")
async def test_definition_in_the_document_and_the_standard_library(client: LanguageClient):
    await open_doc(client)
    here = await ask(
        client.text_document_definition_async,
        types.DefinitionParams(
            text_document=types.TextDocumentIdentifier(uri=URI),
            position=position(DOC, "creep then", 1),
        )
    )
    assert here.uri == URI
    assert here.range.start == position(DOC, "creep")
    std = await ask(
        client.text_document_definition_async,
        types.DefinitionParams(
            text_document=types.TextDocumentIdentifier(uri=URI),
            position=position(DOC, "speed_up", 1),
        )
    )
    path = pathlib.Path(std.uri.removeprefix("file://"))
    assert path.name == "positioning.adv" and str(path).startswith(CACHE)
    line = path.read_text().splitlines()[std.range.start.line]
    assert line[std.range.start.character:].startswith("speed_up")
    dim = await ask(
        client.text_document_definition_async,
        types.DefinitionParams(
            text_document=types.TextDocumentIdentifier(uri=URI),
            position=position(DOC, "trans *=", 1),
        ),
    )
    assert dim.uri == std.uri
    line = path.read_text().splitlines()[dim.range.start.line]
    assert line[dim.range.start.character:].startswith("trans")


@pytest.mark.asyncio(loop_scope="function")
async def test_formatting(client: LanguageClient):
    messy = "operator halt  for positioning on action {trans=0 // stop\n}\n"
    uri = "file:///lab/messy.adv"
    await open_doc(client, messy, uri)
    edits = await ask(
        client.text_document_formatting_async,
        types.DocumentFormattingParams(
            text_document=types.TextDocumentIdentifier(uri=uri),
            options=types.FormattingOptions(tab_size=2, insert_spaces=True),
        )
    )
    (edit,) = edits
    assert edit.new_text == "operator halt for positioning on action {\n  trans = 0 // stop\n}\n"
    # A formatted file: no edit.
    tidy = "file:///lab/tidy.adv"
    await open_doc(client, edit.new_text, tidy)
    edits = await ask(
        client.text_document_formatting_async,
        types.DocumentFormattingParams(
            text_document=types.TextDocumentIdentifier(uri=tidy),
            options=types.FormattingOptions(tab_size=2, insert_spaces=True),
        )
    )
    assert not edits
    # A file that does not parse: an error response, not a mangled file.
    broken = "file:///lab/broken.adv"
    await open_doc(client, "operator halt for positioning on action { trans = }\n", broken)
    with pytest.raises(Exception, match="does not parse"):
        await asyncio.wait_for(
            client.text_document_formatting_async(
                types.DocumentFormattingParams(
                    text_document=types.TextDocumentIdentifier(uri=broken),
                    options=types.FormattingOptions(tab_size=2, insert_spaces=True),
                )
            ),
            10,
        )


@pytest.mark.asyncio(loop_scope="function")
async def test_document_symbols(client: LanguageClient):
    await open_doc(client)
    symbols = await ask(
        client.text_document_document_symbol_async,
        types.DocumentSymbolParams(text_document=types.TextDocumentIdentifier(uri=URI))
    )
    assert [s.name for s in symbols] == ["creep", "twice"]
    assert symbols[0].kind == types.SymbolKind.Function
    assert [c.name for c in symbols[0].children] == ["f"]
    assert symbols[0].selection_range.start == position(DOC, "creep")


@pytest.mark.asyncio(loop_scope="function")
async def test_a_session_script(client: LanguageClient):
    script = "task positioning\nload demos teacher:3\nrunn goal 1 2 3\n"
    uri = "file:///lab/session.adv"
    await open_doc(client, script, uri)
    (d,) = client.diagnostics[uri]
    assert d.range.start.line == 2
    result = await ask(
        client.text_document_completion_async,
        types.CompletionParams(
            text_document=types.TextDocumentIdentifier(uri=uri),
            position=types.Position(line=2, character=0),
        )
    )
    items = result if isinstance(result, list) else result.items
    assert "advise" in {i.label for i in items}
    # After `advise`: the task's operators.
    typing = "task positioning\nrun goal 2 -1 0\nadvise sp\n"
    uri = "file:///lab/typing.adv"
    await open_doc(client, typing, uri)
    result = await ask(
        client.text_document_completion_async,
        types.CompletionParams(
            text_document=types.TextDocumentIdentifier(uri=uri),
            position=types.Position(line=2, character=9),
        ),
    )
    items = result if isinstance(result, list) else result.items
    labels = {i.label for i in items}
    assert "speed_up" in labels and "advise" not in labels
