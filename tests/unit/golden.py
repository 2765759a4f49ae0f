from __future__ import annotations

import os
from pathlib import Path

GOLDEN = Path(__file__).parent / "golden"


def check_golden(name: str, text: str) -> None:
    """Compare with tests/unit/golden/<name>; UROS_UPDATE_GOLDEN=1 (re)writes the file. A missing
    golden file fails: a test that creates its own expectation would pass on anything."""
    path = GOLDEN / name
    if os.environ.get("UROS_UPDATE_GOLDEN") == "1":
        path.write_text(text, encoding="utf-8")
    assert path.exists(), f"no golden file {path}: run with UROS_UPDATE_GOLDEN=1 once and review it"
    assert text == path.read_text(encoding="utf-8"), f"{name} differs from its golden file"
