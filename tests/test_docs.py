"""The README and the documentation pages: links, form and content rules.

``mkdocs build --strict`` (``make docs``) checks the links between the site's
pages and their anchors. These tests cover what it does not: the README is not
a page of the site, and CI has no network, so an external link can only be
checked for its form. They read files only (no build), in well under a second.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path
from urllib.parse import urlsplit

import pytest
from markdown.extensions.toc import slugify

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README = ROOT / "README.md"

#: Pages written by hand (docs/examples/ is generated from examples/ by the build).
PAGES = sorted(p for p in DOCS.rglob("*.md") if "examples" not in p.relative_to(DOCS).parts)

_LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)|!\[[^\]]*\]\(([^)\s]+)\)")
_FENCE = re.compile(r"^(```|~~~).*?^\1", re.MULTILINE | re.DOTALL)
_HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*#*\s*$", re.MULTILINE)
_DATE = re.compile(r"\b20\d\d-[01]\d-[0-3]\d\b")
#: A commit hash: 7-40 hex digits holding both a digit and a letter, not part of a
#: number (the mantissa digits of 6.967920282539917e-05 are no hash).
_HASH = re.compile(r"(?<![\w.])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}"
                   r"(?!\w|[-+]\d)")


def _text(path: Path) -> str:
    """The file's text without its fenced code blocks (their brackets are code)."""
    return _FENCE.sub("", path.read_text(encoding="utf-8"))


def _links(path: Path) -> list[str]:
    return [a or b for a, b in _LINK.findall(_text(path))]


def _anchors(path: Path) -> set[str]:
    """The heading anchors of a Markdown file, as MkDocs' toc extension makes them."""
    return {slugify(re.sub(r"[`*]", "", h), "-") for h in _HEADING.findall(_text(path))}


def _external(target: str) -> bool:
    return bool(re.match(r"^[a-z][a-z0-9+.-]*:", target))


def test_readme_links_resolve():
    """Each relative link of the README names a file of the repository and, with
    ``#anchor``, a heading of that file."""
    bad = []
    for target in _links(README):
        if _external(target):
            continue
        path, _, anchor = target.partition("#")
        file = README if not path else (ROOT / path).resolve()
        if not file.exists():
            bad.append(f"{target}: no file {path}")
        elif anchor and file.suffix == ".md" and anchor not in _anchors(file):
            bad.append(f"{target}: no heading #{anchor} in {path or 'README.md'}")
    assert not bad, "README.md: " + "; ".join(bad)


@pytest.mark.parametrize("path", [README, *PAGES], ids=lambda p: str(p.relative_to(ROOT)))
def test_external_links_well_formed(path):
    """An external link is an http(s) address with a host name (it cannot be
    fetched here: no network in CI)."""
    bad = []
    for target in _links(path):
        if not _external(target):
            continue
        parts = urlsplit(target)
        if target.startswith("mailto:"):
            continue
        if parts.scheme not in ("http", "https") or "." not in parts.netloc or " " in target:
            bad.append(target)
    assert not bad, f"{path.name}: malformed external links {bad}"


@pytest.mark.parametrize("path", [README, *PAGES], ids=lambda p: str(p.relative_to(ROOT)))
def test_no_dates_or_commit_hashes(path):
    """User docs state what the tool does now: dates and commits go to CHANGELOG.md
    (docs/changelog.md only includes it)."""
    text = path.read_text(encoding="utf-8")
    found = _DATE.findall(text) + _HASH.findall(text)
    assert not found, f"{path.name}: dates or commit hashes {found[:5]}"


def test_readme_is_short():
    """The README points into the docs; it stays about 200 lines."""
    lines = README.read_text(encoding="utf-8").count("\n")
    assert lines <= 220, f"README.md has {lines} lines"


def _commands() -> list[str]:
    """The subcommands ``fe-impact --help`` lists."""
    run = "import sys; from fe_impact.cli import main; sys.exit(main(['--help']))"
    done = subprocess.run([sys.executable, "-c", run], capture_output=True, text=True,
                          timeout=60, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    section = done.stdout.split("commands:", 1)[1]
    return re.findall(r"^ {4}(\w[\w-]*)\s", section, re.MULTILINE)


def test_every_command_has_its_page():
    """Each subcommand has docs/guide/<command>.md showing its live --help (the
    build hook docs/hooks/cli_help.py fills it in), and is in the site's nav."""
    commands = _commands()
    assert {"calibrate", "solve", "switching"} <= set(commands)
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for command in commands:
        page = DOCS / "guide" / f"{command}.md"
        assert page.exists(), f"no page {page.relative_to(ROOT)} for fe-impact {command}"
        assert f"<!-- fe-impact {command} --help -->" in page.read_text(encoding="utf-8"), (
            f"{page.relative_to(ROOT)} does not show fe-impact {command} --help")
        assert f"guide/{command}.md" in nav, f"guide/{command}.md not in mkdocs.yml's nav"


def _toml_blocks(path: Path) -> list[str]:
    return re.findall(r"^```toml\n(.*?)^```", path.read_text(encoding="utf-8"),
                      re.MULTILINE | re.DOTALL)


def test_readme_gear_set_is_valid():
    """The README's gear-set file is one the project's reader accepts, and the same
    drive as the shipped docs/tutorials/cases/my_drive.toml the docs include."""
    import tomllib

    from fe_impact.gears import load_gearset
    from fe_impact.gears.gearset import gearset_from_dict

    blocks = [b for b in _toml_blocks(README) if "[[face_gear.stages]]" in b]
    assert len(blocks) == 1, "the README shows one gear-set file"
    shown = gearset_from_dict(tomllib.loads(blocks[0]))
    assert shown == load_gearset(DOCS / "tutorials" / "cases" / "my_drive.toml")


@pytest.mark.parametrize("name", ["sphere_static.toml", "sphere_impact.toml"])
def test_tutorial_cases_are_valid(name):
    """The case files the docs include read as shipped (their mesh is committed)."""
    from fe_impact.fe.case import load_case

    case = load_case(DOCS / "tutorials" / "cases" / name)
    assert case.mesh_file.is_file()
