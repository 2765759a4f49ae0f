"""Shell completion through the real CLI, as bash, zsh and fish call it (click's protocol:
_UROS_COMPLETE=<shell>_complete with COMP_WORDS/COMP_CWORD)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from fixture_ws import make_fixture_workspace
from uros_helpers import run_uros

pytestmark = pytest.mark.integration


def _complete(words: str, shell: str = "bash", cwd: Path | None = None) -> list[str]:
    env = {**os.environ, "_UROS_COMPLETE": f"{shell}_complete", "COMP_WORDS": words}
    # bash and zsh pass the index of the word being completed, fish the word itself
    index = len(words.split()) - (0 if words.endswith(" ") else 1)
    env["COMP_CWORD"] = words.split()[index] if shell == "fish" else str(index)
    proc = run_uros(env=env, cwd=cwd)
    if shell == "bash":  # "type,value" lines
        return [line.split(",", 1)[1] for line in proc.stdout.splitlines()]
    # zsh: type, value and help on lines of their own; fish: "type,value[\thelp]" (click >= 8.2)
    values = [line.split("\t", 1)[0] for line in proc.stdout.splitlines() if line not in ("plain", "_")]
    return [v.split(",", 1)[1] if v.startswith(("plain,", "file,", "dir,")) else v for v in values]


def test_targets_distros_packages_and_options_complete(tmp_path: Path) -> None:
    assert _complete("uros build --toolchain cortex-m4") == ["cortex-m4", "cortex-m4f"]
    assert _complete("uros targets show esp32s") == ["esp32s2", "esp32s3-bare", "esp32s3"]
    # the shipped rv32 profiles
    assert _complete("uros toolchain render rv") == ["rv32imac", "rv32imafc", "rv32imc"]
    assert _complete("uros create-firmware --distro h") == ["humble"]
    ws = make_fixture_workspace(tmp_path / "ws")
    assert _complete(f"uros build -w {ws} --packages-up-to fx_c") == ["fx_core"]
    assert "rmw_microxrcedds.RMW_UXRCE_MAX_NODES=" in _complete(
        "uros build --set rmw_microxrcedds.RMW_UXRCE_MAX_N"
    )
    assert "fx_time." in _complete(f"uros build -w {ws} --set fx_t")
    assert _complete("uros doctor --toolchain rp", shell="zsh") == ["rp2040"]
    assert _complete("uros build --toolchain rp", shell="fish") == ["rp2040"]


def test_the_completion_scripts_are_there() -> None:
    for shell in ("bash", "zsh", "fish"):
        env = {**os.environ, "_UROS_COMPLETE": f"{shell}_source"}
        assert "_UROS_COMPLETE" in run_uros(env=env).stdout, shell
