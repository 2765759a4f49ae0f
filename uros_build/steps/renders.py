"""Texts a build renders from templates, kept per target (or per host stage) by a key of
everything they depend on: a build whose inputs did not change takes them from ``renders.json``
without importing jinja2 or compiling a template (~0.05 s of CPU: a sixth of an up-to-date build's
start, and of what uros itself spends on a build that only runs colcon over its trees).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from uros_build import resources
from uros_build.colcon import fingerprint as fp
from uros_build.files import write_if_changed

RENDERS = "renders.json"


def render_key(inputs: str, templates: tuple[str, ...]) -> str | None:
    """Everything a render's text depends on, by content: ``inputs`` (the repr of what the
    templates are given: frozen dataclasses, every field in their repr), the templates' bytes (none
    includes another), uros's code (the filters, how the context is made) and jinja2's version (its
    ``__init__.py``, which holds it). None: inputs that name an object by its address, which no later
    run could match."""
    import importlib.util

    spec = importlib.util.find_spec("jinja2")
    if " object at 0x" in inputs or spec is None or spec.origin is None:
        return None
    texts = [(resources.templates_dir() / name).read_bytes() for name in templates]
    return fp.digest(inputs, *texts, fp.uros_code_digest(), Path(spec.origin).read_bytes())


def kept_render(
    folder: Path, name: str, inputs: str, templates: tuple[str, ...], render: Callable[[], str]
) -> str:
    """``render()``, or the text it gave a build before for the same :func:`render_key` (the text's
    digest checked; anything off renders again), kept in ``folder``'s renders.json, one entry per
    ``name``."""
    import json

    key = render_key(inputs, templates)
    store = folder / RENDERS
    try:
        kept = json.loads(store.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        kept = None
    kept = kept if isinstance(kept, dict) else {}
    entry = kept.get(name)
    if (
        key is not None
        and isinstance(entry, dict)
        and entry.get("key") == key
        and isinstance(entry.get("text"), str)
        and fp.digest(entry["text"]) == entry.get("digest")
    ):
        return str(entry["text"])
    text = render()
    if key is not None:
        kept[name] = {"digest": fp.digest(text), "key": key, "text": text}
        write_if_changed(store, json.dumps(kept, indent=1, sort_keys=True) + "\n")
    return text
