"""docs/reliability.md promises that every row is a test: each test it names exists."""

from __future__ import annotations

import re
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
DOC = TESTS.parent / "docs" / "reliability.md"
# `integration/test_x.py::test_name[param]` or `unit/test_y.py` (a whole file)
REF = re.compile(r"`((?:unit|integration)/test_\w+\.py)(?:::(\w+))?")


def test_every_test_the_reliability_table_names_exists() -> None:
    rows = [line for line in DOC.read_text(encoding="utf-8").splitlines() if line.startswith("| ")]
    refs = [m.groups() for row in rows[1:] for m in REF.finditer(row)]
    assert len(rows) - 1 >= 40 and refs  # the header, then the rows
    missing = []
    for file, name in refs:
        path = TESTS / file
        if not path.is_file():
            missing.append(file)
        elif name and not re.search(rf"^def {name}\(", path.read_text(encoding="utf-8"), re.M):
            missing.append(f"{file}::{name}")
    assert not missing, missing
