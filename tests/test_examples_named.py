"""Every shipped example a page or an example's own comment names exists: a newcomer copies the
command (the drive catalogue's comment once named a program file that was never shipped)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NAMED = re.compile(r"examples/([\w.-]+\.(?:toml|csv|py|urdf))\b")
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")),
         *sorted(p for p in (ROOT / "examples").iterdir() if p.suffix in {".toml", ".py"})]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_example_named_is_shipped(page: Path) -> None:
    missing = []
    for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
        if re.search(r": line \d", line):  # an error message quoted in the docs, not a command
            continue
        missing += [f"{page.name}:{number}: examples/{name}" for name in NAMED.findall(line)
                    if not (ROOT / "examples" / name).exists()]
    assert not missing, missing
