"""The reference pages made from the code, so that they cannot drift from it:

    python -m lift_gl.reference_docs            # writes docs/cli.md, docs/manifest.md, docs/options.md
    python -m lift_gl.reference_docs --check    # exit 1 if a committed page is stale

docs/cli.md is every `lift-gl` command's arguments as argparse knows them (the help strings
in lift_gl/cli.py and the modules that add a command). docs/manifest.md is the plugin
manifest: its docstring's example in lift_gl/plugins.py and the keys and values it accepts.
docs/options.md is every key of lift_gl/options.py's Options (a short page saying so where
that module does not exist).
tests/test_reference_docs.py checks that the committed pages are what this makes now.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from unittest import mock

REPO_ROOT = Path(__file__).resolve().parent.parent
DOCS = REPO_ROOT / "docs"


class _Parsed(Exception):
    """Raised in place of parsing, once lift_gl.cli.main has built its parser."""


def cli_parser() -> argparse.ArgumentParser:
    """The parser lift_gl.cli.main builds, taken at its parse_args call (so nothing here
    repeats how main() assembles the commands)."""
    from . import cli

    built = {}

    def capture(self, args=None, namespace=None):
        built["parser"] = self
        raise _Parsed

    with mock.patch.object(argparse.ArgumentParser, "parse_args", capture):
        try:
            cli.main([])
        except _Parsed:
            pass
    return built["parser"]


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _shown(value) -> str | None:
    """A default as the page shows it, or None where it says nothing (or depends on the machine)."""
    if value is None or value is False or value == [] or value is argparse.SUPPRESS:
        return None
    if isinstance(value, Path):
        try:
            return str(value.resolve().relative_to(REPO_ROOT))
        except ValueError:
            return None
    if isinstance(value, (str, int, float, tuple)):
        return str(value) if not isinstance(value, tuple) else ",".join(map(str, value))
    return None


def _argument(action: argparse.Action) -> str:
    if not action.option_strings:
        return f"`{action.metavar or action.dest}`"
    names = ", ".join(action.option_strings)
    if action.nargs == 0:
        return f"`{names}`"
    if action.metavar is not None:
        metavar = action.metavar if isinstance(action.metavar, str) else " ".join(action.metavar)
    elif action.choices is not None:
        metavar = "|".join(map(str, action.choices))
    else:
        metavar = action.dest.upper()
    return f"`{names} {metavar}`".replace("|", "\\|")


def _meaning(formatter: argparse.HelpFormatter, action: argparse.Action) -> str:
    text = formatter._expand_help(action) if action.help else ""
    if action.choices is not None and action.metavar is not None and not isinstance(action.choices, dict):
        listed = ", ".join(map(str, action.choices))   # the argument column shows choices without a metavar
        if listed not in text:
            text = f"{text} (one of {listed})" if text else f"one of {listed}"
    default = _shown(action.default) if action.nargs != 0 else None
    if default is not None and "default" not in text:
        text = f"{text} (default {default})" if text else f"default {default}"
    if action.required and action.option_strings:
        text = f"required. {text}"
    return _cell(text) or "–"


def _subcommands(parser: argparse.ArgumentParser):
    """(name, help, subparser) of each subcommand, in the order they were added."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help for choice in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, helps.get(name) or "", sub


def _command_section(name: str, summary: str, parser: argparse.ArgumentParser, depth: int) -> list[str]:
    formatter = argparse.HelpFormatter(parser.prog)   # for its %(default)s expansion only
    lines = [f"{'#' * depth} `{parser.prog}`", ""]
    description = " ".join((parser.description or "").split()) or summary
    if description:
        lines += [description[0].upper() + description[1:] + ("" if description.endswith(".") else "."), ""]
    rows = []
    for group in parser._action_groups:
        actions = [a for a in group._group_actions
                   if not isinstance(a, (argparse._HelpAction, argparse._SubParsersAction))
                   and a.help is not argparse.SUPPRESS]
        if actions and group.title not in ("positional arguments", "options", "optional arguments"):
            rows.append(f"| *{_cell(group.title)}* | |")
        rows += [f"| {_argument(a)} | {_meaning(formatter, a)} |" for a in actions]
    if rows:
        lines += ["| argument | meaning |", "| --- | --- |", *rows, ""]
    for sub_name, sub_help, sub in _subcommands(parser):
        lines += _command_section(sub_name, sub_help, sub, depth + 1)
    return lines


def cli_reference() -> str:
    parser = cli_parser()
    commands = list(_subcommands(parser))
    lines = [
        "# Command-line reference",
        "",
        "Generated from the argument parsers by `python -m lift_gl.reference_docs`: do not edit",
        "by hand; change the help strings in the code and run it again. `lift-gl COMMAND --help`",
        "prints the same. The commands are also `python -m lift_gl COMMAND`.",
        "",
    ]
    lines += ["Commands: " + ", ".join(f"[`{name}`](#lift-gl-{name.replace(' ', '-')})" for name, _, _ in commands)
              + ". Each exits 0 on success and 2 on a bad input (one line `lift-gl: error: ...` naming the file).", ""]
    for name, help_text, sub in commands:
        lines += _command_section(name, help_text, sub, 2)
    return "\n".join(lines).rstrip() + "\n"


# ---- The plugin manifest ----

def _docstring_parts(doc: str) -> tuple[str, str, str]:
    """plugins.py's docstring: the prose before the example (its summary line left out),
    the example, the prose after."""
    before, example, after = [], [], []
    part = before
    for line in doc.strip("\n").split("\n\n", 1)[-1].splitlines():
        if line.startswith("    ") and part is not after:
            part = example
            example.append(line[4:])
        elif part is example and not line.strip():
            example.append("")
        else:
            if part is example:
                part = after
            part.append(line)
    while example and not example[-1].strip():
        example.pop()
    return " ".join(" ".join(before).split()), "\n".join(example), " ".join(" ".join(after).split())


def manifest_reference() -> str:
    from . import plugins

    intro, example, after = _docstring_parts(plugins.__doc__ or "")
    lines = [
        "# Plugin manifest reference",
        "",
        "Generated by `python -m lift_gl.reference_docs` from `lift_gl/plugins.py` (its docstring",
        "and the values it accepts): do not edit by hand. The guide to writing a plugin is",
        "[plugins.md](plugins.md).",
        "",
        intro,
        "",
        "```toml",
        example,
        "```",
        "",
    ]
    if after:
        lines += [after, ""]
    accepted = [
        ("manifest keys", getattr(plugins, "_MANIFEST_KEYS", None)),
        ("`language`", getattr(plugins, "LANGUAGES", None)),
        ("`primary`", getattr(plugins, "PRIMARY_MODES", None)),
        ("`bvh_stack`", getattr(plugins, "BVH_STACKS", None)),
        ("a parameter's keys", getattr(plugins, "_PARAM_KEYS", None)),
        ("a parameter's `type`", getattr(plugins, "PARAM_TYPES", None)),
        ("`[reduced]` keys", getattr(plugins, "_REDUCED_KEYS", None)),
        ("`[prepass]` keys", getattr(plugins, "_PREPASS_KEYS", None)),
    ]
    lines += ["## Accepted values", "", "| key | values |", "| --- | --- |"]
    for key, values in accepted:
        if values:
            ordered = values if isinstance(values, (tuple, list)) else sorted(values)
            lines.append(f"| {key} | {', '.join(f'`{v}`' for v in ordered)} |")
    types = getattr(plugins, "GLSL_TYPES", {})
    if types:
        lines.append("| GLSL type of a parameter's uniform | "
                     + ", ".join(f"`{t}`: `{g}`" for t, g in types.items()) + " |")
    defaults = getattr(plugins, "REDUCED_DEFAULTS", {})
    if defaults:
        lines.append("| `[reduced]` defaults | " + ", ".join(f"`{k}` {v}" for k, v in defaults.items()) + " |")
    prefixes = getattr(plugins, "_HOST_DEFINE_PREFIXES", ())
    if prefixes:
        lines.append("| a `define` may not start with | " + ", ".join(f"`{p}`" for p in prefixes) + " |")
    lines += ["", "`lift-gl plugins` lists every plugin found with its parameters, and the errors of any",
              "manifest that does not load."]
    return "\n".join(lines).rstrip() + "\n"


# ---- The options ----

OPTIONS_STUB = """# Options reference

The settings that choose how a frame runs (the BVH's layout, where the traversal keeps its
stack, the trace pass's variants, the G-buffer's kind) are chosen per device: `lift-gl render
--explain` prints each choice and why. This page is generated from `lift_gl/options.py` by
`python -m lift_gl.reference_docs` wherever that module exists.
"""


def options_reference() -> str:
    """docs/options.md: every key of lift_gl/options.py's Options, its values, default and help."""
    try:
        from . import options
    except ImportError:
        return OPTIONS_STUB
    fields = getattr(options, "OPTION_FIELDS", None)
    if not fields:
        return OPTIONS_STUB
    allowed = getattr(options, "allowed", lambda name: "")
    lines = [
        "# Options reference",
        "",
        "Generated by `python -m lift_gl.reference_docs` from `lift_gl/options.py`: do not edit by",
        "hand. Set an option with `--option KEY=VALUE` on the command line (repeatable) or",
        "`Renderer(..., options=...)`; `lift-gl render --explain` prints what each one chose and",
        "why, and each render's JSON records it.",
        "",
    ]
    lines += ["| key | values | default | meaning |", "| --- | --- | --- | --- |"]
    for name, f in fields.items():
        lines.append(f"| `{name}` | {_cell(allowed(name))} | `{f.default}` | {_cell(f.metadata.get('help', ''))} |")
    return "\n".join(lines).rstrip() + "\n"


PAGES = {"cli.md": cli_reference, "manifest.md": manifest_reference, "options.md": options_reference}


def stale_pages() -> list[str]:
    return [name for name, make in PAGES.items()
            if not (DOCS / name).is_file() or (DOCS / name).read_text(encoding="utf-8") != make()]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m lift_gl.reference_docs", description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="only say which pages are stale (exit 1 if any)")
    args = parser.parse_args(argv)
    if args.check:
        stale = stale_pages()
        for name in stale:
            print(f"docs/{name} is stale: run  python -m lift_gl.reference_docs")
        return 1 if stale else 0
    for name, make in PAGES.items():
        (DOCS / name).write_text(make(), encoding="utf-8")
        print(f"wrote docs/{name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
