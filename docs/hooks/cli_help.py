"""MkDocs hook: the live ``--help`` text of fe-impact's commands in the pages.

A line ``<!-- fe-impact COMMAND --help -->`` (or ``<!-- fe-impact --help -->``)
becomes a code block holding what that command prints for ``--help``, so a
command's page lists every option the installed code has. An unknown command
stops the build.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from functools import cache

from mkdocs.exceptions import PluginError

_MARKER = re.compile(r"^<!-- fe-impact(?P<command>(?: [a-z-]+)?) --help -->$", re.MULTILINE)
_RUN = "import sys; from fe_impact.cli import main; sys.exit(main(sys.argv[1:]))"


@cache
def _help(command: str) -> str:
    """What ``fe-impact [COMMAND] --help`` prints, wrapped at 88 columns."""
    args = [command, "--help"] if command else ["--help"]
    env = dict(os.environ, COLUMNS="88")
    done = subprocess.run([sys.executable, "-c", _RUN, *args], capture_output=True,
                          text=True, env=env, timeout=60)
    if done.returncode != 0:
        raise PluginError(f"fe-impact {' '.join(args)} failed ({done.returncode}): "
                          f"{done.stderr.strip()[-300:]}")
    return done.stdout.rstrip()


def on_page_markdown(markdown: str, page, **kwargs) -> str:
    def block(match: re.Match) -> str:
        command = match.group("command").strip()
        title = f"fe-impact {command} --help" if command else "fe-impact --help"
        return f"```text\n$ {title}\n{_help(command)}\n```"

    return _MARKER.sub(block, markdown)
