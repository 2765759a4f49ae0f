"""What every command of the `uros` command line shares: the option and group classes (hidden old
spellings, suggestions for typos), shell completion, a settings row as its option (`uros build`'s
options are made from the table, config/settings.py), the options spelled alike across commands
(--toolchain, -w/--workspace, -o/--output) and table output."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
from click.shell_completion import CompletionItem

from uros_build import console, defaults
from uros_build.config import settings as rows
from uros_build.config.settings import Setting
from uros_build.errors import did_you_mean

PATH_ARG = click.Path(path_type=Path)
Decorator = Callable[[Callable[..., Any]], Callable[..., Any]]


class Option(click.Option):
    """An option whose old spellings (``aliases``) keep working but stay out of ``--help``."""

    def __init__(self, *args: Any, aliases: tuple[str, ...] = (), **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.hidden_aliases = aliases

    def get_help_record(self, ctx: click.Context) -> tuple[str, str] | None:
        shown = self.opts
        self.opts = [o for o in shown if o not in self.hidden_aliases]
        try:
            return super().get_help_record(ctx)
        finally:
            self.opts = shown


class Group(click.Group):
    """A command group that answers a mistyped command with the closest names."""

    def resolve_command(
        self, ctx: click.Context, args: list[str]
    ) -> tuple[str | None, click.Command | None, list[str]]:
        name = args[0] if args else ""
        if (
            name
            and not name.startswith("-")
            and not ctx.resilient_parsing
            and not self.get_command(ctx, name)
        ):
            ctx.fail(f"No such command {name!r}{did_you_mean(name, self.list_commands(ctx))}.")
        return super().resolve_command(ctx, args)


# Shell completion (click's: `_UROS_COMPLETE=bash_source uros`, see the README): the names a value
# can take, filtered by what was typed so far.
def matching(names: list[str], incomplete: str) -> list[CompletionItem]:
    return [CompletionItem(n) for n in names if n.startswith(incomplete)]


def complete_targets(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    from uros_build.commands import listings

    return matching(listings.target_names(), incomplete)


def complete_distros(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    from uros_build.commands import listings

    return matching(listings.distro_names(), incomplete)


def complete_packages(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    from uros_build.commands import listings

    return matching(listings.package_names(ctx.params.get("workspace")), incomplete)


def complete_sets(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    from uros_build.commands import listings

    return matching(listings.set_candidates(ctx.params.get("workspace")), incomplete)


_COMPLETIONS = {"targets": complete_targets, "packages": complete_packages, "sets": complete_sets}
_TYPES: dict[str, Any] = {"text": None, "path": PATH_ARG, "int": int}


def setting_option(setting: Setting[Any]) -> Decorator:
    """A row of the settings table as its click option: its flag, its name (the keyword the callback
    gets, a field of BuildArgs), its help (the meaning, or the option's own text) and the rest of
    its ``option`` (config/settings.py CommandLine)."""
    spec = setting.option
    if spec is None or setting.flag is None:
        raise TypeError(f"setting {setting.name} is no option")
    spellings = [setting.flag] if spec.kind == "switch" else setting.flag.split("/")
    extra: dict[str, Any] = {}
    if spec.kind == "flag":
        extra["is_flag"] = True
    elif spec.kind == "switch":
        extra["default"] = None
    if spec.show_default:  # the value itself, or the words for a default that is no value
        extra["default"] = setting.default
        extra["show_default"] = True if setting.default is not None else setting.default_text
    if spec.complete is not None:
        extra["shell_complete"] = _COMPLETIONS[spec.complete]
    return click.option(
        *spellings, *spec.aliases, setting.name, cls=Option, aliases=spec.aliases, help=setting.help,
        type=click.Choice(list(spec.choices)) if spec.choices else _TYPES[spec.type],
        multiple=spec.multiple, metavar="|".join(spec.choices) or spec.metavar, **extra,
    )  # fmt: skip


def setting_options(table: tuple[Setting[Any], ...]) -> Decorator:
    """Every row of ``table`` with an option, in the table's order (the order --help lists them)."""

    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        for setting in reversed([s for s in table if s.option is not None]):
            command = setting_option(setting)(command)
        return command

    return decorate


def toolchain_option(help_text: str) -> Decorator:
    return click.option(
        "--toolchain", "--target", "toolchain", cls=Option, aliases=("--target",), help=help_text,
        shell_complete=complete_targets,
    )  # fmt: skip


def workspace_option(help_text: str) -> Decorator:
    # One default everywhere, resolved by config.resolver.resolve_workspace (None here: "not given").
    return click.option(
        "-w", "--workspace", "--dir", "workspace", cls=Option, aliases=("--dir",), type=PATH_ARG,
        default=None, show_default=defaults.WORKSPACE_HELP, help=help_text,
    )  # fmt: skip


def output_option(help_text: str, required: bool = False) -> Decorator:
    return click.option("-o", "--output", type=PATH_ARG, required=required, help=help_text)


VERBOSE = click.option("-v", "--verbose", is_flag=True, help="Stream the tools' output.")
JSON = click.option("--json", "as_json", is_flag=True, help="Print the table as JSON.")
MIRRORS = click.option(
    "--mirror", "mirrors", multiple=True, metavar="UPSTREAM=LOCAL",
    help="Rewrite URLs, e.g. 'https://github.com/{owner}/{repo}=/srv/mirror/{owner}+{repo}/repo'.",
)  # fmt: skip


def mirror_override_option(repo_help: str) -> Decorator:
    """--mirror-override, with what REPO names in this command."""
    return click.option(
        "--mirror-override", "overrides", multiple=True, metavar="REPO=URL[@VERSION]",
        help=f"One repository from elsewhere (REPO: {repo_help}).",
    )  # fmt: skip


# uros build's own, and meta write's: made from their rows
METAS = setting_option(rows.METAS)
SETS = setting_option(rows.SETS)
TRANSPORT = setting_option(rows.TRANSPORT)
PRESET = setting_option(rows.PRESET)
# `--from` names the build output to copy; without it, --output is that output, rewritten in place.
FROM = click.option(
    "--from", "source", type=PATH_ARG, help="A `uros build` output to copy (default: --output itself)."
)


def table(rows: list[dict[str, Any]], as_json: bool, columns: tuple[tuple[str, str], ...]) -> None:
    """Rows as JSON (sorted keys, every field) or as aligned text columns under a header;
    ``columns``: (key, title) of what the text shows."""
    if as_json:
        console.print_json(rows)
        return
    lines = [[title for _key, title in columns], *([str(r[key]) for key, _title in columns] for r in rows)]
    widths = [max(len(line[i]) for line in lines) for i in range(len(columns) - 1)]
    for line in lines:
        cells = [f"{cell:<{w}}" for cell, w in zip(line, widths, strict=False)]
        click.echo("  ".join([*cells, line[-1]]).rstrip())
