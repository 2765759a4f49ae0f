"""The import graph of uros_build, by layer: `python tests/import_graph.py` prints it (the table in
docs/architecture.md), and tests/unit/test_layers.py checks that no module imports one above it."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "uros_build"

# Bottom to top. A module may import modules of its own layer or below, never above.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("base", ("__init__", "errors", "resources", "defaults")),
    ("io", ("console", "loader", "templating")),
    ("runner", ("proc",)),
    (
        "data and builders",
        (
            "profiles",
            "distros",
            "meta",
            "interfaces",
            "packages",
            "includes",
            "toolsearch",
            "colcon",
            "toolchain",
            "buildinfo",
            "espidf",
            "export",
            "contents",
            "sizes",
            "options",
            "abi",
            "archive",
            "installtree",
            "hoststage",
            "fingerprint",
            "firmware_scan",
            "depfiles",
            "probe",
            "cache",
            "gencache",
            "callcache",
            "pyshim",
        ),
    ),
    ("workspace model", ("wsfiles", "damage", "workspace", "outputs", "swap", "clones")),
    ("plans and probes", ("settings", "plan", "sourceplan", "hosttools")),
    ("build steps", ("steps",)),
    ("commands", ("commands",)),
    ("cli", ("cli", "__main__")),
)


def module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE).with_suffix("")
    return ".".join(rel.parts)


def layer_of(module: str) -> int:
    head = module.split(".")[0]
    for index, (_name, members) in enumerate(LAYERS):
        if head in members or module in members:
            return index
    raise KeyError(f"{module} is in no layer of tests/import_graph.py: add it")


def imports() -> dict[str, set[str]]:
    """module -> uros_build modules it imports (commands.x kept whole)."""
    graph: dict[str, set[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        name = module_name(path)
        found: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("uros_build"):
                base = node.module.removeprefix("uros_build").lstrip(".")
                if base:
                    found.add(base)
                else:
                    found.update(a.name for a in node.names)
                if base == "commands":
                    found.discard("commands")
                    found.update(f"commands.{a.name}" for a in node.names)
            elif isinstance(node, ast.Import):
                found.update(
                    a.name.removeprefix("uros_build.") for a in node.names if a.name.startswith("uros_build.")
                )
        found.discard(name)
        graph[name] = {f for f in found if f not in ("__version__",)}
    return graph


def main() -> None:
    graph = imports()
    print("| layer | module | imports (uros_build) |")
    print("|---|---|---|")
    for index in range(len(LAYERS) - 1, -1, -1):
        for module in sorted(m for m in graph if layer_of(m) == index):
            deps = ", ".join(sorted(graph[module])) or "-"
            print(f"| {LAYERS[index][0]} | `{module}` | {deps} |")


if __name__ == "__main__":
    main()
