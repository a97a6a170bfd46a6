"""Saving and external edits, in the browser: Save writes the file atomically (through
grammarkit.run.write_files); an external edit is picked up when the page has no unsaved edits
and asks first when it has; a save over a file changed on disk asks before overwriting."""
from __future__ import annotations

import os

import pytest

from _studio import copy_grammars, open_page


@pytest.fixture()
def own_studio(tmp_path):
    pytest.importorskip("starlette", reason="the studio extra is not installed")
    from grammarkit_studio import running

    path = copy_grammars(tmp_path / "g")
    with running(path, poll=0.1) as s:
        yield s, path


def editor_text(page) -> str:
    return page.evaluate("window.studio.text")


def wait_saved(page) -> None:
    """The server's "saved" reply reached the page: what was sent is now the file on disk (the
    status line's "saved ..." may already show the next model's timings, under load)."""
    page.wait_for_function("document.getElementById('dirty').hidden && window.studio.savedText"
                           " === window.studio.text && window.studio.diskText === window.studio.text",
                           timeout=20_000)


def type_at_end(page, text: str) -> None:
    page.locator(".CodeMirror-code").click()
    page.keyboard.press("Control+End")
    page.keyboard.type(text)
    page.wait_for_function("(t) => window.studio.text.endsWith(t)", arg=text)


def test_save_and_external_edits(own_studio, browser):
    studio, path = own_studio
    page = open_page(browser, studio.url)
    original = path.read_text()
    mode = 0o640
    os.chmod(path, mode)

    # Save (Ctrl-S, in the editor) writes exactly the editor's text, atomically, keeping the
    # file's permissions
    type_at_end(page, "# edited in the studio\n")
    assert page.locator("#dirty").is_visible()
    page.keyboard.press("Control+s")
    wait_saved(page)
    assert path.read_text() == original + "# edited in the studio\n"
    assert (path.stat().st_mode & 0o777) == mode
    assert not page.locator("#dirty").is_visible()
    assert sorted(p.name for p in path.parent.iterdir()) == ["library.grammar", "paris.grammar", "parts"]

    # an external edit with no unsaved edits in the page: picked up
    path.write_text(path.read_text() + "# external 1\n")
    page.wait_for_function("window.studio.text.endsWith('# external 1\\n')", timeout=10_000)
    assert not page.locator("#dirty").is_visible()

    # an external edit while the page has unsaved edits: the user is asked; keep theirs
    type_at_end(page, "# mine\n")
    path.write_text(path.read_text() + "# external 2\n")
    dialog = page.locator("#ask")
    dialog.wait_for(state="visible", timeout=10_000)
    assert "changed on disk" in page.locator("#ask-text").inner_text()
    page.click("#ask-no")  # keep mine
    assert editor_text(page).endswith("# mine\n")

    # saving now would overwrite the external edit: asked again, and nothing is written before
    page.click("#save")
    dialog.wait_for(state="visible", timeout=10_000)
    assert "Overwrite" in page.locator("#ask-yes").inner_text()
    assert path.read_text().endswith("# external 2\n")
    page.click("#ask-yes")
    wait_saved(page)
    assert path.read_text() == editor_text(page)
    assert not page.errors
    page.context.close()


def test_a_save_in_one_page_reaches_the_other(own_studio, browser):
    studio, path = own_studio
    first, second = open_page(browser, studio.url), open_page(browser, studio.url)
    type_at_end(first, "# from the first page\n")
    first.click("#save")
    wait_saved(first)
    second.wait_for_function("window.studio.text.endsWith('# from the first page\\n')", timeout=10_000)
    assert not second.locator("#dirty").is_visible()
    assert path.read_text() == editor_text(second)
    first.context.close()
    second.context.close()


def test_unreadable_file_is_a_clear_error(tmp_path):
    pytest.importorskip("starlette", reason="the studio extra is not installed")
    from grammarkit.errors import GrammarkitError
    from grammarkit_studio import Studio

    bad = tmp_path / "latin1.grammar"
    bad.write_bytes("grammar caf\xe9\n".encode("latin-1"))
    with pytest.raises(GrammarkitError, match="not UTF-8 text"):
        Studio(bad, port=1)
