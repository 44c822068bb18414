"""docs/cli.md against the parser (issue 23): every sub-command and option of :func:`gyrojax.cli.app.build_parser`
is documented, and every option the page documents exists.

The parser is built here and its actions walked; no option list is written in this test. How the page is read:

- each sub-command has a section ``## NAME`` and a row in the command table at the top;
- an option belongs to the section it is written in, except inside a code span or code-block line that starts with
  a command (``gyrojax fit …``, ``fit --per-instrument``), where it belongs to that command; before the first
  ``## `` section it belongs to the top-level ``gyrojax`` parser;
- every option string of a sub-command (``-o`` and ``--option`` both) must appear in its section, every positional
  argument's name in upper case (``RECORDS``) too; argparse's own ``-h``/``--help`` is not required.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from gyrojax.cli.app import build_parser

CLI_MD = Path(__file__).resolve().parents[1] / "docs" / "cli.md"
OPTION = re.compile(r"(?<![\w-])(--?[a-zA-Z][\w-]*)")
CODE_SPAN = re.compile(r"`([^`\n]+)`")
HELP = {"-h", "--help"}
OTHER_PROGRAMS = {"python", "pip", "make", "pytest"}


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    raise AssertionError("the gyrojax parser has no sub-commands")


def _options(parser: argparse.ArgumentParser) -> set[str]:
    return {s for a in parser._actions for s in a.option_strings} - HELP


def _positionals(parser: argparse.ArgumentParser) -> list[str]:
    return [
        a.dest.upper()
        for a in parser._actions
        if not a.option_strings and not isinstance(a, argparse._SubParsersAction)
    ]


PARSER = build_parser()
COMMANDS = _subparsers(PARSER)


def _sections(text: str) -> dict[str, str]:
    """``{"": text before the first section, NAME: text of "## NAME"}``."""
    out: dict[str, str] = {}
    name, lines = "", []
    for line in text.splitlines():
        m = re.match(r"^## +(\S+)\s*$", line)
        if m:
            out[name] = "\n".join(lines)
            name, lines = m.group(1), []
        else:
            lines.append(line)
    out[name] = "\n".join(lines)
    return out


def _owner(snippet: str, default: str) -> str | None:
    """The command a code snippet is about: ``gyrojax NAME …`` or ``NAME --…``; else ``default``; ``None`` for
    another program's command line (``python -m gyrojax``)."""
    words = snippet.split()
    if words and words[0] in OTHER_PROGRAMS:
        return None
    if words and words[0] == "gyrojax":
        words = words[1:]
        if not words or words[0].startswith("-"):
            return ""
    return words[0] if words and words[0] in COMMANDS else default


def documented_options(text: str) -> dict[str, set[str]]:
    """{command ('' = top level): option strings the page writes for it}."""
    found: dict[str, set[str]] = {}
    for section, body in _sections(text).items():
        in_block = False
        for line in body.splitlines():
            if line.startswith("```"):
                in_block = not in_block
                continue
            snippets = [line] if in_block else CODE_SPAN.findall(line)
            prose = "" if in_block else CODE_SPAN.sub(" ", line)
            for snip in snippets:
                owner = _owner(snip.strip(), section)
                if owner is not None:
                    found.setdefault(owner, set()).update(OPTION.findall(snip))
            found.setdefault(section, set()).update(OPTION.findall(prose))
    return found


TEXT = CLI_MD.read_text(encoding="utf-8")
SECTIONS = _sections(TEXT)
DOCUMENTED = documented_options(TEXT)


def test_every_command_has_a_section_and_a_table_row():
    table = {m for m in re.findall(r"^\| \[`([\w-]+)`\]\(#[\w-]+\)", TEXT, flags=re.M)}
    assert set(COMMANDS) - set(SECTIONS) == set(), "sub-commands without a '## NAME' section in docs/cli.md"
    assert set(COMMANDS) - table == set(), "sub-commands missing from the command table of docs/cli.md"
    assert (set(SECTIONS) - {""}) - set(COMMANDS) == set(), "sections of docs/cli.md that are not sub-commands"
    assert table - set(COMMANDS) == set(), "rows of the command table that are not sub-commands"


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_option_of_the_parser_is_documented(name):
    sub = COMMANDS[name]
    body = SECTIONS.get(name, "")
    missing = sorted(_options(sub) - DOCUMENTED.get(name, set()))
    assert missing == [], f"docs/cli.md, section '## {name}': options of the parser not documented: {missing}"
    absent = [p for p in _positionals(sub) if not re.search(rf"\b{re.escape(p)}\b", body)]
    assert absent == [], f"docs/cli.md, section '## {name}': positional arguments not named: {absent}"


def test_every_documented_option_exists():
    wrong = {}
    for cmd, options in DOCUMENTED.items():
        parser = COMMANDS[cmd] if cmd else PARSER
        extra = sorted(options - _options(parser) - HELP)
        if extra:
            wrong[cmd or "gyrojax"] = extra
    assert wrong == {}, f"docs/cli.md documents options the parser does not have: {wrong}"


def test_top_level_options_are_documented():
    missing = sorted(_options(PARSER) - DOCUMENTED.get("", set()))
    assert missing == [], f"docs/cli.md, before the first section: top-level options not documented: {missing}"


def test_the_reader_sees_what_it_should():
    """The page reader on a known snippet (so a reader that finds nothing cannot pass the tests above)."""
    text = (
        "intro `gyrojax --version` (`python -m gyrojax`)\n## fit\n| `--json` | x |\n"
        "```\ngyrojax mc s --out d\n```\n`diagnose --alpha A`\n"
    )
    assert documented_options(text) == {"": {"--version"}, "fit": {"--json"}, "mc": {"--out"}, "diagnose": {"--alpha"}}
