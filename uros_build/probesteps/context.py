"""The frozen records `uros probe`'s steps share: what the command line asked (`ProbeRequest`), what
was found before anything runs (`ProbePlan`), and the one context every step after the run is open is
handed (`ProbeContext`, as steps/context.py is a build's); each step returns a frozen result of its
own (`Tools`, `Firmware`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from uros_build.output.buildinfo import BuildInfo
from uros_build.output.sizes import Sizes
from uros_build.proc import Runner
from uros_build.run.app import AppPlan
from uros_build.run.freertos import FreeRtos
from uros_build.run.machines import Machine
from uros_build.run.network import Network
from uros_build.run.relay import FaultPlan


@dataclass(frozen=True)
class AppRequest:
    """--app DIR, its --define/-D macros and --duration."""

    folder: Path
    defines: tuple[str, ...] = ()
    duration: float | None = None


@dataclass(frozen=True)
class ProbeRequest:
    """`uros probe`'s command line, as given."""

    output: Path | None
    workspace: Path | None
    toolchain: str | None
    agent: str | None  # --agent
    timeout: float
    as_json: bool = False
    verbose: bool = False
    peer: Path | None = None  # --peer SCRIPT
    freertos: str | None = None  # --freertos KERNEL
    board: str | None = None
    app: AppRequest | None = None
    graph: bool = False  # --graph: the graph stage, with uros's own peer (run/graph.py)
    link: str | None = None  # --link FAULTS: a relay that drops between QEMU and the agent (run/relay.py)
    instances: int = 1  # --instances N: N boards of the one image on one agent (run/fleet.py)
    client_keys: str | None = None  # --client-keys own|same|drawn (with --instances)


@dataclass(frozen=True)
class ProbePlan:
    """What is probed, found and checked before anything runs (probesteps/plan.py)."""

    out: Path  # the output
    info: BuildInfo  # its build-info.json
    machine: Machine  # the QEMU board it runs on
    rtos: FreeRtos | None  # the FreeRTOS kernel it runs on; None: bare metal
    base: Path  # the folder of the probe's locks and work folders (run/report.py probe_base)
    app: AppPlan | None  # --app: the app; None: the probe firmware
    peer: Path | None = None  # the peer's script: --peer's, or --graph's own
    link: FaultPlan | None = None  # --link, parsed


@dataclass(frozen=True)
class ProbeContext:
    """Every step's context once the run is open (probesteps/start.py), unchanged to the end."""

    request: ProbeRequest
    plan: ProbePlan
    work: Path  # the run's work folder: firmware, console, logs, report.json
    network: Network | None  # the IP stack it runs over; None: the serial link
    runner: Runner  # this run's processes and its log

    @property
    def on(self) -> str:
        """What the firmware runs on, as the lines say it: ' on FreeRTOS (...)', ' over UDP (...)'."""
        rtos = self.plan.rtos
        on = f" on FreeRTOS ({rtos.why})" if rtos else ""
        if self.network is not None:
            on += f" over UDP ({self.network.label} on the LAN9118)"
        return on


@dataclass(frozen=True)
class Tools:
    """The programs a run starts (probesteps/tools.py)."""

    qemu: str
    agent: str


@dataclass(frozen=True)
class Firmware:
    """The firmware built for the run (probesteps/firmware.py) and the agent side it was built for."""

    elf: Path
    middleware: str  # the agent's -m (run/session.py middleware_for)
    port: int  # the agent's UDP port (over UDP)
    sizes: Sizes | None = None  # --app: its text/data/bss
    nonce: str = ""  # --app: the runner's nonce of this run
