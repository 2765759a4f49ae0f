"""docs/settings.md prints the code's table of settings (config/settings.py SETTINGS): a setting
added, renamed or given another default in the code must reach the page, and the other way round."""

from __future__ import annotations

import re
from pathlib import Path

from uros_build.config.settings import SETTINGS, markdown_table

DOC = Path(__file__).resolve().parents[2] / "docs" / "settings.md"
README = DOC.parents[1] / "README.md"


def test_the_settings_page_prints_the_code_s_table() -> None:
    text = DOC.read_text(encoding="utf-8")
    found = re.search(
        r"<!-- the table: generated from SETTINGS -->\n(.*?)<!-- end of the table -->", text, re.S
    )
    assert found is not None, "docs/settings.md lost its table markers"
    assert found.group(1) == markdown_table(), (
        "docs/settings.md differs from config/settings.py: regenerate the table with "
        "python -c \"from uros_build.config.settings import markdown_table; print(markdown_table(), end='')\""
    )


def test_every_environment_variable_uros_reads_is_in_the_table() -> None:
    """Every UROS_* a module reads as a setting is a row (credentials and uros's own marker are not
    settings: the page says so)."""
    code = Path(__file__).resolve().parents[2] / "uros_build"
    read = set()
    for path in code.rglob("*.py"):
        if path.name != "settings.py":
            read |= set(re.findall(r"\"(UROS_[A-Z_]+)\"", path.read_text(encoding="utf-8")))
    in_table = {s.env for s in SETTINGS if s.env}
    assert read - in_table == {"UROS_CACHE_TOKEN", "UROS_OWNER"}
    doc = DOC.read_text(encoding="utf-8")
    assert all(name in doc for name in read)


def test_the_readme_links_the_settings_page() -> None:
    assert "docs/settings.md" in README.read_text(encoding="utf-8")
