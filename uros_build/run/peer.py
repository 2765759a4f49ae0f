"""The verdict of a run with a host ROS 2 peer (`uros probe --peer`): the firmware's judged verdict
and the peer's exit status together (pure). Neither alone is enough: a wrong interface definition on
one side matches over DDS (the type names agree) and decodes wrongly, so the firmware passes its own
checks while only the peer's field checks fail; a peer that passes says nothing of a firmware that
crashed afterwards, or of a stage only the host judges (the time stage's offset from the host's
clock: a firmware that exits 0 can fail it).

The firmware's half is what the run without a peer would say (the built-in probe: its exit status
and every stage judged, run/stages.verdict; an app: run/appverdict.verdict), never its exit status alone:
`--peer` adds a condition, it never removes one."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PeerVerdict:
    passed: bool
    text: str


def peer_verdict(firmware_passed: bool, firmware_text: str, peer_status: int | None) -> PeerVerdict:
    """``firmware_passed``/``firmware_text``: the firmware's own judged verdict (what the run would
    say without a peer); passes only when that passed and the peer exited 0."""
    if peer_status is None:
        peer = "the peer did not finish in time"
    elif peer_status == 0:
        peer = "the peer passed"
    else:
        peer = f"the peer failed (exit {peer_status})"
    if firmware_passed and peer_status == 0:
        return PeerVerdict(True, "pass: the firmware and the peer both passed")
    if firmware_passed:
        return PeerVerdict(False, f"{peer}, though the firmware passed its own checks")
    return PeerVerdict(False, f"{firmware_text}; {peer}")
