"""What tools print, read (pure): the most telling line of a failed tool's output, the line saying
a disk is full and the path it names, and how to install a program that is missing. proc.py runs
the tools and hands their lines here; colcon's steps read colcon's logs with the same rules."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

# Where a missing program comes from, by name pattern. Target compilers carry their own hint
# in the target profile (toolchains/*.yaml); this covers the host tools.
_HOST_TOOL_HINTS: tuple[tuple[str, str], ...] = (
    (r"^cmake$", "install CMake: apt-get install cmake (or pip install cmake)"),
    (r"^git$", "install git: apt-get install git"),
    (r"^ninja$", "install ninja: pip install ninja (or apt-get install ninja-build)"),
    (r"^colcon$", "install colcon: pip install colcon-common-extensions"),
    (r"^arm-none-eabi-", "install the Arm GCC: apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi"),
    (r"^riscv64-unknown-elf-", "install the RISC-V GCC: apt-get install gcc-riscv64-unknown-elf"),
    (r"^xtensa-lx106-elf-", "install the Xtensa GCC: apt-get install gcc-xtensa-lx106"),
)

# The most telling line of a failed build, best first: a compiler diagnostic (file:line: error:),
# a CMake error, any other "error:", then ninja's/make's own failure lines.
_ERROR_PATTERNS = tuple(
    re.compile(p)
    for p in (
        r":\d+:(\d+:)? (fatal )?error: ",
        # rosidl rejecting an interface file: its own message names the file and the line, which
        # is what a user needs rather than the CMake stack around it
        r"^\s*Error processing '|^\s*([\w.]+\.)?(Invalid\w+|\w+Error): ",
        r"CMake Error",
        # colcon's own errors (duplicate package names, a bad option in a meta file)
        r"^\[[\d.]+s\] ERROR:colcon",
        r"\berror: |\bError: |^fatal: ",
        r"^FAILED: |\*\*\* ",
    )
)
_COLCON_LOG_PREFIX = re.compile(r"^\[[\d.]+s\] ERROR:[\w.]+:\s*")
_LONGEST = 300


def first_error(lines: Sequence[str]) -> str | None:
    """The most telling line of ``lines``, one line: a header that ends in ':' ("CMake Error at
    CMakeLists.txt:4 (message):", colcon's "Duplicate package names not supported:") carries the
    indented lines that follow it (the message itself), up to a blank line."""
    for pattern in _ERROR_PATTERNS:
        for i, line in enumerate(lines):
            if pattern.search(line):
                text = _COLCON_LOG_PREFIX.sub("", line.strip())
                if text.endswith(":"):
                    for more in lines[i + 1 : i + 8]:
                        if not more.strip() or not (more[:1].isspace() or more.startswith("- ")):
                            break
                        if more.strip().startswith("Call Stack"):
                            break
                        text += " " + more.strip()
                # ninja's FAILED lines list every output of the step: keep the message one line
                return text if len(text) <= _LONGEST else text[: _LONGEST - 3] + "..."
    return lines[-1].strip() if lines else None


# What tools print when a write fails for want of space (strerror of ENOSPC and EDQUOT; the tools
# run with LC_MESSAGES=C, so in English).
_DISK_FULL = re.compile(r"No space left on device|Disk quota exceeded")


def disk_full_line(lines: Sequence[str]) -> str | None:
    """The first line of ``lines`` saying that a disk is full (pure)."""
    for line in lines:
        if _DISK_FULL.search(line):
            text = _COLCON_LOG_PREFIX.sub("", line.strip())
            return text if len(text) <= _LONGEST else text[: _LONGEST - 3] + "..."
    return None


def disk_full_path(line: str) -> str | None:
    """The absolute path a disk-full message names ("... No space left on device [/a/b.log]",
    "... writing to /tmp/ccX.s: No space left ..."), or None (pure)."""
    # The file being written stands right before the reason ("ar: /o/lib.a: No space left ..."),
    # or after it (Python: "[Errno 28] No space left on device: '/a/b'" or "... [/a/b]"); a tool's
    # own path ("/usr/bin/arm-none-eabi-ar: /o/lib.a: ...") is not the disk that is full.
    before = re.search(r"(/[^\s'\"\[\]:]+):\s*(?:No space left on device|Disk quota exceeded)", line)
    if before:
        return before.group(1)
    after = re.search(r"(?:No space left on device|Disk quota exceeded)\W*(/[^\s'\"\[\]]+)", line)
    if after:
        return after.group(1)
    found = re.findall(r"(/[^\s'\"\[\]:]+)", line)
    return found[-1] if found else None


def install_hint(program: str) -> str:
    name = Path(program).name
    for pattern, hint in _HOST_TOOL_HINTS:
        if re.search(pattern, name):
            return hint
    return f"install {name} or put it on PATH"
