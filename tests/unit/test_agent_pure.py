"""`uros agent`'s pure pieces: the pin data (meta/distros/<distro>/agent.repos) and its loader, the
build's key, the CMake command lines, the wheels' mends, the wrapper script, the built agent's
record, and `uros agent run`'s command lines and checks (run/agentbuild.py, run/builtagent.py, commands/agent.py)."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest

from uros_build.commands import agent as agent_cmd
from uros_build.errors import ConfigError
from uros_build.run import agentbuild, builtagent, graph
from uros_build.sources.distros import Repo, parse_repos

XRCE = Repo("xrce_agent", "https://github.com/eProsima/Micro-XRCE-DDS-Agent.git", "v3.0.1")
GRAPH = Repo("micro_ros_agent", "https://github.com/micro-ROS/micro-ROS-Agent.git", "a" * 40)
MSGS = Repo("micro_ros_msgs", "https://github.com/micro-ROS/micro_ros_msgs.git", "b" * 40)


def test_humble_pins_the_agent_release_for_fast_dds_3_and_micro_ros_agent() -> None:
    pin = agentbuild.load_pin("humble")
    assert pin.xrce.version == "v3.0.1"
    assert pin.graph is not None and pin.msgs is not None
    assert len(pin.graph.version) == 40 and len(pin.msgs.version) == 40  # branches move: commits
    assert [r.path for r in pin.repos] == ["xrce_agent", "micro_ros_agent", "micro_ros_msgs"]


def test_a_distro_without_an_agent_pin_is_one_line_naming_one_with() -> None:
    with pytest.raises(ConfigError, match=r"--distro rolling: no agent is pinned") as err:
        agentbuild.load_pin("rolling")
    assert "humble" in (err.value.hint or "")
    with pytest.raises(ConfigError, match="unknown distro"):
        agentbuild.load_pin("hubmle")


def test_the_pin_without_micro_ros_agent_is_the_plain_agent() -> None:
    pin = agentbuild.parse_pin((XRCE,), "a.repos", "humble")
    assert pin.graph is None and pin.repos == (XRCE,)


@pytest.mark.parametrize(
    ("repos", "message"),
    [
        ((GRAPH, MSGS), r"a.repos: repositories.xrce_agent: is required"),
        ((XRCE, Repo("agent", "u", "v")), r"a.repos: repositories.agent: not one of"),
        ((XRCE, GRAPH), r"repositories.micro_ros_agent: given without micro_ros_msgs"),
        ((XRCE, MSGS), r"repositories.micro_ros_msgs: given without micro_ros_agent"),
    ],
)
def test_a_bad_pin_is_refused_on_load(repos: tuple[Repo, ...], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        agentbuild.parse_pin(repos, "a.repos", "humble")


def test_the_pin_file_is_a_repos_file() -> None:
    text = {"repositories": {"xrce_agent": {"type": "git", "url": "u", "version": "v3.0.1"}}}
    pin = agentbuild.parse_pin(parse_repos(text, "a.repos"), "a.repos", "humble")
    assert pin.xrce == Repo("xrce_agent", "u", "v3.0.1")


def test_the_key_follows_the_commits_and_the_wheels() -> None:
    commits = {"xrce_agent": "1" * 40, "micro_ros_agent": "2" * 40}
    key = agentbuild.agent_key(commits, "kilted-py3.11-aaaa")
    assert key == agentbuild.agent_key(dict(reversed(commits.items())), "kilted-py3.11-aaaa")
    assert key != agentbuild.agent_key({**commits, "xrce_agent": "3" * 40}, "kilted-py3.11-aaaa")
    assert key != agentbuild.agent_key(commits, "kilted-py3.11-bbbb")
    assert len(key) == 16


def test_the_link_reaches_the_wheels_vendored_libraries() -> None:
    libs = [Path("/v/lib/python3.11/site-packages/ros_fastdds.libs")]
    options = agentbuild.link_options(Path("/p"), Path("/v"), libs)
    assert options[0] == (
        "-DCMAKE_EXE_LINKER_FLAGS=-Wl,-rpath-link,/v/lib/python3.11/site-packages/ros_fastdds.libs "
        "-Wl,--disable-new-dtags"
    )
    assert (
        options[2] == "-DCMAKE_INSTALL_RPATH=/p/lib;/v/lib;/v/lib/python3.11/site-packages/ros_fastdds.libs"
    )


def test_the_agent_configures_against_the_venv_without_superbuild() -> None:
    b = agentbuild.Build("cmake", Path("/p"), Path("/v"), (), ("-G", "Ninja"))
    argv = agentbuild.xrce_configure_argv(b, Path("/s"), Path("/b"))
    assert argv[:8] == ["cmake", "-S", "/s", "-B", "/b", "-G", "Ninja", "-DCMAKE_INSTALL_PREFIX=/p"]
    for option in ("-DUAGENT_SUPERBUILD=OFF", "-DUAGENT_USE_SYSTEM_FASTDDS=ON", "-DCMAKE_PREFIX_PATH=/v"):
        assert option in argv


def test_micro_ros_agent_gets_empty_packages_for_what_the_wheels_lack() -> None:
    b = agentbuild.Build("cmake", Path("/p"), Path("/v"), ())
    argv = agentbuild.graph_configure_argv(b, Path("/s"), Path("/b"), Path("/u"))
    assert "-DMICROROSAGENT_SUPERBUILD=OFF" in argv and "-DCMAKE_PREFIX_PATH=/p;/v" in argv
    assert "-Dfastrtps_cmake_module_DIR=/u/fastrtps_cmake_module" in argv
    assert "-DCMAKE_CXX_FLAGS=-include iterator" in argv
    text = agentbuild.unused_package_config("ament_lint_auto")
    assert "set(ament_lint_auto_FOUND TRUE)" in text and text.startswith("# Written by uros agent build")


def test_fast_dds_links_the_wheel_s_own_tinyxml2() -> None:
    text = 'INTERFACE_LINK_LIBRARIES "fastcdr;dl;/usr/lib64/libtinyxml2.so;rt"'
    fixed = agentbuild.fix_fastdds_tinyxml(text, "/v/ros_fastdds.libs/libtinyxml2-1592532c.so.6.0.0")
    assert (
        fixed == 'INTERFACE_LINK_LIBRARIES "fastcdr;dl;/v/ros_fastdds.libs/libtinyxml2-1592532c.so.6.0.0;rt"'
    )
    assert agentbuild.fix_fastdds_tinyxml(fixed, "/x") == fixed  # idempotent


def test_the_wrapper_quotes_every_path_and_execs_the_agent() -> None:
    text = agentbuild.wrapper_script(Path("/a b/micro_ros_agent"), ["/p/lib", "/it's"], ["/p", "/v"], "x")
    assert text.startswith("#!/bin/sh\n# Written by uros agent build")
    assert f"LD_LIBRARY_PATH={shlex.quote('/p/lib:/it' + chr(39) + 's')}" in text
    assert text.endswith("exec '/a b/micro_ros_agent' \"$@\"\n")


def test_the_current_agent_is_read_from_its_record(tmp_path: Path) -> None:
    assert builtagent.current_agent(tmp_path) is None
    folder = tmp_path / "agent" / "humble-0123"
    (folder / "bin").mkdir(parents=True)
    (folder / "bin" / "uros-agent").write_text("#!/bin/sh\n", encoding="utf-8")
    record = {"program": "micro_ros_agent", "why": "built", "distro": "humble", "commits": {"xrce_agent": "c"},
              "venv": "kilted-x", "seconds": 200.5}  # fmt: skip
    (folder / "uros-agent.json").write_text(json.dumps(record), encoding="utf-8")
    (tmp_path / "agent" / "current.json").write_text('{"folder": "humble-0123"}', encoding="utf-8")
    built = builtagent.current_agent(tmp_path)
    assert (
        built is not None
        and built.program == "micro_ros_agent"
        and built.run == folder / "bin" / "uros-agent"
    )
    assert "xrce_agent c" in built.describe()
    (tmp_path / "agent" / "current.json").write_text('{"folder": "../elsewhere"}', encoding="utf-8")
    assert builtagent.current_agent(tmp_path) is None  # the pointer names only a folder beside it


def test_a_record_naming_another_program_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="program"):
        builtagent.parse_record(
            {"program": "sh", "why": "", "distro": "h", "commits": {}, "venv": "v", "seconds": 1},
            "r",
            tmp_path,
        )


@pytest.mark.parametrize(
    ("transport", "level", "argv"),
    [
        (agent_cmd.Transport("serial", ("/dev/pts/3",), 115200), None,
         ["A", "serial", "--dev", "/dev/pts/3", "-b", "115200"]),
        (agent_cmd.Transport("multiserial", ("/dev/pts/3", "/dev/pts/4"), 921600), 6,
         ["A", "multiserial", "--devs", "/dev/pts/3 /dev/pts/4", "-b", "921600", "-v", "6"]),
        (agent_cmd.Transport("udp4", port=8888), 4, ["A", "udp4", "--port", "8888", "-v", "4"]),
    ],
)  # fmt: skip
def test_the_agent_s_command_line(transport: agent_cmd.Transport, level: int | None, argv: list[str]) -> None:
    assert agent_cmd.run_argv("A", transport, level) == argv


def test_devices_repeated_or_in_one_value() -> None:
    assert agent_cmd.parse_devices(("/dev/a /dev/b", "/dev/c")) == ("/dev/a", "/dev/b", "/dev/c")


@pytest.mark.parametrize(
    ("transport", "level", "message"),
    [
        (agent_cmd.Transport("serial", ("/dev/uros-no-such-tty",)), None, r"--dev /dev/uros-no-such-tty: no such"),
        (agent_cmd.Transport("multiserial", ("/dev/null", "/dev/uros-none")), None, r"--devs /dev/uros-none: no"),
        (agent_cmd.Transport("serial", ()), None, r"uros agent run serial: --dev is required"),
        (agent_cmd.Transport("serial", ("/dev/null",), 0), None, r"-b/--baudrate 0"),
        (agent_cmd.Transport("udp4", port=70000), None, r"--port 70000: not a UDP port"),
        (agent_cmd.Transport("udp4", port=8888), 7, r"-v/--verbose-level 7: must be 0-6"),
    ],
)  # fmt: skip
def test_bad_transport_values_are_one_line(
    transport: agent_cmd.Transport, level: int | None, message: str
) -> None:
    with pytest.raises(ConfigError, match=message):
        agent_cmd.check_transport(transport, level)


# ---------------------------------------------------------------------------------------------
# the graph stage (run/graph.py)

SEEN = {
    "graph": "seen",
    "after": 0.12,
    "nodes": [{"name": "uros_probe", "namespace": "/"}],
    "topics": [{"name": "/uros_probe", "types": ["std_msgs/msg/Int32"]}],
    "endpoints": [
        {"topic": "/uros_probe", "kind": kind, "node": "uros_probe", "namespace": "/", "type": "std_msgs/msg/Int32",
         "reliability": "reliable", "durability": "volatile", "history": "unknown", "depth": 0}
        for kind in ("publisher", "subscription")
    ],
}  # fmt: skip


def test_the_graph_stage_passes_on_the_node_its_topic_type_and_both_endpoints() -> None:
    text = "some rclpy warning\n" + json.dumps(SEEN) + "\n"
    stage = graph.stage(text, "micro_ros_agent")
    assert stage.result == "pass" and stage.name == "graph"
    assert stage.detail == (
        "node /uros_probe, topic /uros_probe [std_msgs/msg/Int32] publisher and subscription "
        "(reliable volatile depth 0), seen after 0.12 s"
    )


def test_the_graph_stage_names_the_plain_agent_when_nothing_was_seen() -> None:
    stage = graph.stage('{"graph": "none", "after": 30.0}\n', "MicroXRCEAgent")
    assert stage.result == "fail"
    assert "the agent is MicroXRCEAgent, which has no graph manager" in stage.detail
    assert "uros agent build" in stage.detail
    assert "saw no node" in graph.stage("", "micro_ros_agent").detail


def test_the_graph_stage_fails_on_another_node_or_a_missing_endpoint() -> None:
    other = {**SEEN, "nodes": [{"name": "talker", "namespace": "/"}]}
    assert "(it has //talker)" in graph.stage(json.dumps(other), "micro_ros_agent").detail
    half = {**SEEN, "endpoints": SEEN["endpoints"][:1]}
    assert "lacks its publisher or subscription" in graph.stage(json.dumps(half), "micro_ros_agent").detail
    wrong = {**SEEN, "endpoints": [{**e, "type": "std_msgs/msg/String"} for e in SEEN["endpoints"]]}
    assert graph.stage(json.dumps(wrong), "micro_ros_agent").result == "fail"


def test_which_agent_a_program_is() -> None:
    built = builtagent.BuiltAgent(Path("/c/a"), "micro_ros_agent", "", "humble", {}, "v", 1.0)
    assert builtagent.program_name("/c/a/bin/uros-agent", built) == "micro_ros_agent"
    assert builtagent.program_name("/x/MicroXRCEAgent", built) == "MicroXRCEAgent"
    assert builtagent.program_name("/x/MicroXRCEAgent", None) == "MicroXRCEAgent"
    assert builtagent.program_path(Path("/c/a"), "micro_ros_agent") == Path(
        "/c/a/lib/micro_ros_agent/micro_ros_agent"
    )
