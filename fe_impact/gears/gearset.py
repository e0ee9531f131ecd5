"""Gear-set description: typed records, TOML loading and validation.

A gear set is one involute spur pinion design (``n_pinions`` identical
pinions arranged symmetrically) meshing with one or more face-gear stages
(nested rings), all of one material. SI units inside: m, kg m^2, Pa,
kg/m^3.

TOML format (every key that carries a unit says so in its suffix; a field
of the records is the key without its suffix)::

    name = "seed"                      # required
    notes = "free text"                # optional
    n_pinions = 4                      # optional, default 4

    [material]
    youngs_modulus_pa = 212e9
    poisson_ratio = 0.289
    density_kg_m3 = 7860.0
    yield_strength_pa = 835e6
    contact_stress_limit_pa = 1500e6   # optional: ISO 6336-5 sigma_Hlim
    bending_stress_limit_pa = 500e6    # optional: ISO 6336-5 sigma_Flim

    [pinion]
    teeth = 19
    module_mm = 3.0
    pressure_angle_deg = 20.0
    addendum_coeff = 1.0
    clearance_coeff = 0.25
    face_width_mm = 24.0
    fillet_radius_coeff = 0.38
    lengthwise_crowning_um = 10.0
    profile_crowning_um = 0.0
    inertia_kg_m2 = 1.95e-4
    tip_edge_radius_mm = 0.3           # optional: rounding of the tip edges (0: sharp)

    [face_gear]
    module_mm = 3.0                    # must equal the pinion module
    inner_limit = "conjugate"          # or "undercut": the inner-radius rule
    tip_edge_radius_mm = 0.1           # optional: rounding of the rings' tip edges

    [friction]                         # optional: Coulomb friction between the flanks
    mu_static = 0.05                   # optional, default the seed's (greased, eqs. 9-10)
    mu_dynamic = 0.02                  # optional, default the seed's; 0 and 0: frictionless

    [[face_gear.stages]]               # one table per stage, inner ring first
    teeth = 56
    shaper_teeth = 21
    inner_radius_mm = 82.5
    outer_radius_mm = 96.0
    lengthwise_crowning_um = 0.0
    inertia_kg_m2 = 7.15e-3
    force_shaper = false               # optional: allow N_s outside N_p + 1..3

Stages are numbered from 1 in messages, as in the seed study.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fe_impact.errors import GeometryError
from fe_impact.gears.facegear import (
    INNER_LIMIT_RULES,
    FaceGearLimits,
    FaceGearTooth,
    face_gear_limits,
)
from fe_impact.gears.pinion import (
    PinionTooth,
    involute_function,
    max_fillet_radius_coeff,
    min_teeth_without_undercut,
)
from fe_impact.inputs import (
    MAX_DENSITY,
    MAX_YOUNGS_MODULUS,
    Reader,
    check_choice,
    check_flag,
    check_integer,
    check_number,
    invalid,
    read_document,
)

logger = logging.getLogger(__name__)

__all__ = [
    "FaceGearStage",
    "FlankFriction",
    "GearSet",
    "Material",
    "Pinion",
    "default_gearset",
    "default_gearset_path",
    "gearset_from_dict",
    "load_gearset",
]

#: Shaper tooth counts accepted without ``force_shaper``: pinion + 1..3
#: (Litvin's handbook recommends a difference of 1-3: N_s = N_p gives line
#: contact, sensitive to misalignment; a larger difference shrinks the contact).
SHAPER_TEETH_EXCESS = (1, 3)

#: The design ranges a gear set must lie in, the ranges the face-gear geometry is
#: checked over (tests/test_drives.py, validation/face_gear_limits.py): pressure
#: angle [deg], module [m], pinion teeth, face-gear stages and pinions (each
#: inclusive). Inside them a set is refused only by the geometry's own conditions
#: (undercut, pointing, rings that overlap, ...), each message saying what to change.
PRESSURE_ANGLE_RANGE_DEG = (18.0, 30.0)
MODULE_RANGE = (1e-3, 10e-3)
PINION_TEETH_RANGE = (12, 40)
STAGES_RANGE = (1, 5)
PINIONS_RANGE = (1, 4)
#: ``sigma_Hlim`` [Pa] when a gear set gives none: ISO 6336-5:2016, case-hardened
#: (carburised) wrought steels, material quality MQ, 1500 MPa (ML 1300, ME 1650);
#: the seed's 20CrMnTi, carburised and quenched to 58-62 HRC, is such a steel
#: (GB/T 3480.5, the Chinese adoption of ISO 6336-5, gives the same chart).
DEFAULT_CONTACT_STRESS_LIMIT = 1500e6
#: ``sigma_Flim`` [Pa] when a gear set gives none: ISO 6336-5:2016, case-hardened
#: (carburised) wrought steels, material quality MQ, 500 MPa (ML 312, ME 525): the
#: nominal stress number of the reference test gear, whose local root stress is
#: ``Y_ST = 2`` times it (:mod:`fe_impact.gears.root_stress`).
DEFAULT_BENDING_STRESS_LIMIT = 500e6
_RANGE_HINT = "(the design range fe-impact's face-gear geometry is checked over)"

#: Crowning above this fraction of the module is taken for a unit mistake
#: (micrometres entered as millimetres).
MAX_CROWNING_PER_MODULE = 0.1

#: Tip-edge rounding radii [m] when a gear set gives none. Finished teeth have
#: their tip edges broken; the radius is a design input with no standard
#: value. The defaults are chosen for the seed set (module 3): 0.3 mm = 0.1 m
#: on the pinion, and 0.1 mm on the face gears, whose narrowest top land
#: (0.2 mm, at stage 1's outer radius) takes two roundings of at most 0.19 mm.
DEFAULT_PINION_TIP_EDGE_RADIUS = 0.3e-3
DEFAULT_FACE_TIP_EDGE_RADIUS = 0.1e-3
#: Radii at which a face gear's top land is checked against its two roundings
#: (evenly over the face, ends included).
_LAND_CHECKS = 9

#: The seed's flank friction (section 4, eqs. 9-10: greased flanks), the default of a
#: gear set without a ``[friction]`` table.
SEED_MU_STATIC = 0.05
SEED_MU_DYNAMIC = 0.02
#: Coefficients are refused from this up: no greased or dry steel flank reaches 1
#: (dry steel on steel about 0.6-0.8), and a coefficient of 1 or more makes the
#: lumped model's friction torque the size of the mesh force's own.
MAX_FLANK_FRICTION = 1.0

_MM = 1e-3
_UM = 1e-6


# -- small checks ------------------------------------------------------------------
def _positive(field: str, value: float, unit: str = "mm", scale: float = 1e3) -> None:
    """Raise GeometryError naming ``field`` unless ``value`` is finite and > 0.

    The value is shown times ``scale`` in ``unit`` (a length in m shown in mm).
    """
    check_number(field, value, low=0.0, low_open=True, unit=unit, scale=scale,
                 error=GeometryError)


def _integer(field: str, value: Any, minimum: int) -> None:
    """Raise GeometryError unless ``value`` is an integer >= ``minimum``."""
    check_integer(field, value, low=minimum, error=GeometryError)


def _largest(ok: Callable[[float], bool], high: float) -> float:
    """The largest value in ``[0, high]`` where ``ok`` holds, ``ok`` holding below it
    and not above it (bisection, 60 halvings: 1e-18 of ``high``)."""
    low = 0.0
    for _ in range(60):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if ok(mid) else (low, mid)
    return low


def _crowning(field: str, value: float, module: float) -> None:
    """Crowning must be >= 0 and at most ``MAX_CROWNING_PER_MODULE`` modules."""
    check_number(field, value, low=0, high=MAX_CROWNING_PER_MODULE * module, unit="um",
                 scale=1e6, hint=f"({MAX_CROWNING_PER_MODULE} module)", error=GeometryError)


# -- records -----------------------------------------------------------------------------
@dataclass(frozen=True)
class Material:
    """Isotropic elastic material with a yield strength.

    Parameters
    ----------
    youngs_modulus : float
        E [Pa].
    poisson_ratio : float
        nu [-], in (-1, 0.5).
    density : float
        rho [kg/m^3].
    yield_strength : float
        Y [Pa] (uniaxial; an input, used for plasticity and yield-onset speed).
    contact_stress_limit : float
        Allowable contact stress [Pa] the Hertz peak pressure is compared with:
        the endurance limit for contact stress ``sigma_Hlim`` of ISO 6336-5.
        Default :data:`DEFAULT_CONTACT_STRESS_LIMIT` (case-carburised steel).
    bending_stress_limit : float
        The nominal stress number for bending ``sigma_Flim`` of ISO 6336-5 [Pa]
        (root stresses are compared with ``2 sigma_Flim``). Default
        :data:`DEFAULT_BENDING_STRESS_LIMIT` (case-carburised steel).
    """

    youngs_modulus: float
    poisson_ratio: float
    density: float
    yield_strength: float
    contact_stress_limit: float = DEFAULT_CONTACT_STRESS_LIMIT
    bending_stress_limit: float = DEFAULT_BENDING_STRESS_LIMIT

    def __post_init__(self) -> None:
        check_number("material.youngs_modulus", self.youngs_modulus, low=0.0, low_open=True,
                     high=MAX_YOUNGS_MODULUS, unit="Pa", error=GeometryError)
        check_number("material.density", self.density, low=0.0, low_open=True,
                     high=MAX_DENSITY, unit="kg/m^3", error=GeometryError)
        check_number("material.yield_strength", self.yield_strength, low=0.0, low_open=True,
                     high=self.youngs_modulus, high_open=True, unit="Pa",
                     hint="(below the Young's modulus)", error=GeometryError)
        check_number("material.poisson_ratio", self.poisson_ratio, low=-1, high=0.5,
                     low_open=True, high_open=True, error=GeometryError)
        check_number("material.contact_stress_limit", self.contact_stress_limit, low=0.0,
                     low_open=True, high=self.youngs_modulus, high_open=True, unit="MPa",
                     scale=1e-6, hint="(below the Young's modulus)", error=GeometryError)
        check_number("material.bending_stress_limit", self.bending_stress_limit, low=0.0,
                     low_open=True, high=self.youngs_modulus, high_open=True, unit="MPa",
                     scale=1e-6, hint="(below the Young's modulus)", error=GeometryError)


@dataclass(frozen=True)
class Pinion:
    """Involute spur pinion design (standard, no profile shift).

    Parameters
    ----------
    teeth : int
        ``z``; at least the undercut bound (17.1 for the standard rack).
    module : float
        ``m`` [m].
    pressure_angle_deg : float
        [deg], in (0, 45).
    addendum_coeff, clearance_coeff : float
        ``ha*``, ``c*`` [-]; the face gear uses the same proportions.
    face_width : float
        [m].
    fillet_radius_coeff : float
        Rack tip-round radius / module [-], in (0, max_fillet_radius_coeff].
    lengthwise_crowning, profile_crowning : float
        Parabolic crowning amounts [m] (see :mod:`fe_impact.gears.pinion`).
    inertia : float
        Mass moment of inertia about the pinion axis [kg m^2].
    tip_edge_radius : float
        Radius [m] of the rounding between each flank and the tip land, >= 0
        (0: sharp edges); it must leave a tip land
        (:meth:`tip_edge_rounding`).
    """

    teeth: int
    module: float
    pressure_angle_deg: float
    addendum_coeff: float
    clearance_coeff: float
    face_width: float
    fillet_radius_coeff: float
    lengthwise_crowning: float
    profile_crowning: float
    inertia: float
    tip_edge_radius: float = DEFAULT_PINION_TIP_EDGE_RADIUS

    def __post_init__(self) -> None:
        check_number("pinion.module", self.module, low=MODULE_RANGE[0], high=MODULE_RANGE[1],
                     unit="mm", scale=1e3, hint=_RANGE_HINT, error=GeometryError)
        _positive("pinion.face_width", self.face_width)
        _positive("pinion.addendum_coeff", self.addendum_coeff, "", 1.0)
        _positive("pinion.clearance_coeff", self.clearance_coeff, "", 1.0)
        _positive("pinion.inertia", self.inertia, "kg m^2", 1.0)
        check_number("pinion.pressure_angle_deg", self.pressure_angle_deg,
                     low=PRESSURE_ANGLE_RANGE_DEG[0], high=PRESSURE_ANGLE_RANGE_DEG[1],
                     unit="deg", hint=_RANGE_HINT, error=GeometryError)
        check_integer("pinion.teeth", self.teeth, low=PINION_TEETH_RANGE[0],
                      high=PINION_TEETH_RANGE[1], error=GeometryError)
        self._check_rack()
        rho_max = max_fillet_radius_coeff(
            self.pressure_angle_deg, self.addendum_coeff, self.clearance_coeff
        )
        if not 0.0 < self.fillet_radius_coeff <= rho_max:
            raise GeometryError(
                f"pinion.fillet_radius_coeff = {self.fillet_radius_coeff!r} must lie in "
                f"(0, {rho_max:.4f}] for this rack (addendum_coeff = {self.addendum_coeff:g}, "
                f"clearance_coeff = {self.clearance_coeff:g}, {self.pressure_angle_deg:g} deg)"
            )
        z_min = min_teeth_without_undercut(
            self.pressure_angle_deg,
            self.addendum_coeff,
            self.clearance_coeff,
            self.fillet_radius_coeff,
        )
        if self.teeth < z_min:
            raise GeometryError(
                f"pinion.teeth = {self.teeth} must be >= {math.ceil(z_min)} "
                f"(bound {z_min:.2f}): fewer teeth are undercut by the rack; raise it, "
                f"{self._undercut_remedy()}"
            )
        self._check_tip_land()
        _crowning("pinion.lengthwise_crowning", self.lengthwise_crowning, self.module)
        _crowning("pinion.profile_crowning", self.profile_crowning, self.module)
        self._check_tip_edge()

    def _undercut_remedy(self) -> str:
        """What else frees this tooth count of undercut: the pressure angle at which it is
        (the bound falls as the angle grows), if one inside the range does."""
        high = PRESSURE_ANGLE_RANGE_DEG[1]

        def free(angle: float) -> bool:
            bound = min_teeth_without_undercut(angle, self.addendum_coeff,
                                               self.clearance_coeff,
                                               min(self.fillet_radius_coeff,
                                                   max_fillet_radius_coeff(
                                                       angle, self.addendum_coeff,
                                                       self.clearance_coeff)))
            return self.teeth >= bound

        if not free(high):
            return f"or lower addendum_coeff (even at {high:g} deg {self.teeth} teeth are)"
        low = self.pressure_angle_deg
        for _ in range(50):    # bisection to 1e-14 of the bracket
            mid = 0.5 * (low + high)
            low, high = (low, mid) if free(mid) else (mid, high)
        return f"or raise pressure_angle_deg to >= {math.ceil(high * 10) / 10:g} deg"

    def tip_edge_rounding(self) -> tuple[float, float]:
        """Where the tip-edge rounding leaves the involute, and what it leaves of the land:
        :func:`pinion_tip_rounding` for this pinion."""
        alpha = math.radians(self.pressure_angle_deg)
        return pinion_tip_rounding(self.teeth, alpha, self.pitch_radius,
                                   self.pitch_radius + self.addendum_coeff * self.module,
                                   self.tip_edge_radius)

    def _check_tip_edge(self) -> None:
        check_number("pinion.tip_edge_radius", self.tip_edge_radius, low=0.0, unit="mm",
                     scale=1e3, hint="(0: sharp edges)", error=GeometryError)
        if self.tip_edge_rounding()[1] > 0.0:
            return
        alpha = math.radians(self.pressure_angle_deg)
        r_a = self.pitch_radius + self.addendum_coeff * self.module
        # the land shrinks as the radius grows
        # a rounding leaving a land is narrower than the land, below a module
        low = _largest(lambda rho: pinion_tip_rounding(self.teeth, alpha, self.pitch_radius,
                                                       r_a, rho)[1] > 0.0,
                       min(self.tip_edge_radius, self.module))
        raise GeometryError(
            f"pinion.tip_edge_radius = {self.tip_edge_radius * 1e3:g} mm: the two tip-edge "
            f"roundings leave no tip land (sharp, the land is {self.tip_land() * 1e3:.3g} mm); "
            f"allowed below {low * 1e3:.4g} mm")

    def _check_rack(self) -> None:
        """The generating rack's tooth, ``(ha* + c*) m`` deep, must not be pointed.

        Its flanks meet at a depth of ``pi m / (4 tan alpha)`` below the pitch
        line (half its pitch-line width ``pi m / 4`` over ``tan alpha``).
        """
        depth = math.pi / (4.0 * math.tan(math.radians(self.pressure_angle_deg)))
        total = self.addendum_coeff + self.clearance_coeff
        if total >= depth:
            raise GeometryError(
                f"pinion.addendum_coeff = {self.addendum_coeff:g} and clearance_coeff = "
                f"{self.clearance_coeff:g}: their sum {total:g} must be below "
                f"pi / (4 tan {self.pressure_angle_deg:g} deg) = {depth:.4g}, where the "
                "generating rack's tooth comes to a point; addendum_coeff < "
                f"{depth - self.clearance_coeff:.4g} with this clearance"
            )

    def tip_land(self, addendum_coeff: float | None = None) -> float:
        """Tooth thickness on the tip circle [m] (negative: the tooth is pointed).

        ``s_a = 2 r_a (pi / (2 z) + inv(alpha) - inv(alpha_a))``, ``cos alpha_a =
        r_b / r_a`` (unshifted tooth; Litvin & Fuentes, *Gear Geometry*, sec. 10.4).
        """
        ha = self.addendum_coeff if addendum_coeff is None else addendum_coeff
        alpha = math.radians(self.pressure_angle_deg)
        r = 0.5 * self.module * self.teeth
        r_a = r + ha * self.module
        alpha_a = math.acos(r * math.cos(alpha) / r_a)
        return 2.0 * r_a * (math.pi / (2.0 * self.teeth) + float(involute_function(alpha))
                            - float(involute_function(alpha_a)))

    def _check_tip_land(self) -> None:
        """The pinion tooth must keep a tip land (not come to a point below its tip)."""
        land = self.tip_land()
        if land > 0.0:
            return
        # the land shrinks as the addendum grows
        low = _largest(lambda ha: self.tip_land(ha) > 0.0, self.addendum_coeff)
        raise GeometryError(
            f"pinion.addendum_coeff = {self.addendum_coeff:g}: the pinion tooth comes to a "
            f"point below its tip circle (tip land {land * 1e3:.3g} mm); with "
            f"{self.teeth} teeth at {self.pressure_angle_deg:g} deg, addendum_coeff must be "
            f"below {low:.4g}"
        )

    @property
    def pitch_radius(self) -> float:
        """``m z / 2`` [m]."""
        return 0.5 * self.module * self.teeth


def involute_end(base_radius: float, tip_radius: float, rho: float) -> float:
    """Roll length [m] at which a tip-edge rounding of radius ``rho`` ends an involute.

    The rounding circle touches the tip circle from inside (centre at
    ``r_a - rho``) and the involute at radius ``r_t``, roll length
    ``s_t = sqrt(r_t^2 - r_b^2)``. Its centre lies ``rho`` behind the involute
    along the involute's normal, whose radial part is ``s_t / r_t`` and
    tangential part ``r_b / r_t``, so ``r_t^2 + rho^2 - 2 rho s_t = (r_a - rho)^2``:

        s_t = rho + sqrt(rho^2 + s_a^2 - 2 r_a rho),   s_a^2 = r_a^2 - r_b^2.

    NaN when no such circle exists; ``s_a`` for ``rho = 0``.
    """
    root = rho**2 + tip_radius**2 - base_radius**2 - 2.0 * tip_radius * rho
    return rho + math.sqrt(root) if root >= 0.0 else math.nan


def rack_flank_end(alpha: float, rho: float) -> float:
    """How much further along the line of action [m] than its tip line a rack's (a
    face gear's, at its design radius) straight flank ends with a tip-edge rounding of
    radius ``rho``. The rounding's centre is ``rho`` inside the flank and above the
    tip line, so the flank ends ``rho (1 - sin a)`` above the tip line, which the
    line of action, inclined at ``a``, reaches ``rho (1 - sin a) / sin a`` further on.
    """
    return rho * (1.0 - math.sin(alpha)) / math.sin(alpha)


def pinion_tip_rounding(teeth: int, alpha: float, pitch_radius: float, tip_radius: float,
                        rho: float) -> tuple[float, float]:
    """Where a tip-edge rounding of radius ``rho`` leaves a pinion's involute
    (:func:`involute_end`), and what it leaves of the tip land.

    Returns ``(s_t, half_land)``: the roll length [m] at which the involute
    ends, and the half angle [rad] of the tip land left between the tooth's
    two roundings (negative: they overlap; ``-inf`` with ``s_t`` NaN when
    no such circle exists). For ``rho = 0``: ``s_a`` and half the sharp tip
    land's angle.
    """
    r_b = pitch_radius * math.cos(alpha)
    s_t = involute_end(r_b, tip_radius, rho)
    if math.isnan(s_t):
        return math.nan, -math.inf
    r_t = math.hypot(r_b, s_t)
    # half the tooth's angle at r_t, less the angle by which the centre lies inside it
    half = (math.pi / (2.0 * teeth) + float(involute_function(alpha))
            - float(involute_function(math.acos(r_b / r_t))))
    return s_t, half - math.atan2(rho * r_b / r_t, r_t - rho * s_t / r_t)


@dataclass(frozen=True)
class FaceGearStage:
    """One face-gear ring (stage).

    Parameters
    ----------
    teeth : int
        ``N_2``; a multiple of the number of pinions.
    shaper_teeth : int
        ``N_s`` of the generating shaper; pinion teeth + 1..3 unless
        ``force_shaper``.
    inner_radius, outer_radius : float
        Face width as radii [m], inside the usable limits.
    lengthwise_crowning : float
        [m], see :class:`~fe_impact.gears.facegear.FaceGearTooth`.
    inertia : float
        Mass moment of inertia of the ring about its axis [kg m^2].
    force_shaper : bool
        Accept a shaper tooth count outside pinion + 1..3.
    """

    teeth: int
    shaper_teeth: int
    inner_radius: float
    outer_radius: float
    lengthwise_crowning: float
    inertia: float
    force_shaper: bool = False

    def __post_init__(self) -> None:
        _integer("face_gear.stages.teeth", self.teeth, 3)
        _integer("face_gear.stages.shaper_teeth", self.shaper_teeth, 3)
        _positive("face_gear.stages.inner_radius", self.inner_radius)
        _positive("face_gear.stages.outer_radius", self.outer_radius)
        _positive("face_gear.stages.inertia", self.inertia, "kg m^2", 1.0)
        if self.outer_radius <= self.inner_radius:
            raise GeometryError(
                f"face_gear.stages.outer_radius = {self.outer_radius * 1e3:g} mm must exceed "
                f"inner_radius = {self.inner_radius * 1e3:g} mm"
            )
        check_flag("face_gear.stages.force_shaper", self.force_shaper, GeometryError)

    @property
    def face_width(self) -> float:
        """``outer_radius - inner_radius`` [m]."""
        return self.outer_radius - self.inner_radius


@dataclass(frozen=True)
class FlankFriction:
    """Coulomb friction between the flanks of every mesh of the set.

    The one source of the coefficients for the FE contact of the calibration
    (:class:`~fe_impact.fe.case.ContactSpec`'s ``mu_static``, ``mu_dynamic``)
    and for the lumped switching model (its ``Friction``).

    Parameters
    ----------
    mu_static : float
        Coefficient [-] at zero sliding speed, in [0, 1); default the seed's 0.05
        (greased flanks, seed section 4, eqs. 9-10).
    mu_dynamic : float
        Coefficient [-] once sliding, in [0, ``mu_static``]; default the seed's 0.02.
        Both 0: frictionless flanks.
    """

    mu_static: float = SEED_MU_STATIC
    mu_dynamic: float = SEED_MU_DYNAMIC

    def __post_init__(self) -> None:
        hint = "(Coulomb coefficient of the flanks; 0 and 0: frictionless)"
        for name in ("mu_static", "mu_dynamic"):
            check_number(f"friction.{name}", getattr(self, name), low=0.0,
                         high=MAX_FLANK_FRICTION, high_open=True, hint=hint,
                         error=GeometryError)
        if self.mu_static < self.mu_dynamic:
            raise GeometryError(
                f"friction.mu_static = {self.mu_static!r}: must be at least friction.mu_dynamic "
                f"= {self.mu_dynamic!r} (the static coefficient is never below the dynamic "
                "one); swap them?")

    @property
    def active(self) -> bool:
        """True unless both coefficients are 0."""
        return self.mu_static > 0.0 or self.mu_dynamic > 0.0


@dataclass(frozen=True)
class GearSet:
    """A pinion design, its face-gear stages and their material.

    Parameters
    ----------
    name : str
        Label used in outputs.
    pinion : Pinion
    stages : tuple of FaceGearStage
        Nested rings; any order, but they must not overlap radially.
    material : Material
        Shared by pinion and face gears.
    n_pinions : int
        Identical pinions around the face gear (4 in the seed).
    notes : str
        Free text (sources, choices).
    face_gear_module : float or None
        Face-gear module [m]; None means the pinion's. A different value is
        invalid: a face gear meshes only with a pinion of its module.
    inner_limit : {"conjugate", "undercut"}
        Which inner limit the inner radii are checked against: the stricter
        conjugate-tip limit (default) or the undercut limit.
    face_tip_edge_radius : float
        Radius [m] of the rounding between each face-gear flank and its top
        land, every ring, >= 0 (0: sharp edges); the top land must take both
        roundings over the whole face (:meth:`face_tip_edge_limit`).
    friction : FlankFriction
        Coulomb friction between the flanks (default the seed's greased flanks).
    """

    name: str
    pinion: Pinion
    stages: tuple[FaceGearStage, ...]
    material: Material
    n_pinions: int = 4
    notes: str = ""
    face_gear_module: float | None = None
    inner_limit: str = "conjugate"
    face_tip_edge_radius: float = DEFAULT_FACE_TIP_EDGE_RADIUS
    friction: FlankFriction = FlankFriction()

    def __post_init__(self) -> None:
        object.__setattr__(self, "stages", tuple(self.stages))
        if not isinstance(self.name, str) or not self.name:
            raise invalid("name", self.name, "must be a non-empty string", GeometryError)
        check_integer("n_pinions", self.n_pinions, low=PINIONS_RANGE[0], high=PINIONS_RANGE[1],
                      error=GeometryError)
        if not self.stages:
            raise GeometryError("face_gear.stages is empty: give at least one stage")
        if len(self.stages) > STAGES_RANGE[1]:
            raise GeometryError(
                f"face_gear.stages: {len(self.stages)} stages given, at most "
                f"{STAGES_RANGE[1]} allowed {_RANGE_HINT}")
        check_choice("face_gear.inner_limit", self.inner_limit, INNER_LIMIT_RULES, GeometryError)
        self._check_module()
        for number, stage in enumerate(self.stages, start=1):
            self._check_stage(number, stage)
        self._check_overlap()
        self._check_pinion_face()
        self._check_face_tip_edge()

    # -- validation -----------------------------------------------------------------
    def _check_module(self) -> None:
        module = self.face_gear_module
        if module is None:
            return
        _positive("face_gear.module", module)
        if not math.isclose(module, self.pinion.module, rel_tol=1e-9):
            raise GeometryError(
                f"face_gear.module = {module * 1e3:g} mm differs from pinion.module = "
                f"{self.pinion.module * 1e3:g} mm: a face gear meshes only with a pinion of "
                "the same module; give both the same value (or leave face_gear.module out)"
            )

    def _label(self, number: int) -> str:
        return f"stage {number} ({self.stages[number - 1].teeth} teeth)"

    def _check_stage(self, number: int, stage: FaceGearStage) -> None:
        label = self._label(number)
        if stage.teeth % self.n_pinions:
            below = stage.teeth - stage.teeth % self.n_pinions
            raise GeometryError(
                f"{label}: teeth = {stage.teeth} must be a multiple of n_pinions = "
                f"{self.n_pinions} (pinions arranged symmetrically): use {below} or "
                f"{below + self.n_pinions}"
            )
        low, high = (self.pinion.teeth + e for e in SHAPER_TEETH_EXCESS)
        if stage.shaper_teeth < self.pinion.teeth:
            raise GeometryError(
                f"{label}: shaper_teeth = {stage.shaper_teeth} must be at least pinion.teeth = "
                f"{self.pinion.teeth}, force_shaper or not: the flank of a face gear cut by a "
                "smaller shaper curves away from the pinion's, so they make no point contact "
                f"(usual: {low}..{high})"
            )
        if stage.shaper_teeth == self.pinion.teeth and self.pinion.lengthwise_crowning <= 0.0:
            raise GeometryError(
                f"{label}: shaper_teeth = {stage.shaper_teeth} equals pinion.teeth and the "
                "pinion has no lengthwise crowning: the teeth touch along a line, not at a "
                "point; crown the pinion (pinion.lengthwise_crowning_um > 0) or use a shaper "
                f"with {low}..{high} teeth"
            )
        if not stage.force_shaper and not low <= stage.shaper_teeth <= high:
            raise GeometryError(
                f"{label}: shaper_teeth = {stage.shaper_teeth} must lie in [{low}, {high}] "
                f"(pinion teeth + {SHAPER_TEETH_EXCESS[0]}..{SHAPER_TEETH_EXCESS[1]}); "
                "set force_shaper = true to accept it"
            )
        if stage.shaper_teeth >= stage.teeth:
            raise GeometryError(
                f"{label}: shaper_teeth = {stage.shaper_teeth} must be < teeth = {stage.teeth}"
            )
        _crowning(f"{label}: lengthwise_crowning", stage.lengthwise_crowning, self.pinion.module)
        self._check_shaper_tip(label, stage.shaper_teeth)
        limits = self._usable_limits(label, number - 1)
        inner, outer = limits.inner(self.inner_limit), limits.outer_pointing
        usable = (f"the {limits.inner_reason(self.inner_limit)}; usable "
                  f"[{inner * 1e3:.3f}, {outer * 1e3:.3f}] mm, the pointing limit outside")
        if stage.inner_radius < inner:
            raise GeometryError(
                f"{label}: inner_radius = {stage.inner_radius * 1e3:.3f} mm is below the "
                f"inner limit: raise it to at least {inner * 1e3:.3f} mm ({usable})"
            )
        if stage.outer_radius > outer:
            raise GeometryError(
                f"{label}: outer_radius = {stage.outer_radius * 1e3:.3f} mm is beyond the "
                f"pointing limit, where the tooth comes to a point: lower it to at most "
                f"{outer * 1e3:.3f} mm ({usable})"
            )
        r_2 = limits.pitch_radius
        if not stage.inner_radius < r_2 < stage.outer_radius:
            raise GeometryError(
                f"{label}: the face {stage.inner_radius * 1e3:.3f} to "
                f"{stage.outer_radius * 1e3:.3f} mm does not hold the pitch radius "
                f"{r_2 * 1e3:.3f} mm, where the pinion's mid-face meshes (the contact "
                f"analysis' design point): allowed inner_radius < {r_2 * 1e3:.3f} mm < "
                "outer_radius"
            )

    def _usable_limits(self, label: str, index: int) -> FaceGearLimits:
        """The stage's limits; refused, saying what to change, when the usable face width
        is empty or does not hold the pitch radius ``r_2`` (the design contact point)."""
        stage = self.stages[index]
        try:
            limits = self.stage_limits(index)
        except GeometryError as exc:
            raise GeometryError(f"{label}: {exc}; {self._more_teeth(stage)}") from exc
        inner, r_2 = limits.inner(self.inner_limit), limits.pitch_radius
        if not inner < r_2 < limits.outer_pointing:
            raise GeometryError(
                f"{label}: the usable face {inner * 1e3:.3f} to "
                f"{limits.outer_pointing * 1e3:.3f} mm does not hold the pitch radius "
                f"{r_2 * 1e3:.3f} mm, where the pinion meshes ("
                f"{limits.inner_reason(self.inner_limit)}); {self._more_teeth(stage)}")
        return limits

    def _more_teeth(self, stage: FaceGearStage) -> str:
        """Advice for a face gear too small for its shaper: the fewest teeth (a multiple
        of n_pinions, up to 20 shaper teeth) whose usable face holds the pitch radius
        (the inner limit falls towards 0.9-0.97 r_2 as the face gear grows), else to raise
        the pressure angle."""
        p, n = self.pinion, self.n_pinions
        for teeth in range(stage.teeth + n - stage.teeth % n, 20 * stage.shaper_teeth, n):
            try:
                limits = face_gear_limits(teeth, stage.shaper_teeth, p.module,
                                          p.pressure_angle_deg, p.addendum_coeff,
                                          p.clearance_coeff)
            except GeometryError:
                continue
            if limits.inner(self.inner_limit) < limits.pitch_radius < limits.outer_pointing:
                return (f"give it at least {teeth} teeth (a multiple of n_pinions = {n}), or "
                        "raise the pressure angle")
        return "raise the pressure angle or the face-gear teeth"

    def _check_shaper_tip(self, label: str, shaper_teeth: int) -> None:
        """The shaper cuts the face gear's root with its tip, ``(ha* + c*) m`` above its
        pitch circle (deeper than the pinion's addendum): it must keep a tip land there.
        Its tooth's half angle at radius ``r`` is ``pi / (2 N_s) + inv(alpha0) -
        inv(alpha_r)``, ``cos(alpha_r) = r_bs / r``."""
        p = self.pinion
        alpha = math.radians(p.pressure_angle_deg)
        r_ps = 0.5 * p.module * shaper_teeth
        r_as = r_ps + (p.addendum_coeff + p.clearance_coeff) * p.module
        alpha_a = math.acos(r_ps * math.cos(alpha) / r_as)
        half = (math.pi / (2 * shaper_teeth) + math.tan(alpha) - alpha
                - (math.tan(alpha_a) - alpha_a))
        if half <= 0.0:
            raise GeometryError(
                f"{label}: the {shaper_teeth}-tooth shaper is pointed at its tip radius "
                f"{r_as * 1e3:.3f} mm ((pinion.addendum_coeff + clearance_coeff) m above its "
                f"pitch circle; its tip land would be {2 * r_as * half * 1e3:.3f} mm): lower "
                "addendum_coeff or clearance_coeff, or give the shaper more teeth"
            )

    def pinion_face_limit(self) -> float:
        """Widest pinion face [m] that keeps the pinions clear of each other.

        The pinion's mid-face sits at the engaged ring's pitch radius ``r_2``
        (:attr:`fe_impact.gears.tca.GearPair.z0`), so its inner end is at
        ``r_2 - b/2``. Pinions ``2 pi / n`` apart are each a cylinder of its tip
        radius ``r_a`` about its axis, their axes radial in one plane: the
        cylinders' facing sides cross on the bisector of two axes, ``r_a cot(pi / n)``
        from the face-gear axis along each, and the cylinders clash when they
        reach inside it (their flat inner ends pass each other outside it). For
        one or two pinions: ``r_a``, clear of the axis. The innermost ring binds.
        """
        p = self.pinion
        r_a = p.pitch_radius + p.addendum_coeff * p.module
        clear = r_a / math.tan(math.pi / self.n_pinions) if self.n_pinions > 2 else r_a
        r_2 = min(0.5 * p.module * s.teeth for s in self.stages)
        return 2.0 * (r_2 - clear)

    def _check_pinion_face(self) -> None:
        limit = self.pinion_face_limit()
        if self.pinion.face_width > limit:
            p = self.pinion
            r_2 = min(0.5 * p.module * s.teeth for s in self.stages)
            inner = r_2 - 0.5 * p.face_width
            reach = (f"{-inner * 1e3:.4g} mm past the face-gear axis" if inner < 0.0
                     else f"radius {inner * 1e3:.4g} mm")
            raise GeometryError(
                f"pinion.face_width = {p.face_width * 1e3:g} mm: centred on the innermost "
                f"ring's pitch radius {r_2 * 1e3:g} mm, the pinion reaches {reach}, inside "
                f"radius {(r_2 - 0.5 * limit) * 1e3:.4g} mm where it hits its neighbours "
                f"({self.n_pinions} pinions, tip radius "
                f"{(p.pitch_radius + p.addendum_coeff * p.module) * 1e3:.4g} mm); allowed at "
                f"most {max(limit, 0.0) * 1e3:.4g} mm"
            )

    def face_tip_edge_limit(self, index: int) -> tuple[float, float]:
        """Largest face-gear tip-edge radius [m] stage ``index`` (0-based) takes, and where.

        At radius ``L`` the face gear is a rack of pressure angle ``alpha_L``,
        ``cos alpha_L = r_2 cos alpha0 / L``; its flank meets the top land at
        ``90 deg + alpha_L``, so a rounding of radius ``rho`` takes
        ``rho tan(45 deg - alpha_L / 2)`` of the land at each edge. The land
        ``2 L psi(L)`` (``psi``: :meth:`FaceGearTooth.top_land_half_angle`)
        is checked at :data:`_LAND_CHECKS` radii over the face. Returns the
        smallest ``L psi / tan(45 deg - alpha_L / 2)`` and its ``L``.
        """
        stage, tooth = self.stages[index], self.face_gear_tooth(index)
        radius = np.linspace(stage.inner_radius, stage.outer_radius, _LAND_CHECKS)
        alpha0 = math.radians(self.pinion.pressure_angle_deg)
        alpha = np.arccos(np.minimum(tooth.pitch_radius * math.cos(alpha0) / radius, 1.0))
        limit = radius * tooth.top_land_half_angle(radius) / np.tan(0.25 * np.pi - 0.5 * alpha)
        i = int(np.argmin(limit))
        return float(limit[i]), float(radius[i])

    def _check_face_tip_edge(self) -> None:
        rho = check_number("face_gear.tip_edge_radius", self.face_tip_edge_radius, low=0.0,
                           unit="mm", scale=1e3, hint="(0: sharp edges)", error=GeometryError)
        if rho == 0.0:
            return
        for index in range(len(self.stages)):
            limit, where = self.face_tip_edge_limit(index)
            if rho >= limit:
                raise GeometryError(
                    f"face_gear.tip_edge_radius = {rho * 1e3:g} mm: {self._label(index + 1)}'s "
                    f"top land at radius {where * 1e3:.2f} mm takes two roundings below "
                    f"{limit * 1e3:.3g} mm only; give a smaller radius or an outer_radius "
                    "where the land is wider")

    def _check_overlap(self) -> None:
        order = sorted(range(len(self.stages)), key=lambda i: self.stages[i].inner_radius)
        for i, j in zip(order, order[1:], strict=False):
            a, b = self.stages[i], self.stages[j]
            overlap = a.outer_radius - b.inner_radius
            if overlap > 0.0:
                raise GeometryError(
                    f"{self._label(i + 1)} and {self._label(j + 1)} overlap radially by "
                    f"{overlap * 1e3:.3f} mm: outer_radius {a.outer_radius * 1e3:.3f} mm > "
                    f"inner_radius {b.inner_radius * 1e3:.3f} mm; lower stage {i + 1}'s "
                    f"outer_radius to at most {b.inner_radius * 1e3:.3f} mm or raise stage "
                    f"{j + 1}'s inner_radius to at least {a.outer_radius * 1e3:.3f} mm (each "
                    "must keep its pitch radius inside its face)"
                )

    # -- geometry ---------------------------------------------------------------------------
    @property
    def module(self) -> float:
        """Common module [m]."""
        return self.pinion.module

    def stage_limits(self, index: int) -> FaceGearLimits:
        """Usable-radius limits of stage ``index`` (0-based)."""
        stage = self.stages[index]
        p = self.pinion
        return face_gear_limits(
            stage.teeth,
            stage.shaper_teeth,
            p.module,
            p.pressure_angle_deg,
            p.addendum_coeff,
            p.clearance_coeff,
        )

    def pinion_tooth(self) -> PinionTooth:
        """Tooth geometry of the pinion."""
        p = self.pinion
        return PinionTooth(
            teeth=p.teeth,
            module=p.module,
            pressure_angle_deg=p.pressure_angle_deg,
            addendum_coeff=p.addendum_coeff,
            clearance_coeff=p.clearance_coeff,
            fillet_radius_coeff=p.fillet_radius_coeff,
            face_width=p.face_width,
            lengthwise_crowning=p.lengthwise_crowning,
            profile_crowning=p.profile_crowning,
        )

    def face_gear_tooth(self, index: int) -> FaceGearTooth:
        """Tooth geometry of stage ``index`` (0-based)."""
        stage, p = self.stages[index], self.pinion
        return FaceGearTooth(
            teeth=stage.teeth,
            shaper_teeth=stage.shaper_teeth,
            module=p.module,
            pressure_angle_deg=p.pressure_angle_deg,
            addendum_coeff=p.addendum_coeff,
            clearance_coeff=p.clearance_coeff,
            inner_radius=stage.inner_radius,
            outer_radius=stage.outer_radius,
            lengthwise_crowning=stage.lengthwise_crowning,
        )


# -- TOML -------------------------------------------------------------------------------------
# Each key carries its unit in its suffix; a reader takes the value, checks its type
# and converts it to SI. Ranges and the relations between values are the records'.
_Read = Callable[[Reader, Mapping[str, Any], str, str], Any]


def _si(scale: float) -> _Read:
    """A number in the key's unit, times ``scale`` to SI."""

    def read(r: Reader, t: Mapping[str, Any], where: str, key: str) -> float:
        return r.number(t, where, key) * scale

    return read


def _count(r: Reader, t: Mapping[str, Any], where: str, key: str) -> int:
    return r.integer(t, where, key)


def _name(r: Reader, t: Mapping[str, Any], where: str, key: str) -> str:
    return r.string(t, where, key)


def _text(r: Reader, t: Mapping[str, Any], where: str, key: str) -> str:
    return r.string(t, where, key, empty=True)


def _flag(r: Reader, t: Mapping[str, Any], where: str, key: str) -> bool:
    return r.boolean(t, where, key)


# key -> (record field, reader)
_TOP_KEYS: dict[str, tuple[str, _Read]] = {
    "name": ("name", _name), "notes": ("notes", _text), "n_pinions": ("n_pinions", _count),
}
_MATERIAL_KEYS = {
    "youngs_modulus_pa": ("youngs_modulus", _si(1.0)),
    "poisson_ratio": ("poisson_ratio", _si(1.0)),
    "density_kg_m3": ("density", _si(1.0)),
    "yield_strength_pa": ("yield_strength", _si(1.0)),
    "contact_stress_limit_pa": ("contact_stress_limit", _si(1.0)),
    "bending_stress_limit_pa": ("bending_stress_limit", _si(1.0)),
}
_PINION_KEYS = {
    "teeth": ("teeth", _count),
    "module_mm": ("module", _si(_MM)),
    "pressure_angle_deg": ("pressure_angle_deg", _si(1.0)),
    "addendum_coeff": ("addendum_coeff", _si(1.0)),
    "clearance_coeff": ("clearance_coeff", _si(1.0)),
    "face_width_mm": ("face_width", _si(_MM)),
    "fillet_radius_coeff": ("fillet_radius_coeff", _si(1.0)),
    "lengthwise_crowning_um": ("lengthwise_crowning", _si(_UM)),
    "profile_crowning_um": ("profile_crowning", _si(_UM)),
    "inertia_kg_m2": ("inertia", _si(1.0)),
    "tip_edge_radius_mm": ("tip_edge_radius", _si(_MM)),
}
_FRICTION_KEYS = {
    "mu_static": ("mu_static", _si(1.0)),
    "mu_dynamic": ("mu_dynamic", _si(1.0)),
}
_FACE_GEAR_KEYS = {
    "module_mm": ("face_gear_module", _si(_MM)),
    "inner_limit": ("inner_limit", _text),
    "tip_edge_radius_mm": ("face_tip_edge_radius", _si(_MM)),
}
_STAGE_KEYS = {
    "teeth": ("teeth", _count),
    "shaper_teeth": ("shaper_teeth", _count),
    "inner_radius_mm": ("inner_radius", _si(_MM)),
    "outer_radius_mm": ("outer_radius", _si(_MM)),
    "lengthwise_crowning_um": ("lengthwise_crowning", _si(_UM)),
    "inertia_kg_m2": ("inertia", _si(1.0)),
    "force_shaper": ("force_shaper", _flag),
}
# the keys each table may leave out (their fields have defaults)
_TOP_OPTIONAL = {"notes", "n_pinions"}
_MATERIAL_OPTIONAL = {"contact_stress_limit_pa", "bending_stress_limit_pa"}
_PINION_OPTIONAL = {"tip_edge_radius_mm"}
_FACE_GEAR_OPTIONAL = {"inner_limit", "module_mm", "tip_edge_radius_mm"}
_STAGE_OPTIONAL = {"force_shaper"}
_READER = Reader(error=GeometryError, syntax="toml")


def _convert(
    data: Mapping[str, Any],
    keys: Mapping[str, tuple[str, _Read]],
    where: str,
    optional: Collection[str] = (),
    more: Collection[str] = (),
) -> dict[str, Any]:
    """Map TOML keys to record fields in SI units, rejecting unknown or missing keys.

    ``more`` are further keys allowed (and required unless ``optional``) here, read by
    the caller.
    """
    r = _READER
    r.keys(data, where, {*keys, *more}, required=(set(keys) | set(more)) - set(optional))
    out: dict[str, Any] = {}
    for key in data:
        if key in keys:
            field, read = keys[key]
            out[field] = read(r, data, where, key)
    return out


def _stage_from_dict(data: Mapping[str, Any], number: int) -> FaceGearStage:
    where = f"face_gear.stages {number}"
    fields = _convert(data, _STAGE_KEYS, where, _STAGE_OPTIONAL)
    try:
        return FaceGearStage(**fields)
    except GeometryError as exc:
        raise GeometryError(f"stage {number}: {exc}") from exc


def gearset_from_dict(data: Mapping[str, Any]) -> GearSet:
    """Build a validated :class:`GearSet` from parsed TOML (see the module docstring).

    Raises
    ------
    GeometryError
        For unknown or missing keys and for any invalid value; the message
        names the key or field, the value and what is allowed.
    """
    r = _READER
    top = _convert(data, _TOP_KEYS, "", _TOP_OPTIONAL | {"friction"},
                   more=("material", "pinion", "face_gear", "friction"))
    try:
        material = Material(**_convert(r.table(data, "", "material"), _MATERIAL_KEYS,
                                       "material", _MATERIAL_OPTIONAL))
        pinion = Pinion(**_convert(r.table(data, "", "pinion"), _PINION_KEYS, "pinion",
                                   _PINION_OPTIONAL))
        face_data = r.table(data, "", "face_gear")
        face = _convert(face_data, _FACE_GEAR_KEYS, "face_gear", _FACE_GEAR_OPTIONAL,
                        more=("stages",))
        raw_stages = r.array(face_data, "face_gear", "stages", required=True)
        stages = tuple(_stage_from_dict(s, i) for i, s in enumerate(raw_stages, start=1))
        friction = FlankFriction(**_convert(r.table(data, "", "friction", {}), _FRICTION_KEYS,
                                            "friction", set(_FRICTION_KEYS)))
        return GearSet(pinion=pinion, stages=stages, material=material, friction=friction,
                       **top, **face)
    except GeometryError as exc:
        raise GeometryError(_file_keys(str(exc))) from exc


def _file_keys(message: str) -> str:
    """A record's message in the file's words: ``pinion.module = -3 mm`` becomes
    ``[pinion] module_mm = -3 mm``, a stage's ``inner_radius = ...`` becomes
    ``inner_radius_mm = ...`` (the values are already in the keys' units)."""
    for table, keys in (("pinion", _PINION_KEYS), ("material", _MATERIAL_KEYS),
                        ("face_gear", _FACE_GEAR_KEYS), ("friction", _FRICTION_KEYS)):
        for key, (name, _) in keys.items():
            if table == "face_gear":   # its messages say face_gear.module for face_gear_module
                name = name.removeprefix("face_gear_").removeprefix("face_")
            message = re.sub(rf"(?<![\w.\[]){table}\.{name}\b", f"[{table}] {key}", message)
    for key, (name, _) in _STAGE_KEYS.items():
        message = re.sub(rf"\bface_gear\.stages\.{name}\b", f"[[face_gear.stages]] {key}",
                         message)
        if key != name and message.startswith("stage "):
            # a stage's own field where its message names it: an identifier
            # (inner_radius) anywhere, a plain word (inertia) before its value
            where = rf"(?<![\w.\]]){name}\b" if "_" in name else rf"(?<=: ){name}(?= = )"
            message = re.sub(where, key, message)
    return message


def load_gearset(path: str | Path) -> GearSet:
    """Read and validate a gear-set TOML file.

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Raises
    ------
    GeometryError
        If the file is missing, is not TOML, or describes an invalid gear
        set; the message starts with the path.
    """
    path = Path(path)
    data = read_document(path, "gear-set file", GeometryError, "toml")
    try:
        gearset = gearset_from_dict(data)
    except GeometryError as exc:
        raise GeometryError(f"{path}: {exc}") from exc
    logger.info("loaded gear set %r from %s", gearset.name, path)
    return gearset


def default_gearset_path() -> Path:
    """The file of the seed study's gear set: ``seed.toml`` next to this module, the one
    copy (packaged with it; the shipped drives under the source tree's ``geometry/``
    are further examples, not defaults).

    Raises
    ------
    GeometryError
        If the file is missing (a broken installation).
    """
    path = Path(__file__).resolve().parent / "seed.toml"
    if not path.is_file():
        raise GeometryError(f"default gear set not found at {path}: reinstall fe-impact")
    return path


def default_gearset() -> GearSet:
    """The seed study's gear set (:func:`default_gearset_path`), m = 3 for all gears."""
    return load_gearset(default_gearset_path())
