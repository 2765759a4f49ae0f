"""The house's floors: every module imports only its own floor or below (docs/architecture.md)."""

from __future__ import annotations

import import_graph


def test_no_module_imports_one_above_it() -> None:
    wrong = [
        f"{module} ({import_graph.LAYERS[import_graph.layer_of(module)][0]}) imports {dep} "
        f"({import_graph.LAYERS[import_graph.layer_of(dep)][0]})"
        for module, deps in import_graph.imports().items()
        for dep in deps
        if import_graph.layer_of(dep) > import_graph.layer_of(module)
    ]
    assert not wrong


def test_the_top_of_the_package_holds_only_the_base() -> None:
    # Everything else lives in the folder of its layer or domain (docs/architecture.md).
    assert len(import_graph.top_level_files()) <= import_graph.TOP_LEVEL_LIMIT, import_graph.top_level_files()


def test_every_folder_is_a_layer() -> None:
    folders = sorted(p.name for p in import_graph.PACKAGE.iterdir() if (p / "__init__.py").is_file())
    assert set(folders) <= {name for name, _ in import_graph.LAYERS}


def test_commands_do_not_import_each_other() -> None:
    graph = import_graph.imports()
    assert not [
        (m, d)
        for m, deps in graph.items()
        if m.startswith("commands.")
        for d in deps
        if d.startswith("commands")
    ]


def test_the_graph_has_no_cycle() -> None:
    graph = import_graph.imports()
    state: dict[str, int] = {}

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for dep in sorted(graph.get(node, ())):
            if state.get(dep) == 1:
                raise AssertionError(" -> ".join([*path, node, dep]))
            if dep not in state:
                visit(dep, [*path, node])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [])


# Modules only POSIX has: importing one at import time would stop `uros targets` on Windows.
POSIX_ONLY = {"fcntl", "termios", "pwd", "grp", "resource", "pty", "tty", "posix", "crypt"}


def test_no_module_imports_a_posix_only_module() -> None:
    import ast

    from import_graph import PACKAGE

    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module.split(".")[0]]
            found += [f"{path.name}: {n}" for n in names if n in POSIX_ONLY]
    # files.py's lock takes a free lock with one flock, inside a function that returns first on
    # Windows (filelock does it there): a start that locks need not import filelock
    assert found == ["files.py: fcntl"]


def test_test_files_have_unique_names() -> None:
    # pytest imports test files by basename (no packages under tests/): two of one name stop the
    # whole collection ("import file mismatch"), as CI found once.
    tests = import_graph.PACKAGE.parent / "tests"
    names = [p.name for p in tests.rglob("test_*.py")]
    assert sorted({n for n in names if names.count(n) > 1}) == []


def test_the_architecture_docs_import_table_is_current() -> None:
    """docs/architecture.md ends with the import table; helpers landed modules without
    regenerating it four times this session (`python tests/import_graph.py` prints it)."""
    doc = (import_graph.PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    start = doc.index("| folder | module | imports (uros_build) |")
    end = doc.find("\n\n", start)
    current = doc[start : end if end >= 0 else len(doc)].strip()
    assert current == import_graph.table(), "run `python tests/import_graph.py` and paste its table"
