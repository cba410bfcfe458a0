"""The documentation: the MkDocs site builds in strict mode (a broken link, anchor or API reference fails it),
and the README stays a front door: at most 200 lines, every relative link pointing to a file that exists."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path
from urllib.parse import unquote

ROOT = Path(__file__).resolve().parents[1]
README_MAX_LINES = 200

#: Markdown links and images: ``[text](target)`` / ``![alt](target)``; the text may span lines.
_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


def test_the_site_builds_in_strict_mode(tmp_path):
    site = tmp_path / "site"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    # not --quiet: it hides the warnings strict mode counts, and the build would pass with a broken link
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(site)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    for page in ("index.html", "getting-started.html", "results.html", "architecture.html", "api/loop.html",
                 "report/report.html"):
        assert (site / page).is_file(), page
    # the API reference came from the docstrings
    assert "Locomotion" in (site / "api" / "loop.html").read_text()
    # offline: no web fonts
    assert "fonts.googleapis" not in (site / "index.html").read_text()


def _relative_links(markdown: str) -> list[str]:
    text = re.sub(r"```.*?```", "", markdown, flags=re.S)  # links inside code blocks are not links
    targets = [m.group(1) for m in _LINK.finditer(text)]
    return [t for t in targets if not re.match(r"^[a-z][a-z0-9+.-]*:", t) and not t.startswith("#")]


def test_the_readme_is_short():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines (at most {README_MAX_LINES})"


def test_every_relative_link_of_the_readme_exists():
    links = _relative_links((ROOT / "README.md").read_text())
    assert links, "README.md links to no file"
    missing = [t for t in links if not (ROOT / unquote(t.split("#")[0])).exists()]
    assert not missing, f"README.md links to missing files: {missing}"


def test_the_link_finder_sees_links_and_skips_urls_and_code():
    text = ("See [the docs](docs/index.md) and ![a\npicture](docs/x.png \"title\"), [web](https://example.org),"
            " [top](#top).\n```\n[not a link](nowhere.md)\n```\n")
    assert _relative_links(text) == ["docs/index.md", "docs/x.png"]


#: A command of the docs: ``contactnet ...`` opening a code span, or a shell line of a fenced block (after ``$ ``,
#: environment assignments, ``&&``, ``;`` or ``|``); python blocks are code, not commands.
_SHELL_BLOCK = re.compile(r"```(?:bash|sh|shell|console|text)?\n(.*?)```", re.S)
_COMMAND = re.compile(r"^\s*(?:\$\s+)?(?:[A-Za-z_][A-Za-z0-9_]*=\S*\s+)*(?:\S*/)?contactnet\s+(.*)$")


def _doc_commands(markdown: str) -> list[str]:
    """The ``contactnet`` commands of a markdown text (what follows ``contactnet``, continuation lines joined)."""
    found = []
    for block in _SHELL_BLOCK.findall(markdown):
        for line in block.replace("\\\n", " ").splitlines():
            for part in re.split(r"&&|;|\|", line):
                match = _COMMAND.match(part)
                if match:
                    found.append(match.group(1))
    prose = re.sub(r"```.*?```", "", markdown, flags=re.S)
    found += [m.group(1) for span in re.findall(r"`([^`\n]+)`", prose) if (m := _COMMAND.match(span))]
    return [" ".join(command.split(" #")[0].split()) for command in found]


def _unknown_names(command: str, parser) -> list[str]:  # noqa: ANN001 - an argparse parser
    """The subcommand or ``--options`` of ``command`` (the words after ``contactnet``) that the CLI does not have.
    Words in capitals (``E``, ``NAME``) stand for a choice and end the subcommands."""
    import argparse
    import shlex

    tokens, path = shlex.split(command), ["contactnet"]
    while tokens and not tokens[0].startswith("-"):
        subcommands = next((a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction)), {})
        if not subcommands or tokens[0].isupper() or tokens[0] in ("...", "[...]"):
            break
        if tokens[0] not in subcommands:
            return [f"{' '.join(path)} {tokens[0]}"]
        parser = subcommands[tokens[0]]
        path.append(tokens.pop(0))
    options = {name for action in parser._actions for name in action.option_strings}
    return [f"{' '.join(path)} {t.split('=')[0]}" for t in tokens
            if t.startswith("--") and t.split("=")[0] not in options]


def test_every_command_in_the_docs_names_a_real_subcommand_and_options():
    """Every ``contactnet ...`` the README, docs and examples show parses as far as names go: its subcommands
    exist and so does each ``--option`` (their values are placeholders often, so they are not checked)."""
    from contactnet.cli import build_parser

    parser = build_parser()
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")), *sorted((ROOT / "examples").rglob("*.md"))]
    checked, stale = 0, []
    for page in pages:
        for command in _doc_commands(page.read_text()):
            checked += 1
            stale += [f"{page.relative_to(ROOT)}: {name} (in `contactnet {command}`)"
                      for name in _unknown_names(command, parser)]
    assert checked > 100, f"only {checked} commands found in the docs: the finder is broken"
    assert not stale, "commands in the docs the CLI does not have:\n" + "\n".join(stale)


def test_the_command_finder_sees_commands_and_catches_a_made_up_option():
    from contactnet.cli import build_parser

    text = ("Run `contactnet simulate --gait walk`, or\n```bash\n$ make setup && contactnet experiment random \\\n"
            "  --trials 3 --bogus 1\n```\n```python\nfrom contactnet import registry\n```\n`contactnet nosuch`")
    commands = _doc_commands(text)
    assert commands == ["experiment random --trials 3 --bogus 1", "simulate --gait walk", "nosuch"]
    parser = build_parser()
    assert _unknown_names(commands[0], parser) == ["contactnet experiment --bogus"]
    assert _unknown_names(commands[1], parser) == []
    assert _unknown_names(commands[2], parser) == ["contactnet nosuch"]
