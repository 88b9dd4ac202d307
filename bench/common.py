"""Shared by the benchmarks: update one section of docs/BENCHMARKS.md in place."""

from __future__ import annotations

import datetime
from pathlib import Path
import re


def write_section(path: Path, title: str, body: str, command: str, after: str | None = None) -> None:
    """Replaces (or appends) the `## title` section, keeping every other section; a new
    section goes after the `## after` section when there is one, else at the end."""
    path.parent.mkdir(parents=True, exist_ok=True)
    text = (
        path.read_text()
        if path.exists()
        else "# Benchmarks\n\nEvery figure below was measured on this project's machine (2 cores, 24 GiB, noisy), in one run per table, with a release build. Compare rows within a table.\n"
    )
    stamp = datetime.date.today().isoformat()
    section = f"## {title}\n\nCommand: `{command}` ({stamp})\n\n{body}\n"
    pattern = re.compile(rf"^## {re.escape(title)}\n.*?(?=^## |\Z)", re.S | re.M)
    previous = re.compile(rf"^## {re.escape(after)}\n.*?(?=^## |\Z)", re.S | re.M).search(text) if after else None
    if pattern.search(text):
        text = pattern.sub(lambda _: section + "\n", text)
    elif previous:
        text = text[: previous.end()].rstrip("\n") + "\n\n" + section + "\n" + text[previous.end() :]
    else:
        text = text.rstrip("\n") + "\n\n" + section
    path.write_text(text)
