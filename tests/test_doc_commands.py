"""Every `pressurepose` command shown in a code block of the README or docs/ parses with the CLI as
it is: its verb exists and every option it gives is one the verb takes, with a value it accepts."""

import contextlib
import io
import re
import shlex
import sys
from pathlib import Path

import pytest

from pressurepose.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def doc_commands() -> list[tuple[str, list[str]]]:
    """(where, argv) of each `pressurepose VERB ...` (or README's `$pp VERB ...`) line in a fenced code block (continued lines
    joined; a trailing `# comment` dropped; usage synopses, with `...`, `[--option]` or `a|b`, left out)."""
    out = []
    for doc in DOCS:
        inside = False
        for line in re.sub(r"\\\n\s*", " ", doc.read_text()).splitlines():
            if line.lstrip().startswith("```"):
                inside = not inside
                continue
            m = re.match(r"\s*(?:\$\s*)?(?:pressurepose|\$pp|python -m pressurepose\.cli)\s+(.*)", line) if inside else None
            if m and not any(mark in m.group(1) for mark in ("...", "[-", "|")):
                argv = shlex.split(m.group(1).split(" #")[0])
                out.append((f"{doc.relative_to(ROOT)} #{sum(w.startswith(str(doc.relative_to(ROOT))) for w, _ in out) + 1}",
                            argv))
    return out


COMMANDS = doc_commands()


def test_the_docs_show_commands():
    assert len(COMMANDS) >= 10, [w for w, _ in COMMANDS]


@pytest.mark.parametrize("where,argv", COMMANDS, ids=[w for w, _ in COMMANDS])
def test_a_documented_command_parses(where, argv, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["pressurepose", *argv])  # the parser builds the named verb's options
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            args = build_parser().parse_args(argv)
        except SystemExit as exc:
            pytest.fail(f"{where}: `pressurepose {' '.join(argv)}` does not parse: {err.getvalue().strip()[-300:]}"
                        f" (exit {exc.code})")
    assert args.verb == argv[0]


def test_the_readme_trains_at_full_speed_on_any_cpu():
    """`--cpu-amp` trains 10x slower on a CPU without bf16 instructions: a README command a reader copies
    does not carry it (the text says where it helps)."""
    readme = [argv for where, argv in COMMANDS if where.startswith("README.md")]
    trains = [argv for argv in readme if argv[0] == "train"]
    assert trains and not any("--cpu-amp" in argv for argv in trains)
