"""What the API's modules share: the types of its arguments and where progress lines go."""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from typing import Union

__all__ = ["Echo", "PathLike", "say_to"]

logger = logging.getLogger("fe_impact.api")

#: A file or folder name: a string or a path.
PathLike = Union[str, "os.PathLike[str]"]
#: Receives each progress line of a run (``print`` in the command).
Echo = Callable[[str], None]


def say_to(echo: Echo | None) -> Echo:
    """``echo``, or a function logging each line at INFO level (logger ``fe_impact.api``)."""
    if echo is not None:
        return echo
    return lambda line: logger.info("%s", line)
