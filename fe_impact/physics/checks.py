"""Argument checks shared by the closed forms of :mod:`fe_impact.physics`.

Each returns the value as a float or raises :class:`ValueError` naming the
argument, the value and what is allowed.
"""

from __future__ import annotations

import numpy as np

__all__ = ["require_poisson", "require_positive"]


def require_positive(name: str, value: float) -> float:
    """Return ``value`` as a float, or raise ValueError naming it when not > 0."""
    value = float(value)
    if not np.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return value


def require_poisson(name: str, value: float) -> float:
    """Return ``value`` as a float, or raise ValueError when outside (-1, 0.5]."""
    value = float(value)
    if not -1.0 < value <= 0.5:
        raise ValueError(f"{name} must lie in (-1, 0.5], got {value!r}")
    return value
