"""`uros check`: the build's ABI check on any library or object."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from uros_build import console
from uros_build.errors import ConfigError, VerifyError
from uros_build.proc import Runner, new_run_log, user_log_dir
from uros_build.target import abi
from uros_build.target.profiles import find_profile, load_profile_file


def check_library(
    library: Path, target: str | None, profile_path: Path | None, verbose: bool, as_json: bool = False
) -> None:
    if (target is None) == (profile_path is None):
        raise ConfigError("uros check needs one target", "pass --toolchain NAME or --profile FILE")
    if not library.is_file():
        raise ConfigError(f"{library}: no such file", "pass the path of a static library (.a) or an object")
    profile = (
        load_profile_file(profile_path)
        if profile_path is not None
        else find_profile(str(target), alternative="or pass your own profile with --profile FILE")
    )
    runner = Runner(new_run_log(user_log_dir(), "check"), verbose=verbose)
    try:
        summary = abi.check_library(runner, library.resolve(), profile)
    except VerifyError as exc:
        if not _is_archive(library):  # a linked firmware (app.elf) or one object, not the library
            exc.hint = (
                f"it holds code built for another core than {profile.name}: build micro-ROS and the "
                f"firmware with {profile.name}'s flags (uros build --toolchain {profile.name}), or check "
                "it against the core it runs on (uros check --toolchain NAME)"
            )
        if as_json:  # the verdict on stdout for scripts; the message and exit 5 as always
            failed = {"library": str(library), "target": profile.name, "result": "fail", "error": exc.message}
            sys.stdout.write(json.dumps(failed, indent=2, sort_keys=True) + "\n")
        raise
    if as_json:  # the warnings are in the summary too
        sys.stdout.write(json.dumps({"library": str(library), **summary}, indent=2, sort_keys=True) + "\n")
    else:
        console.step(f"{library}: {abi.describe(summary)}")
    for warning in summary.get("warnings", ()):
        console.warn(warning)


def _is_archive(path: Path) -> bool:
    with path.open("rb") as f:
        return f.read(8) == b"!<arch>\n"
