"""The verdict of a run with a host ROS 2 peer (`uros probe --peer`): the firmware's exit status and
the peer's together (pure). Neither alone is enough: a wrong interface definition on one side
matches over DDS (the type names agree) and decodes wrongly, so the firmware passes its own checks
while only the peer's field checks fail; a peer that passes says nothing of a firmware that crashed
afterwards."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PeerVerdict:
    passed: bool
    text: str


def peer_verdict(firmware_status: int | None, firmware_text: str, peer_status: int | None) -> PeerVerdict:
    """``firmware_text``: what the firmware's status means (run/machines.verdict)."""
    if peer_status is None:
        peer = "the peer did not finish in time"
    elif peer_status == 0:
        peer = "the peer passed"
    else:
        peer = f"the peer failed (exit {peer_status})"
    if firmware_status == 0 and peer_status == 0:
        return PeerVerdict(True, "pass: the firmware and the peer both passed")
    if firmware_status == 0:
        return PeerVerdict(False, f"{peer}, though the firmware passed its own checks")
    return PeerVerdict(False, f"{firmware_text}; {peer}")
