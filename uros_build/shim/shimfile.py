"""The ``uros-python`` shim's file, as uros writes it for a target's builds (steps/colcon_setup.py):
what it is written for (:class:`Shim`) and its text. Apart from pyshim.py, which the shim imports on
every call it sends to uros: this runs once per build, in uros's own process."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from uros_build import templating
from uros_build.shim import gencache, pyshim


@dataclass(frozen=True)
class Shim:
    """What a target's shim is written for."""

    python: str  # the real interpreter
    cache_dir: Path  # the user's caches' folder ($UROS_GEN_CACHE_DIR, else ~/.cache/uros/gen)
    target_dir: Path  # the target's folder (or the host stage's): its run log
    workspace: Path
    code_dir: Path  # the folder holding uros_build, appended to the path of uros's calls
    written_by: str  # "uros 1.2 build"
    modules: Mapping[str, str]  # gencache.module_versions() of ``python``, found once by uros
    stdlib_distutils: bool  # ``python`` has a distutils of its own (before 3.12)
    # what ``python`` wrote for each of pyshim.FINDPYTHON_QUESTIONS (pyshim.parse_answers)
    answers: Mapping[str, str] = field(default_factory=dict)


def shim_text(shim: Shim) -> str:
    """The ``Python3_EXECUTABLE`` of a target's CMake builds (templates/uros-python.sh.j2)."""
    given = dict(shim.answers)
    return templating.render(
        "uros-python.sh.j2",
        written_by=shim.written_by,
        python=shim.python,
        # Compiled modules kept in the cache's folder, even where PYTHONDONTWRITEBYTECODE is set
        # (it is, on some CI images): else every call compiles uros's cache modules (and a miss
        # rosidl's, empy's and lark's) again, ~20 ms per call; no .pyc lands beside anyone's
        # sources. https://docs.python.org/3/using/cmdline.html#cmdoption-X (pycache_prefix)
        pycache=str(shim.cache_dir / "pycache"),
        entry=(
            f"import sys; sys.path.append({str(shim.code_dir)!r}); "
            "from uros_build.shim.pyshim import main; sys.exit(main(sys.argv[1:]))"
        ),
        folders=[str(p) for p in (shim.cache_dir, shim.target_dir, shim.workspace)],
        versions=json.dumps(dict(shim.modules), sort_keys=True),
        repair=(
            f"import sys; sys.path.append({str(shim.code_dir)!r}); "
            "from uros_build.shim.pyshim import drop_unloadable; "
            "sys.exit(0 if drop_unloadable(sys.argv[1]) else 1)"
        ),
        answers=[(code, text) for code, text in sorted(given.items()) if code in pyshim.FINDPYTHON_QUESTIONS],
        version_flag=pyshim.VERSION_FLAG,
        version_answer=given.get(pyshim.VERSION_FLAG),
        arguments_flag=gencache.ARGUMENTS_FLAG,
        stdlib_distutils=shim.stdlib_distutils,
        findpython_probe=pyshim.FINDPYTHON_PROBE,
    )
