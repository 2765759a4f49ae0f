"""The smallest valid target profile, as the data a toolchains/*.yaml holds (shared by the profile
loader's tests and the schema's)."""

from __future__ import annotations

from typing import Any


def minimal_profile() -> dict[str, Any]:
    return {
        "name": "board",
        "description": "a board",
        "compiler_prefix": "arm-none-eabi-",
        "system_processor": "arm",
        "cpu_flags": ["-mcpu=cortex-m4"],
        "elf": {"machine": "ARM"},
    }
