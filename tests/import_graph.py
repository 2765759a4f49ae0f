"""The import graph of uros_build, by folder: `python tests/import_graph.py` prints it (the table in
docs/architecture.md), and tests/unit/test_layers.py checks that imports between folders run one way:
down the order below, never up. A folder is a layer or a domain; the modules at the top of the package
are the base every folder may use."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "uros_build"

# Bottom to top: the folder names (a module at the top of the package is "base"). A module may import
# modules of its own folder or of a folder below, never above. A new folder must be placed here.
LAYERS: tuple[tuple[str, str], ...] = (
    ("base", "the top-level modules: errors, console, loader, templating, proc, tooltext, files, defaults"),
    ("shim", "what runs inside a target's build: the Python shim and its two caches"),
    ("target", "what a target is: profiles, toolchain text, compilers, ESP-IDF, ABI"),
    ("sources", "what is built: the workspace, its files, distros, clones, packages, interfaces, meta"),
    ("colcon", "how it is built: colcon's command, host tools, fingerprints, install trees, host stage"),
    ("output", "what comes out: the archive, includes, build-info, output folders, exports, team cache"),
    (
        "run",
        "what runs a built library: QEMU machines, the probe and app firmware, the agent session, the peer",
    ),
    ("config", "what the user asked: settings and their precedence, the build and source plans"),
    ("probesteps", "a probe's steps, siblings over one frozen probe context"),
    ("steps", "a build's steps, each over the frozen plan"),
    ("commands", "one module a command"),
    ("cli", "click: options and the one place errors become messages"),
)
TOP_LEVEL_LIMIT = 12
ENTRY = {"__main__": "cli"}


def module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" and len(rel.parts) > 1 else rel.parts
    return ".".join(parts)


def folder_of(module: str) -> str:
    if module in ENTRY:
        return ENTRY[module]
    return module.split(".")[0] if "." in module or (PACKAGE / module).is_dir() else "base"


def layer_of(module: str) -> int:
    folder = folder_of(module)
    for index, (name, _role) in enumerate(LAYERS):
        if name == folder:
            return index
    raise KeyError(f"{module}: folder {folder} is in no layer of tests/import_graph.py: add it")


def _resolve(base: str, name: str) -> str:
    """`from uros_build.<base> import <name>`: a submodule if there is one, else the module itself."""
    if not base:
        return name
    candidate = PACKAGE.joinpath(*base.split("."), name)
    if candidate.with_suffix(".py").is_file() or candidate.is_dir():
        return f"{base}.{name}"
    return base


def imports() -> dict[str, set[str]]:
    """module -> uros_build modules it imports (submodules by their full dotted name)."""
    graph: dict[str, set[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        if "_data" in path.relative_to(PACKAGE).parts:
            continue
        name = module_name(path)
        found: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("uros_build"):
                base = node.module.removeprefix("uros_build").lstrip(".")
                found.update(_resolve(base, a.name) for a in node.names)
            elif isinstance(node, ast.Import):
                found.update(
                    a.name.removeprefix("uros_build.") for a in node.names if a.name.startswith("uros_build.")
                )
        found.discard(name)
        graph[name] = {f for f in found if f not in ("__version__", "")}
    return graph


def top_level_files() -> list[str]:
    return sorted(p.name for p in PACKAGE.glob("*.py"))


def table() -> str:
    """The import table at the end of docs/architecture.md."""
    graph = imports()
    lines = ["| folder | module | imports (uros_build) |", "|---|---|---|"]
    for index in range(len(LAYERS) - 1, -1, -1):
        for module in sorted(m for m in graph if layer_of(m) == index):
            deps = ", ".join(sorted(graph[module])) or "-"
            lines.append(f"| {LAYERS[index][0]} | `{module}` | {deps} |")
    return "\n".join(lines)


def main() -> None:
    print(table())


if __name__ == "__main__":
    main()
