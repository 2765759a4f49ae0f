from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from uros_build.errors import ConfigError
from uros_build.profiles import find_profile, load_profile_file, shipped_profiles


def _write(tmp_path: Path, data: object) -> Path:
    path = tmp_path / "board.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def _base() -> dict[str, object]:
    return {
        "name": "board",
        "description": "a board",
        "compiler_prefix": "arm-none-eabi-",
        "system_processor": "arm",
        "cpu_flags": ["-mcpu=cortex-m4"],
        "elf": {"machine": "ARM"},
    }


def test_shipped_profiles_load() -> None:
    profiles = shipped_profiles()
    assert "cortex-m7" in profiles
    m7 = find_profile("cortex-m7")
    assert m7.cpu_flags == ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard")
    assert m7.tool("gcc") == "arm-none-eabi-gcc"
    assert dict(m7.elf.attributes)["Tag_ABI_VFP_args"] == "VFP registers"


def test_minimal_profile(tmp_path: Path) -> None:
    p = load_profile_file(_write(tmp_path, _base()))
    assert p.name == "board" and p.transport == "custom" and p.optimization == "-Os"


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"cpu_flag": ["x"]}, r"board.yaml: cpu_flag: unknown key"),
        ({"cpu_flags": "-mcpu=cortex-m4"}, r"board.yaml: cpu_flags: must be a list of strings"),
        ({"transport": "can"}, r"board.yaml: transport: 'can' is not one of"),
        ({"elf": {"machine": "ARM", "flags": []}}, r"board.yaml: elf.flags: unknown key"),
        ({"optimization": "fast"}, r"board.yaml: optimization: 'fast' is not a -O flag"),
        ({"native_64bit_atomics": "yes"}, r"native_64bit_atomics: must be true or false"),
    ],
)
def test_bad_profiles_name_file_and_key(tmp_path: Path, change: dict[str, object], expected: str) -> None:
    with pytest.raises(ConfigError, match=expected):
        load_profile_file(_write(tmp_path, {**_base(), **change}))


def test_missing_field(tmp_path: Path) -> None:
    data = _base()
    del data["compiler_prefix"]
    with pytest.raises(ConfigError, match="compiler_prefix: is required but missing"):
        load_profile_file(_write(tmp_path, data))


def test_unknown_target_lists_known() -> None:
    with pytest.raises(ConfigError) as info:
        find_profile("cortex-m99")
    assert info.value.hint is not None and "cortex-m7" in info.value.hint
