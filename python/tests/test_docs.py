"""The Python examples of docs/python.md run, in order, and print what the page shows.

Every ```python block of the page runs in one namespace, in a scratch directory with the
bundled `data-synthetic` linked in; a block after the marker `<!-- test: stdout -->` must be
exactly what the Python block before it printed (tests/docs_examples.rs does the same for the
command lines of every page).
"""

import contextlib
import io
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "python.md"
STDOUT_MARKER = "<!-- test: stdout -->"


def blocks(text):
    """(first line, info string, marker line before the fence, code) of each fenced block."""
    out = []
    lines = text.splitlines()
    previous = ""
    i = 0
    while i < len(lines):
        stripped = lines[i].strip()
        if stripped.startswith("```"):
            info = stripped[3:].strip()
            start = i + 1
            i += 1
            while i < len(lines) and lines[i].strip() != "```":
                i += 1
            assert i < len(lines), f"{PAGE}:{start}: the block is never closed"
            out.append((start + 1, info, previous, "".join(f"{l}\n" for l in lines[start:i])))
            previous = lines[i]
        elif stripped:
            previous = stripped
        i += 1
    return out


def test_python_examples_run_and_print_what_the_page_shows(tmp_path, monkeypatch):
    (tmp_path / "data-synthetic").symlink_to(ROOT / "data-synthetic")
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs__"}
    printed = None
    ran = compared = 0
    for line, info, marker, code in blocks(PAGE.read_text(encoding="utf-8")):
        if marker == STDOUT_MARKER:
            if printed is None:
                continue  # the output of a shell block, not Python's
            assert printed == code, (
                f"docs/python.md:{line}: the page shows\n{code}\nthe example printed\n{printed}"
            )
            compared += 1
        elif info == "python":
            # Leading newlines keep the page's line numbers in a traceback.
            source = "\n" * (line - 1) + code
            buffer = io.StringIO()
            with contextlib.redirect_stdout(buffer):
                exec(compile(source, "docs/python.md", "exec"), namespace)
            printed = buffer.getvalue()
            ran += 1
        else:
            printed = None
    assert ran >= 2 and compared >= 2, f"{ran} Python blocks run, {compared} outputs compared"
