"""The Python calls of a package's CMake configure, once per workspace (issue 19, item 1).

Each of the ~60 configures of a micro-ROS build starts Python for the same few questions:
ament_cmake_core's ``templates_2_cmake.py`` (what ament_package's templates are: the same answer
for every package), ``package_xml_2_cmake.py`` (the package.xml as CMake variables) and, in an
interface package, ``python -m rosidl_adapter`` (.msg/.srv to .idl). Each is a function of the
files it reads and the Python code it runs, never of the target, and costs 0.1-0.2 s, mostly
importing (catkin_pkg, empy). Measured on real Humble: about a third of a package's configure.

A call's key is made in two steps, as ccache's direct mode does: the first from its command line
(outputs and the target's folder taken out), the content of the files it reads, the environment
it reads and the interpreter's search path; under that key a manifest lists the Python files the
call imported when it ran (and, for rosidl_adapter, the .msg files its arguments file names: a
hit reads no JSON), and the second key adds their content. A miss runs the call in this
process (runpy) with its outputs in an empty folder and keeps exactly what it wrote; a hit writes
it where the call would have (a file whose content is already there is left alone). An output
that names the target's folder is never kept, except the rosidl_adapter list, whose folder is
put back as the call would have written it.

Sources:
https://github.com/ament/ament_cmake/blob/humble/ament_cmake_core/cmake/ament_cmake_package_templates-extras.cmake,
https://github.com/ament/ament_cmake/blob/humble/ament_cmake_core/cmake/core/ament_package_xml.cmake,
https://github.com/ros2/rosidl/blob/humble/rosidl_adapter/cmake/rosidl_adapt_interfaces.cmake.
"""

from __future__ import annotations

# Imported on every configure call: only what a hit needs (gencache.py says why: no json, no re).
import hashlib
import os
import sys

from uros_build.files import write_atomic
from uros_build.shim import gencache

TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping, Sequence

    from uros_build.shim.gencache import StrPath

FORMAT = 4  # 4: entries and manifests carry sha256 (3: no JSON, the adapter's .msg files listed)
OUT = "<out>"  # the scratch folder of a miss, in a kept output


class Call:
    """A recognised configure call: what it reads and writes. ``outputs``: the name of each output
    in a cache entry and where the call writes it (a folder for rosidl_adapter's .idl files).
    A plain class, not a dataclass: importing dataclasses costs a hit a third of its time."""

    __slots__ = ("argv", "env", "kind", "outputs", "reads")

    def __init__(
        self,
        kind: str,
        argv: tuple[str, ...],  # as CMake runs it (without the interpreter)
        reads: tuple[str, ...],  # files whose content the answer depends on
        env: tuple[str, ...],  # environment variables it reads
        outputs: tuple[tuple[str, str], ...],
    ) -> None:
        self.kind, self.argv, self.reads, self.env, self.outputs = kind, argv, reads, env, outputs


def _flags(argv: Sequence[str]) -> dict[str, str] | None:
    """``--name value`` pairs; None when anything else is there."""
    if len(argv) % 2:
        return None
    pairs = dict(zip(argv[::2], argv[1::2], strict=True))
    return pairs if all(k.startswith("--") for k in pairs) else None


def condition_variables(text: str) -> tuple[str, ...]:
    """The environment variables package.xml conditions name (REP 149: ``$NAME``, also
    ``${NAME}``), what ``\\$\\{?([A-Za-z_][A-Za-z0-9_]*)`` finds, sorted; without re (a hit does
    not import it)."""
    names = set()
    at = text.find("$")
    while at >= 0:
        start = at + 2 if text.startswith("${", at) else at + 1
        end = start
        while end < len(text) and text[end].isascii() and (text[end].isalnum() or text[end] == "_"):
            end += 1
        if end > start and not text[start].isdigit():
            names.add(text[start:end])
        at = text.find("$", at + 1)
    return tuple(sorted(names))


def recognise(argv: Sequence[str]) -> Call | None:
    """The call CMake asked for, when it is one of the three; else None (the real interpreter runs)."""
    if len(argv) == 2 and argv[0].endswith("/package_templates/templates_2_cmake.py"):
        return Call("templates", tuple(argv), (argv[0],), (), (("out", argv[1]),))
    if len(argv) == 3 and argv[0].endswith("/core/package_xml_2_cmake.py"):
        try:
            with open(argv[1], encoding="utf-8", errors="replace") as f:
                text = f.read()
        except OSError:
            return None
        return Call(
            "package_xml", tuple(argv), (argv[0], argv[1]), condition_variables(text), (("out", argv[2]),)
        )
    if argv[:2] == ["-m", "rosidl_adapter"]:
        flags = _flags(argv[2:])
        if flags is None or set(flags) != {
            "--package-name",
            "--arguments-file",
            "--output-dir",
            "--output-file",
        }:
            return None
        outputs = (("idl", flags["--output-dir"]), ("list", flags["--output-file"]))
        return Call("rosidl_adapter", tuple(argv), (flags["--arguments-file"],), (), outputs)
    return None


def named_inputs(call: Call) -> list[str] | None:
    """The files a call's arguments file names (rosidl_adapter's .msg/.srv/.action files): read at
    a miss, listed in the manifest, their content in the second key. None when the arguments
    file does not say (the call then runs as CMake asked)."""
    if call.kind != "rosidl_adapter":
        return []
    import json

    try:
        with open(call.reads[0], encoding="utf-8") as f:
            arguments = json.loads(f.read())
        return sorted({os.path.join(*str(t).rsplit(":", 1)) for t in arguments["non_idl_tuples"]})
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _scratch_argv(call: Call, scratch: str) -> list[str]:
    """The call's command line with each output moved into ``scratch``."""
    where = {path: os.path.join(scratch, name) for name, path in call.outputs}
    return [where.get(a, a) for a in call.argv]


def _content(path: str, top: str, ws: str) -> str:
    """The sha256 of a file the call reads, the target's and the workspace's folders taken out of
    it (rosidl_adapter's arguments file lists the .msg files by absolute path: another checkout
    of the same sources asks the same question)."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError:
        return "missing"
    data = data.replace(top.encode(), gencache.PLACEHOLDER.encode())
    data = data.replace(os.path.join(ws, "").encode(), f"{gencache.WORKSPACE}/".encode())
    return hashlib.sha256(data).hexdigest()


def _first_key(call: Call, target_dir: StrPath, workspace: StrPath) -> str:
    top, ws = os.fspath(target_dir), os.fspath(workspace)
    outputs = {path for _, path in call.outputs}
    return gencache.key_of(
        "configure call",
        FORMAT,
        call.kind,
        tuple(OUT if a in outputs else gencache.normal(a, top, ws) for a in call.argv),
        tuple((gencache.normal(p, top, ws), _content(p, top, ws)) for p in call.reads),
        tuple((name, os.environ.get(name)) for name in call.env),
        tuple(gencache.normal(p, top, ws) for p in sys.path[1:]),  # [0] is the shim's
        tuple(sys.version_info[:3]),
    )


def _shadowed(path: str) -> bool:
    """Whether a folder before the one ``path`` was imported from now holds a module of the same
    top-level name (a package installed meanwhile would be imported instead)."""
    for i, folder in enumerate(sys.path[1:], start=1):
        if folder and path.startswith(os.path.join(os.path.abspath(folder), "")):
            top = os.path.relpath(path, os.path.abspath(folder)).split(os.sep)[0].removesuffix(".py")
            return any(
                os.path.exists(os.path.join(earlier, top))
                or os.path.exists(os.path.join(earlier, f"{top}.py"))
                for earlier in sys.path[1:i]
                if earlier
            )
    return False


def _second_key(first: str, code: Sequence[str], target_dir: StrPath, workspace: StrPath) -> str:
    """``first`` with the content of the Python files the call imported, found in this target's
    own folders (a module another folder now shadows makes a key no entry has)."""
    h = hashlib.sha256(first.encode())
    for path in code:
        name = gencache.normal(path, os.fspath(target_dir), os.fspath(workspace))
        h.update(f"\0{name}\0{gencache.sha(path)}\0{_shadowed(path)}".encode())
    return h.hexdigest()


def _folders(paths: Iterable[str]) -> tuple[str, ...]:
    return tuple(os.path.join(os.path.abspath(p), "") for p in paths)


def _module_files() -> list[str]:
    """The files of the modules loaded now, but the standard library's (the interpreter's version
    is in the key) and uros_build's own (the cache's code, not the call's). In a virtual
    environment, site-packages sits inside platstdlib: what is there counts."""
    import site
    import sysconfig

    paths = sysconfig.get_paths()
    stdlib = _folders([paths["stdlib"], paths["platstdlib"]])
    installed = _folders([paths["purelib"], paths["platlib"], *site.getsitepackages()])
    # uros_build as a whole (this file sits in uros_build/shim/): the package, not only this folder
    own = _folders([os.path.dirname(os.path.dirname(os.path.abspath(__file__)))])
    files = set()
    for module in list(sys.modules.values()):
        path = getattr(module, "__file__", None)
        if not isinstance(path, str) or not os.path.isfile(path):
            continue
        path = os.path.abspath(path)
        if path.startswith(own) or (path.startswith(stdlib) and not path.startswith(installed)):
            continue
        files.add(path)
    return sorted(files)


def _restore(files: Mapping[str, bytes], call: Call, workspace: StrPath) -> None:
    """Write an entry's files where the call writes them, each output's own path put back where
    the call named it (rosidl_adapter's list names its .idl folder), and this workspace's folder
    where the answer named its workspace's (ament's templates live in dev_ws)."""

    def put_back(data: bytes) -> bytes:
        for name, path in call.outputs:
            data = data.replace(f"{OUT}/{name}".encode(), path.encode())
        return data.replace(
            f"{gencache.WORKSPACE}/".encode(), os.path.join(os.fspath(workspace), "").encode()
        )

    for name, path in call.outputs:
        if name == "idl":
            idl = {k.removeprefix("idl/"): put_back(v) for k, v in files.items() if k.startswith("idl/")}
            gencache.write_changed(idl, path)
        else:
            folder, base = os.path.split(path)
            gencache.write_changed({base: put_back(files[name])}, folder)


def run(argv: Sequence[str], cache_dir: StrPath, target_dir: StrPath, workspace: StrPath) -> str:
    """One configure call through the cache: "hit", "miss" or "bypass" (run as CMake asked)."""
    call = recognise(argv)
    if call is None:
        gencache.run_python(argv)
        return "bypass"
    top, ws = os.fspath(target_dir), os.fspath(workspace)
    first = _first_key(call, top, ws)
    manifest = os.path.join(cache_dir, first[:2], f"{first}.code")
    try:
        with open(manifest, "rb") as f:
            listed = gencache.unseal(f.read()).decode("utf-8").split("\n")
        code = [gencache.expand(p, top, ws) for p in listed if p]
        with open(
            os.path.join(cache_dir, first[:2], f"{_second_key(first, code, top, ws)}.entry"), "rb"
        ) as f:
            files: dict[str, bytes] | None = gencache.unpack_files(f.read())
    except (OSError, ValueError):
        files = None
    if files is not None and {name for name, _ in call.outputs if name != "idl"} <= set(files):
        _restore(files, call, ws)
        return "hit"
    import tempfile

    inputs = named_inputs(call)
    if inputs is None:
        gencache.run_python(argv)
        return "bypass"
    with tempfile.TemporaryDirectory(prefix="uros-call-") as tmp:
        try:
            gencache.run_python(_scratch_argv(call, tmp))
        except BaseException:
            # fails as CMake asked it, naming its own files (or succeeds: then it is done)
            gencache.run_python(argv)
            return "bypass"
        code = [*_module_files(), *inputs]
        files = {k: v.replace(tmp.encode(), OUT.encode()) for k, v in gencache.read_folder(tmp).items()}
    if any(top.encode() in v for v in files.values()):
        # an answer that names the target's own folder is not the same for every target
        gencache.run_python(argv)
        return "bypass"
    ws_bytes = os.path.join(ws, "").encode()
    files = {k: v.replace(ws_bytes, f"{gencache.WORKSPACE}/".encode()) for k, v in files.items()}
    try:
        listing = [gencache.normal(p, top, ws) for p in code]
        if any("\n" in p for p in listing):
            raise ValueError("a path with a line break")
        entry = os.path.join(cache_dir, first[:2], f"{_second_key(first, code, top, ws)}.entry")
        write_atomic(entry, gencache.pack(files))
        write_atomic(manifest, gencache.seal("\n".join(listing).encode()))
    except (OSError, ValueError):
        pass  # not kept: the next configure asks again
    _restore(files, call, ws)
    return "miss"
