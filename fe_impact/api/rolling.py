"""The rolling mesh (``fe-impact roll``): the API's names for :mod:`fe_impact.rolling.api`.

:func:`roll` integrates a pinion sector and a face-gear sector turning through
mesh (:class:`~fe_impact.rolling.api.RollInputs`, also ``fe_impact.api.RollInputs``,
holds the operating point and the model's settings); :func:`check_roll_inputs`
refuses bad input in one line before anything is meshed. The numerical modules
are imported when these are first used, so that importing :mod:`fe_impact`
stays cheap.
"""

from __future__ import annotations

__all__ = ["check_roll_inputs", "roll"]


def roll(gearset, inputs, out=None, **kwargs):
    """Run the rolling mesh: :func:`fe_impact.rolling.api.roll` (same arguments)."""
    from fe_impact.rolling.api import roll as _roll

    return _roll(gearset, inputs, out, **kwargs)


def check_roll_inputs(*args, **kwargs):
    """Refuse bad rolling-mesh input in one line: :func:`fe_impact.rolling.api.check_inputs`."""
    from fe_impact.rolling.api import check_inputs

    return check_inputs(*args, **kwargs)

