"""Interface code generation once per workspace, not once per target (issue 19, item 1).

rosidl's generators (``rosidl_generator_c``, ``rosidl_typesupport_c``, ``..._introspection_c``,
``..._microxrcedds_c``) turn an interface package's .idl files into C sources. What they write
depends on the .idl files, the generator's code and templates and its command line, never on the
target: yet every target's build runs them again (about a third of a cold build of micro-ROS).

Each target's CMake builds run Python through a small shim (pyshim.py): a generator run
(``SCRIPT --generator-arguments-file FILE ...``, how rosidl_generate_interfaces calls every
generator: https://github.com/ros2/rosidl/blob/humble/rosidl_cmake/cmake/rosidl_write_generator_arguments.cmake)
comes here. Its key is the content of everything the generator reads, with the target's own folder
taken out of every path: the arguments file, the command line, the files the arguments name
(templates, .idl files, the interfaces it depends on: rosidl lists them as ``target_dependencies``),
the Python packages of the target's install tree (the generators' code) and the generator's
third-party modules' versions. A hit writes the stored files; a miss runs the generator (in this
process, through runpy: no extra interpreter) into an empty folder, keeps exactly what it wrote,
then writes it. Either way a file whose content is already there is left untouched, as the
generators themselves do (their ninja rules have ``restat = 1``).

A miss also keeps what rosidl_parser made of each .idl file (:func:`_parse_memo`): the four C
generators of an interface package each parse all of its .idl files again (Earley parsing, about half
of a generator run), and a parse depends only on the .idl text and the parser's code.

Any trouble with the cache itself falls back to running the generator as CMake asked: the cache
can make a build faster, never different or broken.
"""

from __future__ import annotations

# Imported on every generator run and configure call: only what a hit needs, so that a hit costs
# little more than Python's start (measured: start with hashlib and os 18-19 ms; json, which
# imports re and enum, 10-13 ms more; with pathlib, tarfile, dataclasses and typing as before,
# 85 ms). So a hit parses no JSON: keys are the repr of plain values, entries and indexes plain
# text. A miss imports the rest (json, runpy, tempfile, pickle). Annotations only are imported
# for the type checker.
import hashlib
import os
import sys

from uros_build.files import write_atomic, write_if_changed

TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Mapping, Sequence
    from typing import Any, TypeAlias

    StrPath: TypeAlias = "str | os.PathLike[str]"

FORMAT = 4  # 4: every cached file carries its sha256 (3: keys, entries, indexes without JSON; 2: JSON)
ARGUMENTS_FLAG = "--generator-arguments-file"
# third-party modules the generators import: their versions are part of the key
GENERATOR_MODULES = ("empy", "lark", "lark-parser", "numpy")
PLACEHOLDER = "<target>"
WORKSPACE = "<workspace>"


def is_generator_run(argv: Sequence[str]) -> bool:
    """``SCRIPT --generator-arguments-file FILE ...`` (argv without the interpreter)."""
    return len(argv) >= 3 and argv[1] == ARGUMENTS_FLAG and not argv[0].startswith("-")


def normal(text: str, target_dir: str, workspace: str = "") -> str:
    """``text`` with the target's folder, then the workspace's, taken out (the cache is shared by
    every target of every workspace of the user)."""
    text = text.replace(target_dir, PLACEHOLDER)
    return text.replace(os.path.join(workspace, ""), WORKSPACE + "/") if workspace else text


def expand(text: str, target_dir: str, workspace: str) -> str:
    """:func:`normal` undone for this target and workspace."""
    return text.replace(WORKSPACE + "/", os.path.join(workspace, "")).replace(PLACEHOLDER, target_dir)


def key_of(*fields: object) -> str:
    """The sha256 of ``fields``' repr: str, int, None and tuples of them only, whose repr says
    each exactly and the same way every time (the interpreter's version is in every key)."""
    return hashlib.sha256(repr(fields).encode()).hexdigest()


def _named_files(arguments: Mapping[str, Any]) -> list[str]:
    """Every file the arguments name: target_dependencies, and the .idl files of idl_tuples
    (``base:relative``) and ros_interface_dependencies (``package:path``)."""
    out = [str(p) for p in arguments.get("target_dependencies", ())]
    for item in arguments.get("idl_tuples", ()):
        base, _, rel = str(item).rpartition(":")
        out.append(os.path.join(base, rel))
    for item in arguments.get("ros_interface_dependencies", ()):
        out.append(str(item).partition(":")[2])
    return sorted(set(out))


def sha(path: str) -> str:
    try:
        with open(path, "rb") as f:
            return hashlib.sha256(f.read()).hexdigest()
    except OSError:
        return "missing"


# The Python packages the C generators run on (their own code and what it imports). Only these:
# other rosidl packages are installed alongside the interface packages in whatever order colcon
# happens to run (rosidl_generator_dds_idl was installed after visualization_msgs on one target
# and before it on the next: every run of that package missed).
GENERATOR_PYTHON = (
    "rosidl_adapter",
    "rosidl_cli",
    "rosidl_cmake",
    "rosidl_generator_c",
    "rosidl_generator_type_description",
    "rosidl_parser",
    "rosidl_pycommon",
    "rosidl_typesupport_c",
    "rosidl_typesupport_introspection_c",
    "rosidl_typesupport_microxrcedds_c",
)


def _py_files(folder: str) -> list[str]:
    """The .py files under ``folder``, relative to it, in name order."""
    out = []
    for top, dirs, files in os.walk(folder):
        dirs.sort()
        rel = os.path.relpath(top, folder)
        out += [os.path.normpath(os.path.join(rel, f)) for f in files if f.endswith(".py")]
    return sorted(out)


def _tree_digest(folder: str, prefix: str = "") -> bytes:
    """The names and contents of the .py files under ``folder`` (names given ``prefix``)."""
    return b"".join(
        f"{os.path.join(prefix, rel) if prefix else rel}\0{sha(os.path.join(folder, rel))}\n".encode()
        for rel in _py_files(folder)
    )


def _python_tree(target_dir: StrPath) -> str:
    """The generators' Python packages installed in the target's tree (GENERATOR_PYTHON)."""
    h = hashlib.sha256()
    lib = os.path.join(target_dir, "install", "lib")
    try:
        pythons = sorted(n for n in os.listdir(lib) if n.startswith("python3"))
    except OSError:
        pythons = []
    for python in pythons:
        site = os.path.join(lib, python, "site-packages")
        if os.path.isdir(site):
            for name in GENERATOR_PYTHON:
                h.update(_tree_digest(os.path.join(site, name), name))
    return h.hexdigest()


def module_versions(names: Iterable[str] = GENERATOR_MODULES) -> dict[str, str]:
    """The versions of this interpreter's ``names`` distributions ("-": not installed)."""
    import importlib.metadata  # ~70 ms: in uros's process, once per build, not in each run

    out = {}
    for name in names:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "-"
    return out


def first_key(argv: Sequence[str], arguments_text: str, target_dir: str, modules: str, workspace: str) -> str:
    """A generator run's key from what a hit can tell without parsing the arguments: the command
    line, the arguments file's text, the generator script, the interpreter, the third-party
    modules' versions (``modules``: their JSON, as uros wrote it into the shim) and the generators'
    installed Python packages; the target's and the workspace's folders taken out. The files the
    arguments name are in :func:`second_key` (their list is a function of the text, kept beside
    the entry at the first miss)."""
    top, ws = target_dir, workspace
    return key_of(
        "generator run",
        FORMAT,
        tuple(normal(a, top, ws) for a in argv),
        normal(arguments_text, top, ws),
        sha(argv[0]),
        tuple(sys.version_info[:2]),
        modules,
        _python_tree(target_dir),
    )


def second_key(first: str, named: Sequence[str], target_dir: str, workspace: str) -> str:
    """``first`` with the content of every file the arguments name (templates, .idl files, the
    interfaces depended on)."""
    return key_of(first, tuple((normal(p, target_dir, workspace), sha(p)) for p in named))


# An entry: this line, one line "SIZE SHA256 NAME" per file in name order, an empty line, then the
# contents one after the other. Not a tar (reading one must not cost tarfile's import on every
# hit), not JSON (nor json's). Each file's sha256 is checked on every hit: a byte changed on disk
# (same size: "Int32" -> "Int3X") is a miss, never code in a library.
ENTRY_MAGIC = b"uros-files 3\n"


def pack(files: Mapping[str, bytes]) -> bytes:
    """Files (relative names, contents; nothing else) as one entry, in name order. ValueError for a
    name with a line break (an entry could not say it)."""
    ordered = sorted(files.items())
    if any("\n" in name or "\r" in name for name, _ in ordered):
        raise ValueError("a file name with a line break")
    header = "".join(
        f"{len(data)} {hashlib.sha256(data).hexdigest()} {name}\n" for name, data in ordered
    ).encode()
    return b"".join([ENTRY_MAGIC, header, b"\n", *(data for _, data in ordered)])


def read_folder(folder: StrPath) -> dict[str, bytes]:
    """Every file under ``folder`` by its relative (/-separated) name."""
    out = {}
    for top, _dirs, files in os.walk(folder):
        for name in files:
            path = os.path.join(top, name)
            if os.path.isfile(path):
                with open(path, "rb") as f:
                    out[os.path.relpath(path, folder).replace(os.sep, "/")] = f.read()
    return out


def unpack_files(data: bytes) -> dict[str, bytes]:
    """An entry's files; ValueError for anything but a whole entry of plain relative names (a cut
    or foreign file is never used)."""
    if not data.startswith(ENTRY_MAGIC):
        raise ValueError("not an entry")
    listed: list[tuple[str, int, str]] = []
    at = len(ENTRY_MAGIC)
    while True:
        end = data.find(b"\n", at)
        if end < 0:
            raise ValueError("no end of the list of files")
        line, at = data[at:end], end + 1
        if not line:
            break
        digits, space, rest = line.decode("utf-8").partition(" ")  # UnicodeDecodeError is a ValueError
        sha, space2, name = rest.partition(" ")
        parts = name.split("/")
        if not space or not space2 or not digits.isdigit() or not digits.isascii() or len(sha) != 64:
            raise ValueError(f"refused entry line {line!r}")
        if not name or name.startswith("/") or ".." in parts or "" in parts:
            raise ValueError(f"refused entry {name!r}")
        listed.append((name, int(digits), sha))
    files: dict[str, bytes] = {}
    for name, size, sha in listed:
        files[name] = data[at : at + size]
        at += size
        if hashlib.sha256(files[name]).hexdigest() != sha:
            raise ValueError(f"{name}: not the content the entry's sha256 says")
    if at != len(data):
        raise ValueError("the entry's size is not its files' sizes")
    return files


def write_changed(files: Mapping[str, bytes], output_dir: StrPath) -> int:
    """Write each file whose content differs (a file already as it should be keeps its time, as
    the generators do). Returns how many were written."""
    written = 0
    for name, data in sorted(files.items()):
        written += write_if_changed(os.path.join(output_dir, name), data)
    return written


def _package_tree(folder: StrPath) -> str:
    """The content of a Python package's .py files."""
    return hashlib.sha256(_tree_digest(os.fspath(folder))).hexdigest()


def seal(data: bytes) -> bytes:
    """``data`` behind its sha256 (a cache file that is not an entry: an index, a manifest, a
    pickled parse), for :func:`unseal`."""
    return hashlib.sha256(data).hexdigest().encode() + b"\n" + data


def unseal(data: bytes) -> bytes:
    """What :func:`seal` sealed; ValueError when it is not whole (cut, changed on disk)."""
    sha, newline, body = data.partition(b"\n")
    if not newline or hashlib.sha256(body).hexdigest().encode() != sha:
        raise ValueError("not the content its sha256 says")
    return body


def _parse_memo(parse: Callable[..., Any], memo_dir: StrPath, salt: str) -> Callable[..., Any]:
    """``rosidl_parser.parser.parse_idl_string`` remembered by the .idl text: what the parser made
    of a text is pickled under the hash of the text, the parser's code and ``salt`` (the third-party
    modules' versions: lark parses). A pickle is read only from the workspace's own .uros folder,
    which only uros writes; one that does not load is parsed again."""
    import contextlib
    import pickle

    def memo(idl_string: str, png_file: Any = None) -> Any:
        if png_file is not None:  # a parse tree picture was asked for: parse as asked
            return parse(idl_string, png_file=png_file)
        key = hashlib.sha256(f"{FORMAT}\0{salt}\0{idl_string}".encode()).hexdigest()
        path = os.path.join(memo_dir, key[:2], f"{key}.pickle")
        try:
            with open(path, "rb") as f:
                return pickle.loads(unseal(f.read()))
        except Exception:  # missing, cut, changed or from other code: parse again
            pass
        content = parse(idl_string)
        with contextlib.suppress(OSError, pickle.PicklingError):
            write_atomic(path, seal(pickle.dumps(content, protocol=pickle.HIGHEST_PROTOCOL)))
        return content

    return memo


def _remember_parses(memo_dir: StrPath, modules: Mapping[str, str]) -> Callable[[], None]:
    """Route rosidl_parser's parses through :func:`_parse_memo` for this process; returns the undo.
    Without rosidl_parser (a generator that does not parse) nothing changes. parse_idl_file looks
    parse_idl_string up in its module when called
    (https://github.com/ros2/rosidl/blob/humble/rosidl_parser/rosidl_parser/parser.py), so replacing
    the module's name is enough."""
    import importlib

    try:  # from the target's install tree, found through the PYTHONPATH colcon gives the build
        parser_module = importlib.import_module("rosidl_parser.parser")
    except Exception:  # not importable here: the generator will say so itself
        return lambda: None
    original = getattr(parser_module, "parse_idl_string", None)
    if original is None or parser_module.__file__ is None:
        return lambda: None
    import json

    parser_code = _package_tree(os.path.dirname(parser_module.__file__))
    salt = json.dumps({"parser": parser_code, "modules": dict(modules)}, sort_keys=True)
    setattr(parser_module, "parse_idl_string", _parse_memo(original, memo_dir, salt))  # noqa: B010

    def undo() -> None:
        setattr(parser_module, "parse_idl_string", original)  # noqa: B010

    return undo


def _run_generator(argv: Sequence[str], memo: tuple[StrPath, Mapping[str, str]] | None = None) -> None:
    """The generator script as CMake would have run it, in this process; with ``memo`` (a folder
    and the module versions), its .idl parses remembered there."""
    undo = _remember_parses(*memo) if memo is not None else (lambda: None)
    try:
        run_python(argv)
    finally:
        undo()


def run_python(argv: Sequence[str]) -> None:
    """``python ARGV`` in this process, as the interpreter would run it: a script, or ``-m
    MODULE``; a SystemExit with a failing code is raised, success returns."""
    import runpy

    saved = sys.argv
    sys.argv = list(argv) if argv[0] != "-m" else [argv[1], *argv[2:]]
    try:
        if argv[0] == "-m":
            runpy.run_module(argv[1], run_name="__main__", alter_sys=True)
        else:
            runpy.run_path(argv[0], run_name="__main__")
    except SystemExit as exc:
        if exc.code not in (None, 0):
            raise
    finally:
        sys.argv = saved


INDEX = ".index"  # beside a generator run's entries: its output folder and the files it names


def _taken(index: str, first: str, target_dir: str, workspace: str) -> tuple[str, dict[str, bytes]] | None:
    """A hit: the output folder and the files of the entry of the run keyed ``first``, through its
    index (the output folder and the named files, as the first miss listed them); None when there
    is none, or anything about it is missing or cut."""
    try:
        with open(index, "rb") as f:
            output_dir, *named = unseal(f.read()).decode("utf-8").split("\n")
        if not output_dir:  # not an index uros wrote (it names the output folder first)
            return None
        files = [expand(p, target_dir, workspace) for p in named if p]
        entry = os.path.join(
            os.path.dirname(index), f"{second_key(first, files, target_dir, workspace)}.entry"
        )
        with open(entry, "rb") as f:
            return expand(output_dir, target_dir, workspace), unpack_files(f.read())
    except (OSError, ValueError):
        return None


def generate(
    argv: Sequence[str],
    cache_dir: StrPath,
    target_dir: StrPath,
    modules: str,
    workspace: StrPath,
) -> str:
    """One generator run through the cache; returns "hit", "miss" or "bypass" (cache unusable:
    the generator ran as CMake asked). ``modules``: :func:`module_versions` as JSON (sorted keys),
    as uros wrote it into the shim."""
    top, ws = os.fspath(target_dir), os.fspath(workspace)
    try:
        with open(argv[2], encoding="utf-8") as f:
            arguments_text = f.read()
        first = first_key(argv, arguments_text, top, modules, ws)
    except (OSError, ValueError):
        _run_generator(argv)
        return "bypass"
    index = os.path.join(os.fspath(cache_dir), first[:2], f"{first}{INDEX}")
    taken = _taken(index, first, top, ws)
    if taken is not None:
        write_changed(taken[1], taken[0])
        return "hit"
    import contextlib
    import json
    import tempfile

    try:
        arguments = json.loads(arguments_text)
        output_dir = str(arguments["output_dir"])
        named = _named_files(arguments)
        versions = {str(k): str(v) for k, v in json.loads(modules).items()}
    except (ValueError, KeyError, TypeError, AttributeError):
        _run_generator(argv)
        return "bypass"
    with tempfile.TemporaryDirectory(prefix="uros-gen-") as tmp:
        scratch = os.path.join(tmp, "out")
        os.mkdir(scratch)
        private = os.path.join(tmp, "arguments.json")
        with open(private, "w", encoding="utf-8") as f:
            f.write(json.dumps({**arguments, "output_dir": scratch}))
        _run_generator([argv[0], argv[1], private, *argv[3:]], (os.path.join(cache_dir, "idl"), versions))
        files = read_folder(scratch)
    named_folders = [top.encode(), tmp.encode(), os.path.join(ws, "").encode()]
    if any(folder in c for c in files.values() for folder in named_folders):
        # a generator that writes folders into the code is not the same for every target and
        # workspace: it runs again as CMake asked, and nothing is kept
        _run_generator(argv)
        return "bypass"
    listing = [normal(output_dir, top, ws), *(normal(p, top, ws) for p in named)]
    with contextlib.suppress(OSError, ValueError):  # not kept: the next target generates again
        if any("\n" in line for line in listing):
            raise ValueError("a path with a line break")
        entry = os.path.join(os.path.dirname(index), f"{second_key(first, named, top, ws)}.entry")
        write_atomic(entry, pack(files))
        write_atomic(index, seal("\n".join(listing).encode()))
    write_changed(files, output_dir)
    return "miss"
