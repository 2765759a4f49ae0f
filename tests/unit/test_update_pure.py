"""`uros update`'s pure pieces: git argv, the move table, and the one-line edit of uros.yaml."""

from __future__ import annotations

from pathlib import Path

import pytest

from uros_build.commands.update import Move, describe
from uros_build.errors import ConfigError, StepFailed
from uros_build.sources import clones
from uros_build.sources.clones import UPDATE_REFS, checkout_argv, fetch_argv, fetched_commit_argv
from uros_build.sources.distros import Repo, Source
from uros_build.sources.wsfiles import with_distro

_REPO = Repo("uros/rcl", "https://github.com/micro-ROS/rcl", "humble")


def test_fetch_of_a_branch_lands_in_fetch_head_only() -> None:
    src = Source(_REPO, "/m/rcl", "humble")
    assert fetch_argv("git", src, Path("/w/rcl")) == [
        "git", "-c", "advice.detachedHead=false", "-C", "/w/rcl", "fetch", "--quiet", "--no-tags", "/m/rcl", "humble",
    ]  # fmt: skip
    assert fetched_commit_argv("git", src, Path("/w/rcl"))[-1] == "FETCH_HEAD^{commit}"


def test_fetch_of_a_pinned_commit_takes_every_branch_into_uros_refs() -> None:
    src = Source(_REPO, "/m/rcl", "a" * 40)
    argv = fetch_argv("git", src, Path("/w/rcl"))
    assert argv[-1] == f"+refs/heads/*:{UPDATE_REFS}/*" and UPDATE_REFS.startswith("refs/uros-")
    assert fetched_commit_argv("git", src, Path("/w/rcl"))[-1] == "a" * 40 + "^{commit}"
    assert checkout_argv("git", Path("/w/rcl"), "b" * 40)[-2:] == ["--detach", "b" * 40]


@pytest.mark.parametrize(
    ("move", "line"),
    [
        (
            Move("mcu_ws/uros/rcl", "a" * 40, "b" * 40, 3),
            f"mcu_ws/uros/rcl: {'a' * 12} -> {'b' * 12} (+3 commits)",
        ),
        (Move("mcu_ws/x", "a" * 40, "b" * 40, 2, 5), f"mcu_ws/x: {'a' * 12} -> {'b' * 12} (+2 -5 commits)"),
        (Move("mcu_ws/new", None, "c" * 40), f"mcu_ws/new: new clone at {'c' * 12}"),
        (Move("mcu_ws/new", None, None), "mcu_ws/new: would be cloned"),
        (Move("mcu_ws/gone", "d" * 40, None), f"mcu_ws/gone: removed (not in the distro) was {'d' * 12}"),
    ],
)
def test_describe(move: Move, line: str) -> None:
    assert describe(move) == line


def test_with_distro_keeps_comments_order_and_other_keys() -> None:
    text = (
        "# mine\ndistro: humble  # pinned for the H7\nplatform: generate_lib\nset:\n- rmw_microxrcedds.X=1\n"
    )
    assert with_distro(text, "iron", "uros.yaml") == (
        "# mine\ndistro: iron  # pinned for the H7\nplatform: generate_lib\nset:\n- rmw_microxrcedds.X=1\n"
    )
    assert with_distro("distro: humble\n", "iron", "u") == "distro: iron\n"
    # a uros.yaml without a distro (a build needs none): `uros update --distro` adds the line
    assert (
        with_distro("target: cortex-m7  # mine", "humble", "u")
        == "target: cortex-m7  # mine\ndistro: humble\n"
    )


@pytest.mark.parametrize("text", ["distro:\n  humble\n", "distro: a\ndistro: b\n"])
def test_with_distro_refuses_what_is_not_one_plain_line(text: str) -> None:
    with pytest.raises(ConfigError, match=r"'distro:' line|could not set"):
        with_distro(text, "iron", "uros.yaml")


# --- git's failures, classified once in sources/clones.py -------------------------------------


@pytest.mark.parametrize(
    ("said", "kind"),
    [
        ("fatal: Remote branch no-such-branch not found in upstream origin", "version"),
        ("fatal: couldn't find remote ref refs/heads/gone", "version"),
        ("fatal: unable to access 'https://x/': Could not resolve host: x", "unreachable"),
        ("fatal: '/m/none' does not appear to be a git repository", "unreachable"),
        ("fatal: repository '/m/empty' does not exist", "unreachable"),
        ("fatal: index file corrupt", "other"),
    ],
)
def test_git_failure_kind_is_decided_once(said: str, kind: str) -> None:
    exc = StepFailed(f"clone x failed (exit 128): {said}", output=("Cloning...", said), code=128, cause=said)
    assert clones.git_failure(exc) == clones.GitFailure(kind, 128, said)


def test_source_failed_quotes_git_and_names_the_fix() -> None:
    src = Source(_REPO, "/m/rcl", "nope")
    said = "fatal: Remote branch nope not found in upstream origin"
    exc = clones.source_failed(
        "cloning", "mcu_ws/ros2/rcl", src, StepFailed("x", code=128, cause=said), "fix it"
    )
    assert exc.message == f"cloning mcu_ws/ros2/rcl from /m/rcl at 'nope' failed: {said}"
    assert exc.hint == "check that the source has 'nope', or fix it" and exc.code == 128
    gone = StepFailed("x", code=128, cause="fatal: '/m/rcl' does not appear to be a git repository")
    assert (
        clones.source_failed("fetching", "p", src, gone, "fix it").hint
        == "check that /m/rcl can be reached, or fix it"
    )
