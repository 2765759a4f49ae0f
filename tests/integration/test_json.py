"""--json on every listing and on doctor, size, info and check: valid JSON with sorted keys on stdout."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from uros_helpers import run_uros

pytestmark = pytest.mark.integration


def _json(*args: str, code: int = 0) -> object:
    proc = run_uros(*args, "--json", check=False)
    assert proc.returncode == code, proc.stderr
    data = json.loads(proc.stdout)
    assert proc.stdout == json.dumps(data, indent=2, sort_keys=True) + "\n"  # sorted, stable
    return data


def test_every_listing_and_report_speaks_json(m7_build: Path) -> None:
    lib = m7_build / "build" / "cortex-m7" / "libmicroros.a"
    assert any(t["name"] == "cortex-m7" for t in _json("targets"))  # type: ignore[union-attr, index]
    assert any(d["name"] == "humble" for d in _json("distros"))  # type: ignore[union-attr, index]
    assert any(o["option"] == "RMW_UXRCE_MAX_HISTORY" for o in _json("meta", "options"))  # type: ignore[union-attr, index]
    passed = _json("check", str(lib), "--toolchain", "cortex-m7")
    assert passed["result"] == "pass" and passed["objects"] == 8  # type: ignore[index]
    failed = _json("check", str(lib), "--toolchain", "cortex-m4f", code=5)
    assert failed["result"] == "fail" and "Tag_FP_arch" in failed["error"]  # type: ignore[index]
    assert _json("doctor", "-w", str(m7_build))["ok"] is True  # type: ignore[index]
    assert _json("info", str(lib.parent))["target"] == "cortex-m7"  # type: ignore[index]
    assert _json("size", str(lib))["total"]["text"] > 0  # type: ignore[index]
