"""The environment's switches reach the steps through the plan (plan_build reads them once, through
the settings table), and the plan keeps every setting with who chose it for `uros build -v`."""

from __future__ import annotations

from pathlib import Path

from uros_build.config.buildargs import BuildArgs
from uros_build.config.plan import plan_build


def _ws(tmp_path: Path) -> Path:
    pkg = tmp_path / "ws" / "pkg"
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text("<package><name>pkg</name></package>", encoding="utf-8")
    return tmp_path / "ws"


def test_the_switches_are_plan_fields(tmp_path: Path) -> None:
    args = BuildArgs(workspace=_ws(tmp_path), toolchain="cortex-m7", cache="file:///team")
    on = plan_build(args, {"XDG_CACHE_HOME": str(tmp_path / "xdg")})
    assert (on.host_stage, on.compiler_seed, on.gen_cache) == (True, True, True)
    assert on.gen_cache_dir == tmp_path / "xdg" / "uros" / "gen"
    assert on.cache is not None and on.cache.timeout == 60.0
    env = {
        "UROS_HOST_STAGE": "off",
        "UROS_COMPILER_SEED": "OFF",
        "UROS_GEN_CACHE": "off",
        "UROS_GEN_CACHE_DIR": str(tmp_path / "mine"),
        "UROS_CACHE_TIMEOUT": "5",
    }
    off = plan_build(args, env)
    assert (off.host_stage, off.compiler_seed, off.gen_cache) == (False, False, False)
    assert off.gen_cache_dir == tmp_path / "mine"
    assert off.cache is not None and off.cache.timeout == 5.0


def test_the_plan_says_each_setting_and_who_chose_it(tmp_path: Path) -> None:
    ws = _ws(tmp_path)
    (ws / "uros.yaml").write_text("distro: humble\ntransport: udp\ntarget: cortex-m7\n", encoding="utf-8")
    args = BuildArgs(workspace=ws, toolchain="cortex-m7", toolchain_from=f"{ws}/uros.yaml: target", jobs=2)
    lines = plan_build(args, {"UROS_HOST_STAGE": "off"}).settings.lines()
    assert f"toolchains = cortex-m7  ({ws}/uros.yaml: target)" in lines
    assert f"transport = udp  ({ws}/uros.yaml: transport)" in lines
    assert "jobs = 2  (-j/--jobs)" in lines
    assert "host_stage = off  ($UROS_HOST_STAGE)" in lines
    assert f"output = {(ws / 'build' / 'cortex-m7').resolve()}  (default)" in lines  # the folder itself
    assert "preset = default  (default)" in lines
    assert f"distro = humble  ({ws}/uros.yaml: distro)" in lines
