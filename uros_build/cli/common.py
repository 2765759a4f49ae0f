"""What every command of the `uros` command line shares: the option and group classes (hidden old
spellings, suggestions for typos), shell completion, the options spelled alike across commands
(--toolchain, -w/--workspace, -o/--output) and table output."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
from click.shell_completion import CompletionItem

from uros_build import defaults
from uros_build.commands import listings
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
    return matching(listings.target_names(), incomplete)


def complete_distros(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    return matching(listings.distro_names(), incomplete)


def complete_packages(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    return matching(listings.package_names(ctx.params.get("workspace")), incomplete)


def complete_sets(ctx: click.Context, param: click.Parameter, incomplete: str) -> list[CompletionItem]:
    return matching(listings.set_candidates(ctx.params.get("workspace")), incomplete)


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


METAS = click.option(
    "--meta", "metas", multiple=True, type=PATH_ARG, help="A colcon.meta merged on top (repeatable)."
)
SETS = click.option(
    "--set", "sets", multiple=True, metavar="PKG.OPTION=VALUE", help="Set a CMake option of a package.",
    shell_complete=complete_sets,
)  # fmt: skip
TRANSPORT = click.option(
    "--transport", help="XRCE-DDS transport: custom, udp or serial (default: the target's)."
)
PRESET = click.option(
    "--preset", default=defaults.PRESET, show_default=True, help="colcon.meta starting point (meta/presets/)."
)
# `--from` names the build output to copy; without it, --output is that output, rewritten in place.
FROM = click.option(
    "--from", "source", type=PATH_ARG, help="A `uros build` output to copy (default: --output itself)."
)


def table(rows: list[dict[str, Any]], as_json: bool, columns: tuple[tuple[str, str], ...]) -> None:
    """Rows as JSON (sorted keys, every field) or as aligned text columns under a header;
    ``columns``: (key, title) of what the text shows."""
    if as_json:
        click.echo(json.dumps(rows, indent=2, sort_keys=True))
        return
    lines = [[title for _key, title in columns], *([str(r[key]) for key, _title in columns] for r in rows)]
    widths = [max(len(line[i]) for line in lines) for i in range(len(columns) - 1)]
    for line in lines:
        cells = [f"{cell:<{w}}" for cell, w in zip(line, widths, strict=False)]
        click.echo("  ".join([*cells, line[-1]]).rstrip())
