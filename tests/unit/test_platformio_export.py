"""Issue 33, item 1: the PlatformIO export's extra script, run here on a stand-in for PlatformIO's
SCons environment (tests/integration/test_platformio.py runs it in a real `pio run`)."""

from __future__ import annotations

import json
from typing import Any

import pytest

from uros_build.output.exports import platformio

_M7 = ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard")


class _Exit(Exception):
    pass


class _Env(dict[str, Any]):
    """What the script uses of a SCons environment (with SCons' method names)."""

    def Flatten(self, items: Any) -> list[str]:
        if isinstance(items, (list, tuple)):
            return [flat for item in items for flat in self.Flatten(item)]
        return [items]

    def Append(self, **scopes: list[str]) -> None:
        for scope, values in scopes.items():
            self[scope] = [*self.get(scope, []), *values]

    def Exit(self, code: int) -> None:
        raise _Exit(code)


def _run(cpu: tuple[str, ...], env: _Env, capsys: pytest.CaptureFixture[str]) -> str:
    script = platformio.platformio_files("cortex-m7", cpu)[platformio.PLATFORMIO_SCRIPT]
    exec(compile(script, platformio.PLATFORMIO_SCRIPT, "exec"), {"Import": lambda name: None, "env": env})
    return capsys.readouterr().err


def test_the_manifest_names_the_script() -> None:
    files = platformio.platformio_files("cortex-m7", _M7)
    build = json.loads(files[platformio.PLATFORMIO_FILE])["build"]
    assert build["extraScript"] == platformio.PLATFORMIO_SCRIPT and build["flags"] == ["-L.", "-lmicroros"]
    assert platformio.platformio_build_flags(_M7) == "build_flags = " + " ".join(_M7)


def test_the_link_gets_the_flags_it_lacks(capsys: pytest.CaptureFixture[str]) -> None:
    """The board gives -mcpu and -mthumb to compile and link, build_flags the FPU flags to compile."""
    env = _Env(CCFLAGS=["-mcpu=cortex-m7", "-mthumb", "-Os", "-mfpu=fpv5-d16", "-mfloat-abi=hard"])
    env["LINKFLAGS"] = ["-mcpu=cortex-m7", "-mthumb"]
    assert _run(_M7, env, capsys) == ""
    assert env["LINKFLAGS"] == ["-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard"]


@pytest.mark.parametrize(
    ("ccflags", "linkflags", "said"),
    [
        (["-mcpu=cortex-m7", "-mthumb"], [], "compiles without -mfloat-abi, without -mfpu"),
        (
            ["-mcpu=cortex-m4", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard"],
            [],
            "compiles with -mcpu=cortex-m4, with -mfpu=fpv4-sp-d16",
        ),
        (
            ["-mcpu=cortex-m7", "-mfpu=fpv5-d16", "-mfloat-abi=hard"],
            ["-mfloat-abi=softfp"],
            "links with -mfloat-abi=softfp",
        ),
    ],
)
def test_another_abi_stops_with_one_line(
    ccflags: list[str], linkflags: list[str], said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    env = _Env(CCFLAGS=ccflags, LINKFLAGS=linkflags)
    with pytest.raises(_Exit):
        _run(_M7, env, capsys)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"this firmware {said}: add to platformio.ini `build_flags = " in err, err


def test_a_soft_float_library_asks_for_no_fpu(capsys: pytest.CaptureFixture[str]) -> None:
    env = _Env(CCFLAGS=["-mcpu=cortex-m3", "-mthumb"], LINKFLAGS=["-mcpu=cortex-m3", "-mthumb"])
    assert _run(("-mcpu=cortex-m3", "-mthumb"), env, capsys) == ""
    assert env["LINKFLAGS"] == ["-mcpu=cortex-m3", "-mthumb"]


@pytest.mark.parametrize("value", ['x"\nimport os; os.system("id")\n"', "back\\slash 'q' \u00e9\t\x00"])
def test_values_stay_data_in_the_script(value: str) -> None:
    """A hostile target or flag ends no string in the script: it reads back as the same value."""
    script = platformio.platformio_files(value, ("-mcpu=" + value, value))[platformio.PLATFORMIO_SCRIPT]
    names: dict[str, Any] = {}
    code = script.split('Import("env")', 1)[1].split("\n\n\ndef ", 1)[0]  # the constants only
    exec(compile(code, platformio.PLATFORMIO_SCRIPT, "exec"), names)
    assert names["TARGET"] == value and names["CPU_FLAGS"] == ["-mcpu=" + value, value]
    assert names["ABI"] == {"mcpu": value}
