"""`uros check`: the build's ABI check on any library or object, the global symbols two members
define (``--whole-archive``: a failure) and the symbols the firmware must provide."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from uros_build import console
from uros_build.errors import ConfigError, VerifyError
from uros_build.output import budget, fit, msgsize, symbols
from uros_build.output.buildinfo import BuildInfo, read_build_info
from uros_build.proc import Runner, new_run_log, user_log_dir
from uros_build.sources import firmware_scan
from uros_build.sources.options import known_options
from uros_build.target import abi
from uros_build.target.profiles import find_profile, load_profile_file


@dataclass(frozen=True)
class CheckRequest:
    """`uros check`'s command line, as given (cli/build.py hands every option by its own name)."""

    library: Path
    toolchain: str | None = None  # the target, by name
    profile: Path | None = None  # or the user's own profile file
    verbose: bool = False
    as_json: bool = False
    whole_archive: bool = False  # a global symbol two members define fails the check
    for_firmware: Path | None = None  # the firmware's sources: message sizes and entities


def check_library(request: CheckRequest) -> None:
    library, target, profile_path = request.library, request.toolchain, request.profile
    as_json, whole_archive, for_firmware = request.as_json, request.whole_archive, request.for_firmware
    if (target is None) == (profile_path is None):
        raise ConfigError("uros check needs one target", "pass --toolchain NAME or --profile FILE")
    if not library.is_file():
        raise ConfigError(f"{library}: no such file", "pass the path of a static library (.a) or an object")
    profile = (
        load_profile_file(profile_path)
        if profile_path is not None
        else find_profile(str(target), alternative="or pass your own profile with --profile FILE")
    )
    firmware = _firmware(library, for_firmware) if for_firmware is not None else None
    streams = (
        msgsize.verdicts(library.resolve().parent, firmware[0], firmware[1].packages)
        if firmware is not None
        else []
    )
    runner = Runner(new_run_log(user_log_dir(), "check"), verbose=request.verbose)
    try:
        summary = abi.check_library(runner, library.resolve(), profile)
        # a library's members; a linked firmware (app.elf) or one object has none to collide
        text = symbols.read_nm(runner, "nm", library.resolve()) if _is_archive(library) else ""
        found = symbols.parse_nm(text, library.name)
        duplicates = symbols.duplicate_globals(found)
        if whole_archive and duplicates:
            if not as_json:  # the full list; the error line sums it up
                for line in symbols.duplicate_lines(duplicates):
                    console.info(line)
            hint = f"{symbols.DUPLICATE_HINT}, or link the library without --whole-archive"
            raise VerifyError(symbols.describe_duplicates(duplicates, str(library)), hint)
    except VerifyError as exc:
        if not _is_archive(library):  # a linked firmware (app.elf) or one object, not the library
            exc.hint = (
                f"it holds code built for another core than {profile.name}: build micro-ROS and the "
                f"firmware with {profile.name}'s flags (uros build --toolchain {profile.name}), or check "
                "it against the core it runs on (uros check --toolchain NAME)"
            )
        if as_json:  # the verdict on stdout for scripts; the message and exit 5 as always
            failed = {"library": str(library), "target": profile.name, "result": "fail", "error": exc.message}
            console.print_json(failed)
        raise
    undefined = symbols.undefined_globals(found)
    known = symbols.firmware_symbols()
    fitted = (
        fit.library_fit(
            library.resolve().parent, firmware[0], firmware[1], known_options(), budget.symbol_sizes(text)
        )
        if firmware is not None
        else None
    )
    if as_json:  # the warnings are in the summary too
        report = {
            "library": str(library),
            **summary,
            "duplicate_globals": {d.name: list(d.members) for d in duplicates},
            "undefined": symbols.needed_json(undefined, known),
        }
        if for_firmware is not None:
            report["messages"] = {name: {"warning": warn, "says": line} for name, warn, line in streams}
        if fitted is not None:
            report["entities"] = fit.report(fitted)
        console.print_json(report)
    else:
        console.step(f"{library}: {abi.describe(summary)}")
    for warning in summary.get("warnings", ()):
        console.warn(warning)
    if as_json:
        _verdict(fitted, library, for_firmware)
        return
    if _is_archive(library):
        _say_duplicates(duplicates, library)
    if undefined:
        console.step(f"{len(undefined)} symbols {library.name} leaves undefined, for the firmware's link:")
        for line in symbols.needed_lines(undefined, known):
            console.info(line)
    if for_firmware is not None:
        console.step(f"the message types {for_firmware} uses, against the library's XRCE-DDS streams:")
        for _, warn, line in streams:
            (console.warn if warn else console.info)(line)
    if fitted is not None and for_firmware is not None:
        fit.say(fitted, for_firmware, priced=True)
    _verdict(fitted, library, for_firmware)


def _firmware(library: Path, firmware: Path) -> tuple[BuildInfo, firmware_scan.FirmwareUse]:
    """The output's build-info and what the firmware's sources use (interface types, rclc calls)."""
    if not firmware.is_dir():
        raise ConfigError(f"--for-firmware {firmware}: no such folder", "pass your firmware's source folder")
    info = read_build_info(library.resolve().parent, "LIBRARY's folder")
    used = firmware_scan.scan_folder(firmware.resolve())
    return info, used


def _verdict(fitted: fit.Fit | None, library: Path, firmware: Path | None) -> None:
    """Exit 5 when the firmware's calls take more of a pool than the library holds."""
    if fitted is None or fitted.fits:
        return
    over = [limit for limit in fitted.limits if not limit.fits]
    raise VerifyError(
        f"--for-firmware {firmware}: creates more than {library.name} has room for: "
        + ", ".join(f"{limit.needed} {limit.kind} ({limit.option}={limit.value})" for limit in over),
        "build with "
        + " ".join(f"--set {fit.RMW}.{limit.option}={limit.needed}" for limit in over)
        + f" ({fit.APPROXIMATE})",
    )


def _say_duplicates(duplicates: tuple[symbols.Duplicate, ...], library: Path) -> None:
    if not duplicates:
        console.info(f"{library.name}: no global symbol is defined in more than one member")
        return
    console.warn(symbols.describe_duplicates(duplicates, library.name))
    for line in symbols.duplicate_lines(duplicates):
        console.info(line)


def _is_archive(path: Path) -> bool:
    with path.open("rb") as f:
        return f.read(8) == b"!<arch>\n"
