"""The ``fe-impact`` command line: :func:`main` and one module per subcommand."""

from fe_impact.cli.main import main

__all__ = ["main"]
