"""References to the design document point at ``docs/design.md`` and at sections that exist there."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DESIGN = REPO / "docs" / "design.md"
SOURCES = ("ikcompiler", "subproblems", "tests", "benchmarks")


def _files():
    for folder in SOURCES:
        yield from (p for p in (REPO / folder).rglob("*.py") if "__pycache__" not in p.parts)
    yield from (REPO / "robots").glob("*.toml")


def test_every_design_reference_names_an_existing_section():
    sections = {int(n) for n in re.findall(r"^## (\d+)\. ", DESIGN.read_text(), flags=re.MULTILINE)}
    assert set(range(1, 17)) <= sections
    stale, missing, cited = [], [], 0
    for path in _files():
        if path.resolve() == Path(__file__).resolve():
            continue
        for lineno, line in enumerate(path.read_text().splitlines(), start=1):
            where = f"{path.relative_to(REPO)}:{lineno}"
            # the old name of the document, outside the repository: only docs/design.md is ours
            if "DESIGN.md" in line.replace("docs/design.md", ""):
                stale.append(where)
            for n in re.findall(r"docs/design\.md,? section (\d+)", line):
                cited += 1
                if int(n) not in sections:
                    missing.append(f"{where}: section {n}")
    assert stale == [], "references to DESIGN.md (write docs/design.md section N): " + ", ".join(stale)
    assert missing == [], "sections cited but not in docs/design.md: " + ", ".join(missing)
    assert cited >= 20
