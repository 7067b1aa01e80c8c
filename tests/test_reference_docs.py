"""docs/cli.md, docs/manifest.md and docs/options.md are what lift_gl/reference_docs.py makes
from the code now, and they cover every command, argument, manifest key, value and option."""
from __future__ import annotations

import argparse

import pytest

from conftest import REPO
from lift_gl import plugins, reference_docs

STALE = "is stale: run  python -m lift_gl.reference_docs"


def test_the_committed_cli_page_is_what_the_parsers_make():
    assert (REPO / "docs" / "cli.md").read_text(encoding="utf-8") == reference_docs.cli_reference(), \
        f"docs/cli.md {STALE}"


def test_the_committed_manifest_page_is_what_plugins_py_and_the_manifests_make():
    assert (REPO / "docs" / "manifest.md").read_text(encoding="utf-8") == reference_docs.manifest_reference(), \
        f"docs/manifest.md {STALE}"


def test_the_committed_options_page_is_what_options_py_makes():
    assert (REPO / "docs" / "options.md").read_text(encoding="utf-8") == reference_docs.options_reference(), \
        f"docs/options.md {STALE}"


def test_every_option_is_on_the_options_page():
    options = pytest.importorskip("lift_gl.options", reason="no lift_gl/options.py: the page says so")
    page = reference_docs.options_reference()
    for name in options.OPTION_FIELDS:
        assert f"| `{name}` |" in page, name


def _commands(parser, prefix="lift-gl"):
    for name, _help, sub in reference_docs._subcommands(parser):
        yield f"{prefix} {name}", sub
        yield from _commands(sub, f"{prefix} {name}")


def test_every_command_and_argument_is_on_the_cli_page():
    page = reference_docs.cli_reference()
    commands = list(_commands(reference_docs.cli_parser()))
    assert {"lift-gl render", "lift-gl compare", "lift-gl view", "lift-gl grade", "lift-gl warptest",
            "lift-gl lab check"} <= {name for name, _ in commands}
    for name, parser in commands:
        section = page.split(f"`{name}`\n", 1)[1]
        section = section.split("\n#", 1)[0]
        for action in parser._actions:
            if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)) or action.help == argparse.SUPPRESS:
                continue
            shown = ", ".join(action.option_strings) if action.option_strings else action.metavar or action.dest
            assert f"`{shown}" in section, f"{name}: {shown} is not on the page"


def test_the_pages_do_not_depend_on_the_terminal_or_the_machine(monkeypatch):
    monkeypatch.setenv("COLUMNS", "40")
    narrow = reference_docs.cli_reference()
    monkeypatch.setenv("COLUMNS", "250")
    assert reference_docs.cli_reference() == narrow
    monkeypatch.setenv("LIFT_GL_PLUGIN_PATH", str(REPO / "tests" / "data"))
    for page in (narrow, reference_docs.manifest_reference()):
        assert str(REPO) not in page and "/home/" not in page


def test_the_manifest_example_shows_every_key_plugins_py_accepts():
    _, example, _ = reference_docs._docstring_parts(plugins.__doc__)
    keys = getattr(plugins, "_MANIFEST_KEYS")
    missing = [key for key in keys if f"{key} =" not in example and f"[{key}" not in example]
    assert not missing, f"lift_gl/plugins.py's docstring example lacks {missing}"


def test_every_accepted_key_and_value_is_on_the_manifest_page():
    page = reference_docs.manifest_reference()
    for name in ("_MANIFEST_KEYS", "_PARAM_KEYS", "_REDUCED_KEYS", "LANGUAGES", "PRIMARY_MODES", "PARAM_TYPES"):
        for value in getattr(plugins, name, ()):
            assert f"`{value}`" in page, f"{name}: {value}"


def test_check_says_which_page_is_stale(tmp_path, monkeypatch, capsys):
    for name, make in reference_docs.PAGES.items():
        (tmp_path / name).write_text(make(), encoding="utf-8")
    monkeypatch.setattr(reference_docs, "DOCS", tmp_path)
    assert reference_docs.main(["--check"]) == 0
    (tmp_path / "cli.md").write_text("old\n", encoding="utf-8")
    assert reference_docs.main(["--check"]) == 1
    assert "docs/cli.md is stale" in capsys.readouterr().out
