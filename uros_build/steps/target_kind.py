"""The kind of target a build is for, chosen once (model: cibuildwheel's platform module, chosen once
behind a Protocol): a profile (shipped, or the user's --profile), the user's own toolchain file, or
a profile's target compiled against an ESP-IDF project (--idf-build). The steps ask the kind what
they need; none asks which kind it is.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from uros_build import console
from uros_build.colcon import fingerprint as fp
from uros_build.colcon.hosttools import HostFacts
from uros_build.colcon.installtree import forget_configured_flags
from uros_build.config.buildplan import BuildPlan
from uros_build.config.colconmeta import meta_transport
from uros_build.config.targets import ProfileTarget, ToolchainFileTarget
from uros_build.files import write_if_changed
from uros_build.output.buildinfo import Compiler, Flags, IdfInfo, IpStackInfo, RtosInfo
from uros_build.proc import Runner
from uros_build.steps.renders import kept_render
from uros_build.target import abi, compilers
from uros_build.target.profiles import TargetProfile
from uros_build.target.toolchain import (
    CLOCK_HEADER_NAME,
    CLOCK_HEADER_TEXT,
    CXX_WRAPPERS,
    CXX_WRAPPERS_DIR,
    ToolchainRequest,
    cxx_wrapper_text,
    microros_flags,
    render_toolchain,
    tool_paths,
)
from uros_build.target.toolsearch import BinTools


@dataclass(frozen=True)
class Described:
    """What build-info.json says of the target, beyond its key."""

    profile: str | None = None  # the profile's file name
    toolchain_file: str | None = None  # the user's own toolchain file
    compiler: Compiler | None = None
    flags: Flags = field(default_factory=Flags)
    idf_target: str | None = None
    idf: IdfInfo | None = None
    rtos: RtosInfo | None = None
    ip_stack: IpStackInfo | None = None


def rendered_toolchain(folder: Path, name: str, req: ToolchainRequest) -> str:
    """``render_toolchain(req)``, kept in ``folder`` (steps/renders.py): an up-to-date build renders
    its toolchain texts without jinja2."""
    return kept_render(folder, name, repr(req), ("toolchain.cmake.j2",), lambda: render_toolchain(req))


class TargetKind(Protocol):
    """What the steps ask of a target."""

    @property
    def uses_ccache(self) -> bool:
        """Whether compiles may go through ccache (uros's toolchain carries the path maps that
        keep the library the same under it; a user's toolchain file does not)."""

    def write_toolchain(self) -> Path:
        """The toolchain file the packages are configured with (written when it changes; a changed
        one makes every package configure afresh)."""

    def portable_toolchain(self, toolchain_file: Path) -> str:
        """The toolchain text without the workspace's folder in it (the portable build key's)."""

    def bintools(self) -> BinTools:
        """The archiver, ranlib and nm the library is merged with."""

    def check_library(self, runner: Runner, library: Path, announce: bool = True) -> Mapping[str, Any]:
        """The ABI check's record of the library, said on the console (``announce``: with the step
        line first); ``checked`` False when there is nothing to check against. VerifyError when an
        object fails it."""

    def library_size(self, runner: Runner, library: Path) -> Mapping[str, int] | None:
        """The library's text/data/bss totals, when the target's size tool is known."""

    def firmware_toolchain(self) -> str | None:
        """The text of the firmware's toolchain file beside the library (None: it has its own)."""

    def described(self) -> Described:
        """build-info.json's account of the target."""


@dataclass(frozen=True)
class OwnToolchainFile:
    """The user's own toolchain file, used unchanged: uros knows no ELF facts to check against."""

    plan: BuildPlan
    target: ToolchainFileTarget

    uses_ccache = False

    def write_toolchain(self) -> Path:
        # its flags, too, reach the compiles only through a fresh configure
        seen = self.plan.target_dir / "toolchain-file.sha256"
        if write_if_changed(seen, fp.file_sha256(self.target.toolchain_file) + "\n"):
            forget_configured_flags(self.plan.target_dir / "build")
        return self.target.toolchain_file

    def portable_toolchain(self, toolchain_file: Path) -> str:
        return toolchain_file.read_text(encoding="utf-8", errors="replace")

    def bintools(self) -> BinTools:
        # the archiver CMake recorded for it (the target's); the host binutils read foreign ELF
        # archives too, as a fallback
        return compilers.bintools_from_build(self.plan.target_dir / "build") or BinTools("ar", "ranlib", "nm")

    def check_library(self, runner: Runner, library: Path, announce: bool = True) -> Mapping[str, Any]:
        return {"checked": False, "reason": "your own toolchain file: no target profile to compare with"}

    def library_size(self, runner: Runner, library: Path) -> Mapping[str, int] | None:
        return None

    def firmware_toolchain(self) -> str | None:
        return None  # the firmware has its toolchain file: the user's

    def described(self) -> Described:
        return Described(toolchain_file=str(self.target.toolchain_file))


@dataclass(frozen=True)
class Profile:
    """A profile's target: uros renders its toolchain file and checks the library against it."""

    plan: BuildPlan
    facts: HostFacts
    target: ProfileTarget

    uses_ccache = True

    @property
    def profile(self) -> TargetProfile:
        return self.target.profile

    def toolchain_request(
        self, root: str, clock_header: str | None = None, portable: bool = False
    ) -> ToolchainRequest:
        """The micro-ROS toolchain file's inputs, ``root`` standing for the workspace (the real one,
        or a placeholder) and ``clock_header`` for the clock header's path (by default where the
        build writes it, under ``root``); ``portable``: the RTOS's folders as placeholders too."""
        profile, plan = self.profile, self.plan
        rtos, stack = plan.platform.rtos, plan.platform.ip_stack
        if clock_header is None:
            clock_header = str(
                Path(root) / plan.target_dir.relative_to(plan.workspace.root) / CLOCK_HEADER_NAME
            )
        return ToolchainRequest(
            profile,
            micro_ros=True,
            gcc_major=self.facts.gcc_major,
            clock_header=clock_header if profile.micro_ros.declare_clock_gettime else None,
            cxx_wrappers=str(Path(clock_header).parent / CXX_WRAPPERS_DIR)
            if profile.micro_ros.cxx_wrapper_headers
            else None,
            tool_dir=self.facts.tool_dir,
            command=f"uros build --toolchain {profile.name}",
            prefix_map=root,
            idf=plan.platform.idf,
            transport=meta_transport(plan.meta),
            rtos=rtos.portable() if rtos is not None and portable else rtos,
            ip_stack=stack.portable() if stack is not None and portable else stack,
        )

    def write_toolchain(self) -> Path:
        target_dir = self.plan.target_dir
        if self.profile.micro_ros.declare_clock_gettime:
            write_if_changed(target_dir / CLOCK_HEADER_NAME, CLOCK_HEADER_TEXT)
        if self.profile.micro_ros.cxx_wrapper_headers:
            (target_dir / CXX_WRAPPERS_DIR).mkdir(parents=True, exist_ok=True)
            for name, c_header in CXX_WRAPPERS.items():
                write_if_changed(target_dir / CXX_WRAPPERS_DIR / name, cxx_wrapper_text(c_header))
        path = target_dir / "toolchain.cmake"
        request = self.toolchain_request(str(self.plan.workspace.root))
        text = rendered_toolchain(target_dir, "toolchain.cmake", request)
        if write_if_changed(path, text):
            forget_configured_flags(target_dir / "build")
        return path

    def portable_toolchain(self, toolchain_file: Path) -> str:
        # rendered again with a placeholder for the workspace, quoted as a plain path is
        return rendered_toolchain(
            self.plan.target_dir, "portable", self.toolchain_request("/workspace", portable=True)
        )

    def bintools(self) -> BinTools:
        tools = tool_paths(self.profile, self.facts.tool_dir)
        return BinTools(ar=tools["ar"], ranlib=tools["ranlib"], nm=tools["nm"])

    def check_library(self, runner: Runner, library: Path, announce: bool = True) -> Mapping[str, Any]:
        if announce:
            console.step(f"checking every object against {self.profile.name}'s ELF facts")
        checked = abi.check_library(runner, library, self.profile)
        console.info(abi.describe(checked))
        return checked

    def library_size(self, runner: Runner, library: Path) -> Mapping[str, int] | None:
        return compilers.size_totals(runner, tool_paths(self.profile, self.facts.tool_dir)["size"], library)

    def firmware_toolchain(self) -> str | None:
        profile = self.profile
        req = ToolchainRequest(profile, micro_ros=False, command=f"uros toolchain render {profile.name}")
        return rendered_toolchain(self.plan.target_dir, "firmware", req)

    def described(self) -> Described:
        profile, facts = self.profile, self.facts
        rtos, stack = self.plan.platform.rtos, self.plan.platform.ip_stack
        # recorded without the workspace's folder, so that build-info.json does not depend on it
        micro_ros = self.toolchain_request("<workspace>", clock_header=CLOCK_HEADER_NAME)
        return Described(
            profile=Path(profile.source).name,
            compiler=Compiler(facts.gcc, facts.gcc_version),
            flags=Flags(
                cpu=profile.cpu_flags,
                c=profile.c_flags,
                cxx=profile.cxx_flags,
                optimization=profile.optimization,
                micro_ros_only=tuple(microros_flags(micro_ros)),
            ),
            idf_target=profile.idf_target or None,
            rtos=RtosInfo(**rtos.record()) if rtos is not None else None,
            ip_stack=IpStackInfo(**stack.record()) if stack is not None else None,
        )


@dataclass(frozen=True)
class IdfProfile(Profile):
    """A profile's target compiled against an ESP-IDF project's include folders, sdkconfig.h and
    flags (--idf-build): recorded in build-info.json."""

    def described(self) -> Described:
        idf = self.plan.platform.idf
        assert idf is not None  # chosen for a plan with an ESP-IDF project
        info = IdfInfo(
            version=idf.version_text,
            target=idf.target,
            sdkconfig_sha256=idf.sdkconfig_sha256,
            components=idf.components,
            include_dirs=len(idf.include_dirs),
            c_flags=idf.c_flags,
            cxx_flags=idf.cxx_flags,
        )
        return dataclasses.replace(super().described(), idf=info)


def kind_of(plan: BuildPlan, facts: HostFacts) -> TargetKind:
    """The plan's target kind, chosen once for the whole build."""
    target = plan.target
    if isinstance(target, ToolchainFileTarget):
        return OwnToolchainFile(plan, target)
    if plan.platform.idf is not None:
        return IdfProfile(plan, facts, target)
    return Profile(plan, facts, target)
