"""The configure call cache (issue 19, item 1) with stand-in scripts laid out as ament_cmake_core
and rosidl_adapter install theirs: a call is answered from the cache only when the files it reads,
the environment it reads and the Python code it imported are what they were; the answer is written
where the call writes it, with the target's own folder where the call would name it. (The calls
run in-process through runpy: no process is started.)"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from uros_build.shim import callcache, gencache, pyshim

PACKAGE_XML_2_CMAKE = """
import os, pathlib, sys
import uros_fake_catkin
xml, out = sys.argv[1], sys.argv[2]
text = pathlib.Path(xml).read_text()
counter = pathlib.Path(os.environ["CALL_COUNTER"])
counter.write_text(counter.read_text() + "x")
pathlib.Path(out).write_text(f"set(NAME {uros_fake_catkin.name(text)}) # {os.environ.get('ROS_VERSION')}\\n")
"""

ADAPTER = """
import argparse, json, os, pathlib
p = argparse.ArgumentParser()
for flag in ("--package-name", "--arguments-file", "--output-dir", "--output-file"):
    p.add_argument(flag, required=True)
a = p.parse_args()
counter = pathlib.Path(os.environ["CALL_COUNTER"])
counter.write_text(counter.read_text() + "a")
out = pathlib.Path(a.output_dir)
lines = []
for t in json.loads(pathlib.Path(a.arguments_file).read_text())["non_idl_tuples"]:
    base, _, rel = t.rpartition(":")
    idl = out / rel.replace(".msg", ".idl")
    idl.parent.mkdir(parents=True, exist_ok=True)
    idl.write_text("struct " + pathlib.Path(base, rel).read_text())
    lines.append(f"{out}:{rel.replace('.msg', '.idl')}")
pathlib.Path(a.output_file).write_text("\\n".join(lines) + "\\n")
"""


XML = '<package><name>std_msgs</name><depend condition="$ROS_VERSION == 2">x</depend>'


@pytest.fixture
def setup(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A workspace with ament_cmake_core's script in dev_ws, a stand-in catkin_pkg module and a
    rosidl_adapter package on the path; returns the workspace."""
    ws = tmp_path / "ws"
    core = ws / "dev_ws/install/share/ament_cmake_core/cmake/core"
    core.mkdir(parents=True)
    (core / "package_xml_2_cmake.py").write_text(PACKAGE_XML_2_CMAKE)
    site = ws / "dev_ws/install/lib/python3.11/site-packages"
    (site / "rosidl_adapter").mkdir(parents=True)
    (site / "rosidl_adapter" / "__init__.py").write_text("")
    (site / "rosidl_adapter" / "__main__.py").write_text(ADAPTER)
    (site / "uros_fake_catkin.py").write_text(
        "def name(text):\n    return text.split('<name>')[1].split('<')[0]\n"
    )
    # as in the shim's process: sys.path[0] is '' (python -c), then PYTHONPATH's folders
    monkeypatch.setattr(sys, "path", [sys.path[0], str(site), *sys.path[1:]])
    for name in ("uros_fake_catkin", "rosidl_adapter", "rosidl_adapter.__main__"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    counter = tmp_path / "calls"
    counter.write_text("")
    monkeypatch.setenv("CALL_COUNTER", str(counter))
    monkeypatch.setenv("ROS_VERSION", "2")
    pkg = ws / "mcu_ws" / "std_msgs"
    (pkg / "msg").mkdir(parents=True)
    (pkg / "package.xml").write_text(
        '<package><name>std_msgs</name><depend condition="$ROS_VERSION == 2">x</depend>'
    )
    (pkg / "msg" / "Bool.msg").write_text("bool data")
    return ws


def _xml_call(ws: Path, target: str) -> tuple[list[str], Path]:
    script = ws / "dev_ws/install/share/ament_cmake_core/cmake/core/package_xml_2_cmake.py"
    out = ws / ".uros/targets" / target / "build/std_msgs/ament_cmake_core/package.cmake"
    return [str(script), str(ws / "mcu_ws/std_msgs/package.xml"), str(out)], out


def test_package_xml_answered_once_for_every_target(setup: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    ws, cache = setup, setup / ".uros/gen-cache/calls"
    counter = Path(str(ws.parent / "calls"))
    argv7, out7 = _xml_call(ws, "cortex-m7")
    argv4, out4 = _xml_call(ws, "cortex-m4f")
    call = callcache.recognise(argv7)
    assert call is not None and call.env == ("ROS_VERSION",)  # read from the package.xml's conditions

    assert callcache.run(argv7, cache, ws / ".uros/targets/cortex-m7", ws) == "miss"
    assert callcache.run(argv4, cache, ws / ".uros/targets/cortex-m4f", ws) == "hit"
    assert counter.read_text() == "x"
    assert out4.read_text() == out7.read_text() == "set(NAME std_msgs) # 2\n"

    # what it reads: the package.xml, the variables its conditions name, the code it imported
    (ws / "mcu_ws/std_msgs/package.xml").write_text("<package><name>std_msgs2</name>")
    assert callcache.run(argv4, cache, ws / ".uros/targets/cortex-m4f", ws) == "miss"
    assert out4.read_text() == "set(NAME std_msgs2) # 2\n"
    (ws / "mcu_ws/std_msgs/package.xml").write_text(XML)  # as it was: the first answer again
    assert callcache.run(argv4, cache, ws / ".uros/targets/cortex-m4f", ws) == "hit"
    monkeypatch.setenv("ROS_VERSION", "1")
    assert callcache.run(argv4, cache, ws / ".uros/targets/cortex-m4f", ws) == "miss"
    assert out4.read_text() == "set(NAME std_msgs) # 1\n"
    site = ws / "dev_ws/install/lib/python3.11/site-packages"
    (site / "uros_fake_catkin.py").write_text("def name(text):\n    return 'other'\n")
    monkeypatch.delitem(sys.modules, "uros_fake_catkin")
    assert callcache.run(argv4, cache, ws / ".uros/targets/cortex-m4f", ws) == "miss"
    assert out4.read_text() == "set(NAME other) # 1\n"
    assert counter.read_text() == "xxxx"


def test_a_module_shadowed_by_a_new_one_is_a_miss(
    setup: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    ws, cache = setup, setup / ".uros/gen-cache/calls"
    argv, _ = _xml_call(ws, "cortex-m7")
    assert callcache.run(argv, cache, ws / ".uros/targets/cortex-m7", ws) == "miss"
    earlier = tmp_path / "earlier"
    earlier.mkdir()
    monkeypatch.setattr(sys, "path", [sys.path[0], str(earlier), *sys.path[1:]])
    assert callcache.run(argv, cache, ws / ".uros/targets/cortex-m7", ws) == "miss"  # another search path
    assert callcache.run(argv, cache, ws / ".uros/targets/cortex-m7", ws) == "hit"
    (earlier / "uros_fake_catkin.py").write_text("def name(text):\n    return 'shadow'\n")
    monkeypatch.delitem(sys.modules, "uros_fake_catkin")
    assert callcache.run(argv, cache, ws / ".uros/targets/cortex-m7", ws) == "miss"


def _adapter_call(ws: Path, target: str) -> tuple[list[str], Path]:
    build = ws / ".uros/targets" / target / "build/std_msgs"
    build.mkdir(parents=True, exist_ok=True)
    arguments = build / "rosidl_adapter__arguments__std_msgs.json"
    arguments.write_text(
        json.dumps({"package_name": "std_msgs", "non_idl_tuples": [f"{ws}/mcu_ws/std_msgs:msg/Bool.msg"]})
    )
    argv = ["-m", "rosidl_adapter", "--package-name", "std_msgs", "--arguments-file", str(arguments),
            "--output-dir", str(build / "rosidl_adapter/std_msgs"), "--output-file", str(build / "rosidl_adapter/std_msgs.idls")]  # fmt: skip
    return argv, build


def test_rosidl_adapter_answers_with_each_targets_own_folder(setup: Path) -> None:
    ws, cache = setup, setup / ".uros/gen-cache/calls"
    counter = ws.parent / "calls"
    argv7, b7 = _adapter_call(ws, "cortex-m7")
    argv4, b4 = _adapter_call(ws, "cortex-m4f")
    assert callcache.run(argv7, cache, ws / ".uros/targets/cortex-m7", ws) == "miss"
    assert callcache.run(argv4, cache, ws / ".uros/targets/cortex-m4f", ws) == "hit"
    assert counter.read_text() == "a"
    for build in (b7, b4):  # as the adapter itself writes it: this target's folder
        assert (
            build / "rosidl_adapter/std_msgs.idls"
        ).read_text() == f"{build}/rosidl_adapter/std_msgs:msg/Bool.idl\n"
        assert (build / "rosidl_adapter/std_msgs/msg/Bool.idl").read_text() == "struct bool data"
    before = (b4 / "rosidl_adapter/std_msgs/msg/Bool.idl").stat().st_mtime_ns
    assert callcache.run(argv4, cache, ws / ".uros/targets/cortex-m4f", ws) == "hit"
    assert (b4 / "rosidl_adapter/std_msgs/msg/Bool.idl").stat().st_mtime_ns == before  # content already there
    (ws / "mcu_ws/std_msgs/msg/Bool.msg").write_text("int8 data")
    assert callcache.run(argv4, cache, ws / ".uros/targets/cortex-m4f", ws) == "miss"
    assert (b4 / "rosidl_adapter/std_msgs/msg/Bool.idl").read_text() == "struct int8 data"


def test_condition_variables_are_what_the_rep_149_pattern_finds() -> None:
    import re

    pattern = re.compile(r"\$\{?([A-Za-z_][A-Za-z0-9_]*)")
    for text in (
        XML,
        '<depend condition="$ROS_VERSION == 2 and ${ROS_DISTRO} != humble">x</depend>',
        "$1 $_a1 ${B} ${ $ $$C $é $Dé x$E_F9-g",
        "",
        "$",
        "${",
    ):
        assert callcache.condition_variables(text) == tuple(sorted(set(pattern.findall(text)))), text


def test_a_hit_imports_neither_json_nor_re() -> None:
    """What a hit imports is most of its cost (gencache.py): the modules the shim imports on every
    call import neither at their top."""
    import ast

    for module in (gencache, callcache, pyshim):
        tree = ast.parse(Path(str(module.__file__)).read_text())
        top = {
            alias.name.split(".")[0]
            for node in tree.body
            if isinstance(node, ast.Import | ast.ImportFrom)
            for alias in (node.names if isinstance(node, ast.Import) else [ast.alias(node.module or "")])
        }
        assert not top & {"json", "re", "dataclasses", "pathlib", "typing", "tempfile"}, module.__name__


def test_other_calls_are_not_recognised() -> None:
    assert callcache.recognise(["-c", "import sys"]) is None
    assert callcache.recognise(["-m", "rosidl_adapter", "--package-name", "x"]) is None
    assert callcache.recognise(["/x/templates_2_cmake.py", "out"]) is None  # not ament's
    assert callcache.recognise(["/a/package_templates/templates_2_cmake.py", "o"]) is not None


def test_the_code_checked_is_the_targets_own_copy(setup: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A call imports modules from the target's own install tree (rosidl_adapter is built for each
    target): the second target's hit is checked against its own copy, not the first target's."""
    ws, cache = setup, setup / ".uros/gen-cache/calls"
    core = ws / "dev_ws/install/share/ament_cmake_core/cmake/core"
    (core / "package_xml_2_cmake.py").write_text(
        PACKAGE_XML_2_CMAKE.replace("uros_fake_catkin", "uros_fake_own")
    )
    base = list(sys.path)

    def call(target: str, code: str) -> str:
        site = ws / ".uros/targets" / target / "install/lib/python3.11/site-packages"
        site.mkdir(parents=True, exist_ok=True)
        (site / "uros_fake_own.py").write_text(code)
        monkeypatch.setattr(sys, "path", [base[0], str(site), *base[1:]])
        monkeypatch.delitem(sys.modules, "uros_fake_own", raising=False)
        argv, _ = _xml_call(ws, target)
        return callcache.run(argv, cache, ws / ".uros/targets" / target, ws)

    same = "def name(text):\n    return 'own'\n"
    assert call("cortex-m7", same) == "miss"
    assert call("cortex-m4f", same) == "hit"
    assert call("cortex-m3", same.replace("own", "changed")) == "miss"


TEMPLATES_2_CMAKE = """
import os, pathlib, sys
counter = pathlib.Path(os.environ["CALL_COUNTER"])
counter.write_text(counter.read_text() + "t")
here = pathlib.Path(__file__).resolve().parent
pathlib.Path(sys.argv[1]).write_text(f'set(HOOK "{here}/hook.sh")\\n')
"""


def test_another_workspace_gets_the_answer_with_its_own_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ament's templates answer names files in the workspace's dev_ws: a second checkout hits the
    user's cache and gets its own folder in the answer, as the script would have written it."""
    monkeypatch.setenv("CALL_COUNTER", str(tmp_path / "calls"))
    (tmp_path / "calls").write_text("")
    cache = tmp_path / "user-cache"
    outs = []
    for name in ("ws1", "checkout two"):
        ws = tmp_path / name
        script = ws / "dev_ws/install/share/ament_cmake_core/cmake/package_templates/templates_2_cmake.py"
        script.parent.mkdir(parents=True)
        script.write_text(TEMPLATES_2_CMAKE)
        out = ws / ".uros/targets/cortex-m7/build/std_msgs/ament_cmake_package_templates/templates.cmake"
        result = callcache.run([str(script), str(out)], cache, ws / ".uros/targets/cortex-m7", ws)
        outs.append((result, out.read_text()))
    assert outs[0] == (
        "miss",
        f'set(HOOK "{tmp_path}/ws1/dev_ws/install/share/ament_cmake_core/cmake/package_templates/hook.sh")\n',
    )
    assert outs[1] == ("hit", outs[0][1].replace("/ws1/", "/checkout two/"))
    assert (tmp_path / "calls").read_text() == "t"


def test_rosidl_adapter_in_another_checkout_hits(
    setup: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The adapter's arguments file names the .msg files by absolute path: a second checkout of
    the same sources (another folder) asks the same question and gets its own folders back."""
    import shutil

    cache = tmp_path / "user-cache"
    other = tmp_path / "checkout two"
    shutil.copytree(setup, other)
    base = [p for p in sys.path if not p.startswith(str(setup))]
    results = []
    for ws in (setup, other):
        site = ws / "dev_ws/install/lib/python3.11/site-packages"  # this checkout's PYTHONPATH
        monkeypatch.setattr(sys, "path", [base[0], str(site), *base[1:]])
        for name in ("rosidl_adapter", "rosidl_adapter.__main__"):
            monkeypatch.delitem(sys.modules, name, raising=False)
        argv, build = _adapter_call(ws, "cortex-m7")
        results.append(callcache.run(argv, cache, ws / ".uros/targets/cortex-m7", ws))
        idls = (build / "rosidl_adapter/std_msgs.idls").read_text()
        assert idls == f"{build}/rosidl_adapter/std_msgs:msg/Bool.idl\n"
    assert results == ["miss", "hit"]
