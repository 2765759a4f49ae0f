"""Questions about the colcon.meta a build layers: which files, in which order, and what they say
of one option or of the transport. Nothing here starts a process."""

from __future__ import annotations

from pathlib import Path

from uros_build import defaults
from uros_build.config.targets import Target, target_profile
from uros_build.sources import meta as meta_mod

# ---------------------------------------------------------------------------------------------
# colcon.meta


def meta_for(
    preset: str,
    target: Target | None,
    transport: str | None,
    user_metas: list[Path],
    sets: list[str],
    distro_preset: str | None = None,
) -> meta_mod.Meta:
    return meta_mod.build_meta(
        meta_mod.load_preset(preset, distro_preset),
        meta_mod.target_fragments(target_profile(target), transport),
        [meta_mod.load_meta_file(p) for p in user_metas],
        sets,
    )


def only_the_preset(path: Path, distro_preset: str | None) -> bool:
    """The workspace's colcon.meta is the distro's preset as create-firmware wrote it, unedited.
    It then adds nothing over that preset, and merged over another one (`--preset tiny`) it put
    the distro's values back (RMW_UXRCE_MAX_HISTORY=4 over tiny's 1): such a file is left out,
    an edited one is the user's and is merged over any preset."""
    preset = meta_mod.load_preset(defaults.PRESET, distro_preset)
    return meta_mod.load_meta_file(path).names == preset.names


def meta_option(meta: meta_mod.Meta, package: str, option: str) -> str | None:
    """The value the merged meta gives ``package``'s CMake option ``option`` (-D), or None."""
    args = meta.names.get(package, {}).get("cmake-args", ())
    found = None
    for arg in args if isinstance(args, tuple) else ():
        name, sep, value = arg.removeprefix("-D").partition("=")
        if arg.startswith("-D") and sep and name.partition(":")[0] == option:
            found = value  # the last one wins, as on CMake's command line
    return found


def meta_transport(meta: meta_mod.Meta) -> str | None:
    """The XRCE-DDS transport the merged meta selects (recorded in build-info.json)."""
    args = meta.names.get("rmw_microxrcedds", {}).get("cmake-args", ())
    for arg in args if isinstance(args, tuple) else ():
        if arg.startswith("-DRMW_UXRCE_TRANSPORT="):
            return arg.split("=", 1)[1]
    return None
