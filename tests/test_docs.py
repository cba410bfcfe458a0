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
