"""The workspace model: uros.yaml, uros.lock, extra-package sync, dev_ws environment."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from uros_build.errors import ConfigError
from uros_build.sources.clones import clone_argv
from uros_build.sources.distros import Repo, Source
from uros_build.sources.workspace import Workspace, dev_env, sync_tree
from uros_build.sources.wsfiles import (
    Lock,
    WorkspaceConfig,
    config_text,
    load_config,
    parse_config,
    parse_lock,
    read_lock,
    save_config,
)


def test_config_round_trip(tmp_path: Path) -> None:
    text = "distro: jazzy\nmirror:\n  rules: ['https://github.com/{owner}/{repo}=/m/{owner}+{repo}/repo']\n"
    (tmp_path / "uros.yaml").write_text(text, encoding="utf-8")
    cfg = load_config(tmp_path)
    assert cfg is not None and cfg.distro == "jazzy" and cfg.platform == "generate_lib"
    assert cfg.mirror.rules[0].pattern == "https://github.com/{owner}/{repo}"
    save_config(tmp_path, cfg)
    assert load_config(tmp_path) == cfg
    assert config_text(cfg).startswith("# Written by uros")


def test_no_config_is_not_a_firmware_workspace(tmp_path: Path) -> None:
    assert load_config(tmp_path) is None


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (["distro: humble"], "expected a mapping"),
        ({"distro": 3}, "distro: must be a non-empty string"),
        ({"distro": "humble", "extra_packages": "abc"}, "extra_packages: must be a list of strings"),
        ({"distro": "humble", "mirror": ["x"]}, "mirror: expected a mapping"),
        ({"distro": "humble", "colour": "red"}, "colour: unknown key"),
    ],
)
def test_bad_config(data: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        parse_config(data, "uros.yaml")
    assert info.value.message.startswith("uros.yaml")


def test_bad_config_yaml_names_the_line(tmp_path: Path) -> None:
    (tmp_path / "uros.yaml").write_text("distro: humble\nmirror: [\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"uros.yaml:3:1: not valid YAML"):
        load_config(tmp_path)


def test_lock_round_trip(tmp_path: Path) -> None:
    repo = Repo("uros/rclc", "https://github.com/ros2/rclc.git", "humble")
    lock = Lock.from_clones(
        "humble", {"mcu_ws/uros/rclc": Source(repo, "/m/rclc", "humble")}, {"mcu_ws/uros/rclc": "c" * 40}
    )
    (tmp_path / "uros.lock").write_text(lock.to_json(), encoding="utf-8")
    back = read_lock(tmp_path / "uros.lock", "--locked")
    assert back == lock and back.commits() == {"mcu_ws/uros/rclc": "c" * 40}
    data = json.loads(lock.to_json())
    assert list(data) == sorted(data) and data["repositories"]["mcu_ws/uros/rclc"]["source"] == "/m/rclc"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("{", "not valid JSON"),
        ("[]", "expected a mapping"),
        ('{"repositories": {"mcu_ws/a": {}}}', "commit: is required"),
        # what --force deletes: only repository folders inside dev_ws/ or mcu_ws/
        ('{"repositories": {"../..": {"commit": "c"}}}', "is not a repository folder inside"),
        ('{"repositories": {"mcu_ws": {"commit": "c"}}}', "is not a repository folder inside"),
        ('{"repositories": {"mcu_ws/../x": {"commit": "c"}}}', "is not a repository folder inside"),
        ('{"repositories": {"mcu_ws/extra_packages/a": {"commit": "c"}}}', "is not a repository folder"),
        ('{"repositories": {"/etc/x": {"commit": "c"}}}', "is not a repository folder inside"),
        ('{"repositories": []}', "repositories: expected a mapping"),
    ],
)
def test_bad_lock(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "uros.lock").write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match=message):
        read_lock(tmp_path / "uros.lock", "--locked")


def test_parse_lock_keeps_every_field() -> None:
    lock = parse_lock({"distro": "humble", "repositories": {"dev_ws/p": {"commit": "x", "url": "u"}}}, "l")
    assert lock.repositories["dev_ws/p"].url == "u" and lock.distro == "humble"


def test_clone_state_reads_head_and_changes() -> None:
    from uros_build.sources.wsfiles import clone_state

    clean = "# branch.oid 0123abc\n# branch.head humble\n"
    assert clone_state(clean) == ("0123abc", 0)
    dirty = (
        clean + "1 .M N... 100644 100644 100644 a b src/rcl.c\n2 R. N... 100644 100644 100644 a b R100 n\to\n"
    )
    assert clone_state(dirty) == ("0123abc", 2)


def test_sync_tree_touches_only_what_changed(tmp_path: Path) -> None:
    src, dst = tmp_path / "src", tmp_path / "dst"
    (src / "msg").mkdir(parents=True)
    (src / "msg" / "A.msg").write_text("int32 a\n")
    (src / "package.xml").write_text("<package/>")
    (src / ".git").mkdir()
    (src / ".git" / "HEAD").write_text("ref")
    assert sync_tree(src, dst) == 2
    assert not (dst / ".git").exists()
    assert sync_tree(src, dst) == 0
    (src / "msg" / "A.msg").write_text("int32 a\nint32 b\n")
    (src / "package.xml").unlink()
    assert sync_tree(src, dst) == 2
    assert (dst / "msg" / "A.msg").read_text().endswith("int32 b\n") and not (dst / "package.xml").exists()


def test_dev_env_is_what_sourcing_dev_ws_gives(tmp_path: Path) -> None:
    (tmp_path / "lib/python3.11/site-packages").mkdir(parents=True)
    env = dev_env({"PATH": "/usr/bin", "PYTHONPATH": "/x"}, tmp_path)
    assert env["AMENT_PREFIX_PATH"] == str(tmp_path) == env["CMAKE_PREFIX_PATH"]
    assert env["PATH"] == f"{tmp_path / 'bin'}:/usr/bin"
    assert env["PYTHONPATH"] == f"{tmp_path / 'lib/python3.11/site-packages'}:/x"


def test_clone_argv_branch_and_commit() -> None:
    repo = Repo("uros/rcl", "https://github.com/ros2/rcl.git", "humble")
    assert clone_argv("git", Source(repo, "/m/rcl", "humble"), Path("/w/rcl")) == [
        [
            "git",
            "-c",
            "advice.detachedHead=false",
            "clone",
            "--quiet",
            "--branch",
            "humble",
            "/m/rcl",
            "/w/rcl",
        ]
    ]
    pinned = clone_argv("git", Source(repo, "/m/rcl", "d" * 40), Path("/w/rcl"))
    assert [a[3:5] for a in pinned] == [["clone", "--quiet"], ["-C", "/w/rcl"]]


def test_workspace_config_defaults() -> None:
    assert WorkspaceConfig("humble").extra_packages == ()


def test_clean_counts_and_recognises_only_uros_outputs(tmp_path: Path) -> None:
    from uros_build.commands.clean import human
    from uros_build.output.folders import is_uros_output, write_marker
    from uros_build.sources.workspace import tree_bytes

    out = tmp_path / "out"
    out.mkdir()
    (out / "a.bin").write_bytes(b"x" * 1000)
    (out / "sub").mkdir()
    (out / "sub" / "b.bin").write_bytes(b"y" * 24)
    assert tree_bytes(out) == 1024 and human(1024) == "1.0 KiB" and human(12) == "12 bytes"
    assert not is_uros_output(out)
    (out / "build-info.json").write_text('{"generated_by": "me", "target": "t", "library": {}}')
    assert not is_uros_output(out)
    (out / "build-info.json").write_text(
        '{"generated_by": "uros 0.1.0", "target": "t", "library": {"file": "libmicroros.a", "sha256": "0"}}'
    )
    assert not is_uros_output(out)  # its library is not the one build-info.json names
    write_marker(out, "t", ["a.bin", "sub", "build-info.json"])
    assert is_uros_output(out)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            "# mine\ndistro: humble  # pinned\nextra_packages: []\n",
            '# mine\ndistro: humble  # pinned\nextra_packages: ["/p q"]\n',
        ),
        (
            "distro: humble\nextra_packages:\n  - /x  # first\n# note\n",
            'distro: humble\nextra_packages:\n  - /x  # first\n  - "/p q"\n# note\n',
        ),
        (
            "distro: humble\nextra_packages: [/x]  # c\n",
            'distro: humble\nextra_packages: [/x, "/p q"]  # c\n',
        ),
        ("distro: humble", 'distro: humble\nextra_packages:\n- "/p q"\n'),
    ],
)
def test_with_extra_package_is_a_line_edit(text: str, expected: str) -> None:
    from uros_build.sources.wsfiles import with_extra_package

    assert with_extra_package(text, "/p q", "uros.yaml") == expected


def test_with_extra_package_refuses_what_a_line_edit_cannot_extend() -> None:
    from uros_build.sources.wsfiles import with_extra_package

    with pytest.raises(ConfigError, match="cannot add /p to this list"):
        with_extra_package("distro: humble\nextra_packages: [\n  /x]\n", "/p", "uros.yaml")


def test_lock_hints_fit_what_pointed_at_the_lock(tmp_path: Path) -> None:
    """Round 3 (issue 34, 7): "create the workspace once without --locked" was every lock's hint."""
    hints = {}
    for flag in ("--locked", "--lock-file", "--workspace"):
        with pytest.raises(ConfigError) as info:
            read_lock(tmp_path / "uros.lock", flag)
        hints[flag] = info.value.hint
    assert hints["--locked"] is not None and "pass --lock-file PATH" in hints["--locked"]
    assert (
        hints["--lock-file"] == "pass the uros.lock of a workspace (`uros create-firmware` writes one there)"
    )
    (tmp_path / "uros.lock").write_text("{", encoding="utf-8")
    for flag in ("--locked", "--workspace", "uros.lock"):
        with pytest.raises(ConfigError) as info:
            read_lock(tmp_path / "uros.lock", flag)
        assert info.value.hint is not None and info.value.hint.startswith("restore uros.lock")


def test_an_extra_package_that_is_gone_builds_its_copy_and_one_never_copied_is_refused(
    tmp_path: Path,
) -> None:
    """Round 5 (issue 43): `extra_packages: [/nonexistent]` built without the package after
    "keeping the copy", where there was none; a folder that is gone whose copy uros made builds on."""
    ws = Workspace(tmp_path)
    copy = ws.extra_dir / "my_msgs"
    copy.mkdir(parents=True)
    (copy / "package.xml").write_text("<package format='3'><name>my_msgs</name></package>\n")
    ws.check_extra_sources(WorkspaceConfig("humble", extra_packages=(str(tmp_path / "gone" / "my_msgs"),)))
    assert ws.kept_copy(tmp_path / "gone" / "my_msgs") == copy
    never = WorkspaceConfig("humble", extra_packages=("/nonexistent/other_msgs",))
    with pytest.raises(
        ConfigError, match="extra_packages: /nonexistent/other_msgs is no folder, and mcu_ws/"
    ):
        ws.check_extra_sources(never)
