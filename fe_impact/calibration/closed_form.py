"""The seed's closed-form IMPACT parameters, the hysteresis factors, and a fit compared with both.

- `closed_form_parameters`: ``(k, exponent, cmax, d)`` of one impact from
  the seed's eq. 12, 13, 16 and 17 (`fe_impact.physics.seed`);
- `hysteresis_chis`: the hysteresis factors of the five models of
  `fe_impact.physics.laws.CHI_MODELS` for a target restitution, and the
  restitution each actually produces;
- `compare`: fitted against closed-form parameters, side by side.

Input problems raise `fe_impact.errors.CalibrationError`. SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Protocol

from fe_impact.calibration.history import POSITIVE, RESTITUTION
from fe_impact.inputs import check_number
from fe_impact.physics import hertz, laws, seed

__all__ = [
    "HYSTERESIS_MODELS",
    "ClosedFormParameters",
    "ModelChi",
    "closed_form_parameters",
    "compare",
    "hysteresis_chis",
]

#: The five hysteresis-damping models of `fe_impact.physics.laws.CHI_MODELS` (without
#: the undamped ``"hertz"`` entry), in the order of docs/references.md ("Lumped impact laws").
HYSTERESIS_MODELS: tuple[str, ...] = tuple(m for m in laws.CHI_MODELS if m != "hertz")


class _ImpactParameters(Protocol):
    k: float
    exponent: float
    cmax: float
    d: float


# -- hysteresis models ------------------------------------------------------------------
@dataclass(frozen=True)
class ModelChi:
    """Hysteresis factor of one model for a target restitution.

    Attributes
    ----------
    chi : float
        ``chi(e)`` of the model [-] (`fe_impact.physics.laws.hysteresis_factor`).
    restitution : float
        Restitution the law ``K h^n (1 + chi hdot / v)`` actually produces in
        a one-DOF impact [-] (`fe_impact.physics.laws.restitution_of`).
    """

    chi: float
    restitution: float


def hysteresis_chis(restitution: float, exponent: float = 1.5) -> dict[str, ModelChi]:
    """Hysteresis factors of the five models for a target restitution.

    Parameters
    ----------
    restitution : float
        Target restitution, ``0 < e <= 1``.
    exponent : float, optional
        Force exponent of the law used to measure the produced restitution.

    Returns
    -------
    dict of str to ModelChi
        Keyed by model name (`HYSTERESIS_MODELS`), in that order.

    Examples
    --------
    >>> round(hysteresis_chis(0.7)["flores"].restitution, 3)
    0.683
    """
    restitution = check_number("restitution", restitution, **RESTITUTION)
    exponent = check_number("exponent", exponent, **POSITIVE)
    return {
        model: ModelChi(
            chi=laws.hysteresis_factor(model, restitution),
            restitution=laws.restitution_of(model, restitution, exponent),
        )
        for model in HYSTERESIS_MODELS
    }


# -- closed forms -----------------------------------------------------------------------
@dataclass(frozen=True)
class ClosedFormParameters:
    """IMPACT parameters from the seed's closed forms (eq. 12, 13, 16, 17).

    Attributes
    ----------
    k : float
        Hertz stiffness ``(4/3) E* sqrt(R)`` (eq. 12) or the one given [N/m^1.5].
    exponent : float
        1.5 [-].
    cmax : float
        Eq. 13 at the eq. 16 approach [N s/m].
    d : float
        Eq. 17 at the Hertz peak force [m]; for a sphere-type contact this
        equals ``delta_max``.
    delta_max : float
        Eq. 16, ``(5 m v^2 / (4 k))^(2/5)`` [m].
    force_max : float
        ``k delta_max^1.5`` [N].
    contact_time : float
        Hertz contact time ``2.94328 delta_max / v`` [s].
    restitution : float
        Target restitution used in eq. 13 [-].
    """

    #: Units of the fields, for tables and files.
    UNITS: ClassVar[dict[str, str]] = {
        "k": "N/m^1.5",
        "exponent": "-",
        "cmax": "N s/m",
        "d": "m",
        "delta_max": "m",
        "force_max": "N",
        "contact_time": "s",
        "restitution": "-",
    }

    k: float
    exponent: float
    cmax: float
    d: float
    delta_max: float
    force_max: float
    contact_time: float
    restitution: float

    @property
    def law(self) -> laws.ImpactLaw:
        """The closed-form law."""
        return laws.ImpactLaw(self.k, self.exponent, self.cmax, self.d)

    def as_dict(self) -> dict[str, float]:
        """Values keyed like `UNITS`."""
        return {key: float(getattr(self, key)) for key in self.UNITS}


def closed_form_parameters(
    R: float,
    E_star: float,
    mass: float,
    speed: float,
    restitution: float,
    *,
    k: float | None = None,
) -> ClosedFormParameters:
    """The seed's closed-form IMPACT parameters for one impact.

    - ``k = (4/3) E* sqrt(R)`` (eq. 12, `fe_impact.physics.seed.stiffness`),
      unless ``k`` is given (e.g. from an elliptical Hertz contact);
    - ``exponent = 1.5``;
    - ``delta_max = (5 m v^2 / (4 k))^(2/5)`` (eq. 16), ``F_max = k delta_max^1.5``
      and the Hertz contact time (`fe_impact.physics.hertz.impact_from_stiffness`);
    - ``cmax = 3 k (1 - e^2) exp(2 (1 - e)) delta_max^1.5 / (4 v)`` (eq. 13,
      `fe_impact.physics.seed.damping`);
    - ``d = (9 F_max^2 / (16 R E*^2))^(1/3)`` (eq. 17,
      `fe_impact.physics.seed.penetration_depth`).

    Parameters
    ----------
    R : float
        Effective radius [m].
    E_star : float
        Effective modulus [Pa].
    mass : float
        Effective mass [kg].
    speed : float
        Impact speed v_k [m/s].
    restitution : float
        Restitution e for eq. 13, ``0 < e <= 1``.
    k : float, optional
        Stiffness [N/m^1.5] overriding eq. 12.

    Returns
    -------
    ClosedFormParameters

    Examples
    --------
    >>> p = closed_form_parameters(0.01, 115.66e9, 0.5, 0.1, 0.8)
    >>> round(p.delta_max * 1e6, 2), round(p.force_max), round(p.contact_time * 1e6)
    (11.04, 566, 325)
    """
    R = check_number("R", R, **POSITIVE)
    E_star = check_number("E_star", E_star, **POSITIVE)
    mass = check_number("mass", mass, **POSITIVE)
    speed = check_number("speed", speed, **POSITIVE)
    restitution = check_number("restitution", restitution, **RESTITUTION)
    k = seed.stiffness(R, E_star) if k is None else check_number("k", k, **POSITIVE)
    hit = hertz.impact_from_stiffness(mass, speed, k)
    return ClosedFormParameters(
        k=k,
        exponent=1.5,
        cmax=seed.damping(k, restitution, speed, hit.delta_max, 1.5),
        d=seed.penetration_depth(hit.force_max, R, E_star),
        delta_max=hit.delta_max,
        force_max=hit.force_max,
        contact_time=hit.contact_time,
        restitution=restitution,
    )


def compare(fit: _ImpactParameters, closed: ClosedFormParameters) -> dict[str, dict[str, float]]:
    """Side-by-side comparison of fitted and closed-form IMPACT parameters.

    Parameters
    ----------
    fit : ImpactFit or fe_impact.physics.laws.ImpactLaw
        Anything with ``k``, ``exponent``, ``cmax`` and ``d``.
    closed : ClosedFormParameters

    Returns
    -------
    dict
        For ``k``, ``exponent``, ``cmax``, ``d`` and ``force_at_delta_max``
        (the elastic force ``k delta^exponent`` of each law at the closed-form
        ``delta_max``: comparable even when the exponents differ, unlike
        ``k`` whose units then differ), a dict with ``fit``, ``closed_form``
        and ``relative_difference = fit / closed_form - 1``.
    """
    values = {
        name: (float(getattr(fit, name)), float(getattr(closed, name)))
        for name in ("k", "exponent", "cmax", "d")
    }
    values["force_at_delta_max"] = (
        float(fit.k) * closed.delta_max ** float(fit.exponent),
        closed.k * closed.delta_max**closed.exponent,
    )
    return {
        name: {
            "fit": a,
            "closed_form": b,
            "relative_difference": a / b - 1.0 if b != 0.0 else math.inf,
        }
        for name, (a, b) in values.items()
    }
