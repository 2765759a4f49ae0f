"""The frozen plan of one target's build (:class:`BuildPlan`), what every step of `uros build` is
handed: the data only; plan.py makes and checks it."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from uros_build.config.platform import Platform
from uros_build.config.resolver import Resolved
from uros_build.config.targets import Target
from uros_build.output.team_cache import CacheSettings
from uros_build.sources import meta as meta_mod
from uros_build.sources.distros import Distro
from uros_build.sources.packages import PackageInfo
from uros_build.sources.workspace import Workspace
from uros_build.sources.wsfiles import WorkspaceConfig

if TYPE_CHECKING:  # a type only: the scan is imported by --for-firmware (start-up cost)
    from uros_build.sources import firmware_scan

# ---------------------------------------------------------------------------------------------
# uros build


@dataclass(frozen=True)
class Selection:
    """The packages `uros build` asks colcon for (--packages-up-to), and why each."""

    wanted: tuple[str, ...]  # --packages / uros.yaml packages:
    firmware: firmware_scan.FirmwareUse | None  # --for-firmware's findings
    core: tuple[str, ...]  # the core packages the workspace has
    extra: tuple[str, ...]  # the workspace's extra packages

    @property
    def request(self) -> tuple[str, ...]:
        found = tuple(self.firmware.packages) if self.firmware else ()
        return tuple(sorted({*self.wanted, *found, *self.core, *self.extra}))


@dataclass(frozen=True)
class BuildPlan:
    workspace: Workspace
    config: WorkspaceConfig | None  # None: a plain colcon workspace, not made by create-firmware
    distro: Distro | None
    target: Target
    meta: meta_mod.Meta
    output: Path
    target_dir: Path  # .uros/targets/<key>
    packages_up_to: tuple[str, ...]  # colcon's --packages-up-to as the user gave it (and only that)
    jobs: int | None
    verbose: bool
    workspace_packages: tuple[PackageInfo, ...] = ()  # every package colcon will find in the workspace
    warnings: tuple[str, ...] = ()  # inputs that are valid but likely not what the user meant
    platform: Platform = field(default_factory=Platform)  # ESP-IDF, an RTOS, an IP stack (each or none)
    rebuild: bool = False
    selection: Selection | None = None  # --packages/--for-firmware/uros.yaml packages: (None: all)
    force: bool = False  # --force: the output may be another target's, or hold the user's files
    output_flag: str = "--output"  # how messages name the output ("the output folder" by default)
    cache: CacheSettings | None = None  # the team cache of outputs (None: none)
    ccache: bool | None = None  # True: ccache required; None: when installed; False: never
    # every setting with who chose it (settings.py), printed by `uros build -v`
    settings: Resolved = field(default_factory=lambda: Resolved({}))
    # the environment's switches (settings.py: UROS_HOST_STAGE, UROS_COMPILER_SEED, UROS_GEN_CACHE,
    # UROS_GEN_CACHE_DIR), read once here: the steps read the plan, not the environment
    host_stage: bool = True  # the packages that compile nothing built once for the host
    compiler_seed: bool = True  # CMake's compiler facts found once per target
    gen_cache: bool = True  # generator runs and configure calls through the user's cache
    gen_cache_dir: Path = Path("~/.cache/uros/gen")  # that cache's folder

    @property
    def requested(self) -> tuple[str, ...]:
        """The packages whose closure the build is for: the selection's (--packages, --for-firmware,
        uros.yaml's packages:), else --packages-up-to's; () for every package."""
        return self.selection.request if self.selection else self.packages_up_to
