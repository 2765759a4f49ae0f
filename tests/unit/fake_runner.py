"""A stand-in for proc.Runner in unit tests of the steps: it starts nothing; each query or run is
answered by the function given for the program (which may write files, as the tool would), and
every call is recorded."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from uros_build.errors import StepFailed

Answer = Callable[[Sequence[str]], str]


@dataclass
class FakeRunner:
    log_path: Path
    answers: Mapping[str, Answer] = field(default_factory=dict)  # program name -> its answer
    calls: list[list[str]] = field(default_factory=list)
    verbose: bool = False

    def which(self, program: str, hint: str | None = None, path: str | None = None) -> str:
        return program

    def log(self, text: str) -> None:
        with self.log_path.open("a", encoding="utf-8") as log:
            log.write(text + "\n")

    def query(self, argv: Sequence[str], *, step: str, **_: object) -> str:
        self.calls.append(list(argv))
        name = Path(argv[0]).name
        if name not in self.answers:
            raise StepFailed(f"{step}: {name} failed (the fake runner has no answer for it)")
        return self.answers[name](argv)

    def run(
        self,
        argv: Sequence[str],
        *,
        step: str,
        on_line: Callable[[str], None] | None = None,
        **kwargs: object,
    ) -> list[str]:
        lines = self.query(argv, step=step).splitlines()
        for line in lines:  # as the real runner does, each line as it arrives
            if on_line is not None:
                on_line(line)
        return lines
