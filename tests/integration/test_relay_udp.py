"""The UDP relay of `uros probe --link` (run/relay.py UdpRelay, issue 40 item 4) on the host's
loopback, with a small echo in place of the agent: each datagram meets its seeded fate, the relay's
counts add up, and the same seed loses the same datagrams again. Runs everywhere, CI included (no
agent, no QEMU: sockets and a thread of this process)."""

from __future__ import annotations

import socket
import threading
import time

import pytest

from uros_build.run import relay, xrcewire
from uros_build.run.session import free_udp_port

pytestmark = pytest.mark.integration


def _best_effort(seq: int) -> bytes:
    """An XRCE message on best-effort stream 1 with one WRITE_DATA (its number in the payload)."""
    return bytes([0x81, 0x01, seq & 0xFF, seq >> 8, xrcewire.WRITE_DATA, 0, 4, 0]) + seq.to_bytes(4, "little")


def _echo(sock: socket.socket, stop: threading.Event) -> None:
    """The agent's stand-in: every datagram back to its sender, its write turned into DATA."""
    sock.settimeout(0.05)
    while not stop.is_set():
        try:
            data, source = sock.recvfrom(2048)
        except OSError:
            continue
        sock.sendto(data[:4] + bytes([xrcewire.DATA]) + data[5:], source)


def _run(seed: int) -> tuple[set[int], dict[str, object]]:
    board_port = free_udp_port()
    agent = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    agent.bind(("127.0.0.1", 0))
    stop = threading.Event()
    echo = threading.Thread(target=_echo, args=(agent, stop), daemon=True)
    echo.start()
    plan = relay.FaultPlan(loss=0.1, duplicate=0.05, seed=seed)  # no delay: the echo keeps the order
    link = relay.UdpRelay(board_port, agent.getsockname()[1], plan, None)
    link.start()
    board = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    board.settimeout(0.5)
    back: set[int] = set()
    try:
        for seq in range(200):
            board.sendto(_best_effort(seq), ("127.0.0.1", board_port))
            time.sleep(0.002)
        while True:
            try:
                data = board.recv(2048)
            except TimeoutError:
                break
            back.add(int.from_bytes(data[8:12], "little"))
    finally:
        link.stop()
        stop.set()
        echo.join()
        agent.close()
        board.close()
    return back, link.summary()


def test_the_udp_relay_loses_what_its_seed_says_and_counts_it() -> None:
    back, counts = _run(7)
    up, down = counts["board_to_agent"], counts["agent_to_board"]
    assert isinstance(up, dict) and isinstance(down, dict) and counts["transport"] == "udp"
    assert up["frames"] == up["best_effort"] == 200
    assert 8 <= up["lost"] <= 35  # about 10 %
    assert up["best_effort_passed"] == 200 - up["lost"] + up["duplicated"]
    assert down["best_effort"] == up["best_effort_passed"]  # the echo answered every copy
    assert len(back) <= down["best_effort_passed"] <= down["best_effort"]
    again, _ = _run(7)
    assert again == back  # the same seed: the same datagrams lost
    other, _ = _run(8)
    assert other != back
