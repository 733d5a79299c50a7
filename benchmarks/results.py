"""Writing benchmark figures into docs/RESULTS.md, one delimited section per benchmark."""

from __future__ import annotations

import re
from pathlib import Path

from pressurepose.files import write_text_atomic

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "RESULTS.md"


def write_section(topic: str, text: str, results: Path = RESULTS) -> None:
    """Replace (or append) the ``<!-- bench:topic -->`` ... ``<!-- /bench:topic -->`` section."""
    begin, end = f"<!-- bench:{topic} -->", f"<!-- /bench:{topic} -->"
    block = f"{begin}\n{text.rstrip()}\n{end}\n"
    old = results.read_text() if results.is_file() else "# Measured results\n\n"
    pattern = re.compile(re.escape(begin) + ".*?" + re.escape(end) + "\n?", re.S)
    new = pattern.sub(lambda _: block, old) if pattern.search(old) else old.rstrip() + "\n\n" + block
    results.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(results, new)
