"""Lumped torsional model of a multistage face-gear drive with ratio switching.

Degrees of freedom (rotations, positive in the driving sense): the pinion(s),
each face-gear ring, and the output that carries the load. The ``n_pinions``
identical pinions of the seed's layout mesh in phase (ring teeth are a
multiple of their number), so they are lumped: one angle, ``n`` times the
inertia, ``n`` identical meshes. Each ring sits on the output through a
torsional coupling (its web). The pinion engages one ring at a time.

Mesh of the engaged ring ``i`` (see `fe_impact.switching.geometry`): mesh
coordinate ``x = r_bp theta_p - r_bi theta_i``, ``r_bi = r_i cos(alpha0)``,
with a free play ``j_n / 2`` on each flank. Tooth pair ``k`` at roll ``s_k``
has the approach

    drive flank: h_k = x - j_n/2 - g(s_k) - e(u)
    coast flank: h_k = -x - j_n/2 - g(s'_k) + e(u)

where ``g`` is zero on the active path and the tip-corner gap outside it,
and ``e(u) = A sin(2 pi u / p_b)`` a transmission error of the pinion (an
excitation at mesh frequency; 0 for an ideal drive). The number of pairs in
contact, hence the mesh stiffness, follows from the contact path, i.e. from
the contact ratio. Each pair carries the ADAMS IMPACT force of the law
tables (`fe_impact.switching.calibration`), chosen at its contact onset
from its closing speed; the forces enter the equations through the
derivatives of ``h_k`` (virtual work), so an undamped, frictionless run
conserves energy. Coulomb friction (seed eqs. 9-10, smoothed sign) acts
along the profile with sliding speed ``omega_p s - omega_i r_i sin(alpha0)``.

Ratio switching: a `StageSchedule` is a list of segments (duration, engaged
stage, pinion speed, load); at a segment boundary where the stage changes,
the pinion leaves its ring and enters the new one, placed at
``engage_position`` within the new backlash. All rings turn with the output,
so the new ring's teeth move at the wrong speed and the first contact is an
impact (`geometry.switching_speed`), after which the load transfers. Speed
and load steps between segments are blended over ``ramp_time`` with the
ADAMS STEP cubic.

This module holds the configuration records; `fe_impact.switching.simulation`
runs them.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from fe_impact.errors import CaseError
from fe_impact.gears.gearset import GearSet, default_gearset
from fe_impact.switching.calibration import LawSet, closed_form_laws
from fe_impact.switching.geometry import (
    CORNER_SOURCES,
    MeshGeometry,
    default_backlash,
    mesh_geometry,
)

logger = logging.getLogger(__name__)

__all__ = ["DRIVES", "RPM", "DriveModel", "Friction", "LoadSeries", "Segment",
           "StageSchedule"]

DRIVES = ("speed", "torque")
RPM = 2.0 * math.pi / 60.0  # rad/s per r/min
#: Web of the ring-to-output coupling: thickness and hub radius [m] (see
#: `DriveModel.couplings`).
_WEB_THICKNESS = 10e-3
_HUB_RADIUS = 40e-3


@dataclass(frozen=True)
class Friction:
    """Coulomb friction between the flanks (seed eqs. 9-10), ADAMS-style smoothing.

    Attributes
    ----------
    static, dynamic : float
        Coefficients [-] (seed section 4: 0.05 and 0.02, greased).
    stiction_speed : float
        Below this sliding speed [m/s] the sign is smoothed by the STEP cubic
        (the seed's ``sgn(v12)`` would make the equations discontinuous).
    transition_speed : float
        Sliding speed [m/s] at which the coefficient has blended from static
        to dynamic.
    """

    static: float = 0.05
    dynamic: float = 0.02
    stiction_speed: float = 1e-3
    transition_speed: float = 1e-2

    def __post_init__(self) -> None:
        for name in ("static", "dynamic"):
            if not 0.0 <= getattr(self, name) < 1.0:
                raise CaseError(f"friction.{name} = {getattr(self, name)!r} must lie in [0, 1)")
        if not 0.0 < self.stiction_speed < self.transition_speed:
            raise CaseError(
                f"friction speeds must satisfy 0 < stiction_speed ({self.stiction_speed!r}) "
                f"< transition_speed ({self.transition_speed!r}) m/s"
            )


@dataclass(frozen=True, eq=False)
class LoadSeries:
    """Output load torque of a segment as a time series, linear between its points.

    Attributes
    ----------
    times : ndarray, shape (n,)
        [s] from the segment's start: first 0, strictly increasing, n >= 2.
    torques : ndarray, shape (n,)
        Load torque on the output at ``times`` [N m], >= 0.
    source : str
        Where the series came from (a file name), for messages and reports.
    """

    times: np.ndarray
    torques: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        times = np.asarray(self.times, dtype=float)
        torques = np.asarray(self.torques, dtype=float)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "torques", torques)
        where = f"load series {self.source}".rstrip()
        if times.ndim != 1 or times.shape != torques.shape or times.size < 2:
            raise CaseError(f"{where}: needs two or more (time, torque) points, got "
                            f"{times.size} times and {torques.size} torques")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(torques))):
            raise CaseError(f"{where}: times and torques must be finite numbers (no NaN)")
        if times[0] != 0.0 or np.any(np.diff(times) <= 0.0):
            raise CaseError(f"{where}: times must start at 0 s and increase strictly")
        if np.any(torques < 0.0):
            raise CaseError(f"{where}: torques must be >= 0 N m (the load resists the "
                            "rotation)")

    def profile(self, duration: float) -> tuple[np.ndarray, np.ndarray]:
        """Break points ``(t, torque)`` of the series over ``[0, duration]`` [s, N m], the
        last at ``duration`` (interpolated); CaseError if the series ends before it."""
        if self.times[-1] < duration * (1.0 - 1e-12):
            raise CaseError(f"load series {self.source}: ends at {self.times[-1]:g} s, "
                            f"before the segment's {duration:g} s")
        inside = self.times < duration
        t = np.append(self.times[inside], duration)
        return t, np.interp(t, self.times, self.torques)


@dataclass(frozen=True)
class Segment:
    """One segment of a schedule.

    Attributes
    ----------
    duration : float
        [s], > 0 and at least the blend time after the first segment.
    stage : int
        Engaged ring, from 1.
    speed_rpm : float
        Pinion speed at the segment's start [r/min] (the reference speed for a
        torque-driven pinion).
    load : float
        Load torque on the output at the segment's start [N m], resisting the
        rotation (with ``load_series``: the series' first value).
    input_torque : float
        Torque on the pinions [N m], torque-driven pinion only.
    speed_end_rpm : float or None
        Pinion speed at the segment's end [r/min], reached linearly; None: constant.
    load_end : float or None
        Load at the segment's end [N m], reached linearly; None: constant.
    load_series : LoadSeries or None
        The load as a time series from the segment's start (in place of ``load``
        and ``load_end``).
    blend : float or None
        Time over which speed, load and input torque blend from the previous
        segment's end values to this segment's (the ADAMS STEP cubic) [s]; None: the
        model's ``ramp_time``. Not used on the first segment.
    engage : float or None
        Where the mesh starts within its free play when this segment switches to
        another stage, -1 (coast flank) .. 1 (drive flank); None: the model's
        ``engage_position``.
    """

    duration: float
    stage: int
    speed_rpm: float
    load: float = 0.0
    input_torque: float = 0.0
    speed_end_rpm: float | None = None
    load_end: float | None = None
    load_series: LoadSeries | None = None
    blend: float | None = None
    engage: float | None = None

    def __post_init__(self) -> None:
        if self.load_series is not None:
            if self.load_end is not None:
                raise CaseError("segment: give load_end or load_series, not both")
            object.__setattr__(self, "load", float(self.load_series.torques[0]))
        if not (math.isfinite(self.duration) and self.duration > 0.0):
            raise CaseError(f"segment duration = {self.duration!r} s must be > 0")
        if isinstance(self.stage, bool) or not isinstance(self.stage, int) or self.stage < 1:
            raise CaseError(f"segment stage = {self.stage!r} must be an integer >= 1")
        for name in ("speed_rpm", "load", "input_torque", "speed_end_rpm", "load_end",
                     "blend", "engage"):
            value = getattr(self, name)
            if value is not None and not math.isfinite(value):
                raise CaseError(f"segment {name} = {value!r} must be finite")
        for name in ("speed_rpm", "load", "speed_end_rpm", "load_end", "blend"):
            value = getattr(self, name)
            if value is not None and value < 0.0:
                raise CaseError(f"segment {name} = {value!r} must be >= 0")
        if self.engage is not None and not -1.0 <= self.engage <= 1.0:
            raise CaseError(f"segment engage = {self.engage!r} must lie in [-1, 1]")
        if self.load_series is not None:
            self.load_series.profile(self.duration)

    @property
    def end_speed_rpm(self) -> float:
        """Pinion speed at the segment's end [r/min]."""
        return self.speed_rpm if self.speed_end_rpm is None else self.speed_end_rpm

    @property
    def max_speed_rpm(self) -> float:
        """Largest pinion speed of the segment [r/min] (speeds are linear in time)."""
        return max(self.speed_rpm, self.end_speed_rpm)

    @property
    def mean_speed_rpm(self) -> float:
        """Time-average pinion speed [r/min]."""
        return 0.5 * (self.speed_rpm + self.end_speed_rpm)

    def load_profile(self) -> tuple[np.ndarray, np.ndarray]:
        """Break points ``(t, load)`` of the load over the segment [s, N m], from 0 to
        ``duration``, linear between them."""
        if self.load_series is not None:
            return self.load_series.profile(self.duration)
        end = self.load if self.load_end is None else self.load_end
        return np.array([0.0, self.duration]), np.array([self.load, end])

    @property
    def max_load(self) -> float:
        """Largest load torque of the segment [N m]."""
        return float(self.load_profile()[1].max())

    @property
    def end_load(self) -> float:
        """Load torque at the segment's end [N m]."""
        return float(self.load_profile()[1][-1])


@dataclass(frozen=True)
class StageSchedule:
    """Segments run one after the other from t = 0 (the seed's 5 s time functions)."""

    segments: tuple[Segment, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "segments", tuple(self.segments))
        if not self.segments:
            raise CaseError("a schedule needs at least one segment")

    @property
    def duration(self) -> float:
        """Total duration [s]."""
        return float(sum(s.duration for s in self.segments))

    @property
    def start_times(self) -> np.ndarray:
        """Start of each segment [s]."""
        return np.concatenate([[0.0], np.cumsum([s.duration for s in self.segments])[:-1]])

    @property
    def stages(self) -> tuple[int, ...]:
        """Stages engaged, in order of first use."""
        return tuple(dict.fromkeys(s.stage for s in self.segments))

    def scaled(self, duration: float) -> StageSchedule:
        """The same schedule stretched to a total ``duration`` [s]."""
        if not (math.isfinite(duration) and duration > 0.0):
            raise CaseError(f"duration = {duration!r} s must be > 0")
        factor = duration / self.duration

        def stretch(seg: Segment) -> Segment:
            series = seg.load_series
            if series is not None:
                series = LoadSeries(series.times * factor, series.torques, series.source)
            return replace(seg, duration=seg.duration * factor, load_series=series)

        return StageSchedule(tuple(stretch(s) for s in self.segments))


@dataclass(frozen=True)
class DriveModel:
    """Parameters of the torsional model; ``None`` fields are derived (see properties).

    Attributes
    ----------
    gearset : GearSet
        Pinion, rings and material (default: the seed's set).
    n_pinions : int or None
        Identical pinions in phase; None: the gear set's.
    pinion_inertia : float or None
        One pinion [kg m^2]; None: the gear set's.
    output_inertia : float or None
        Output hub, shaft and load [kg m^2]; None: the sum of the ring inertias
        (an estimate: the seed gives no load inertia).
    coupling_stiffness : tuple of float or None
        Ring-to-output torsional stiffness [N m/rad] per ring; None: an
        annular steel web, see `couplings`.
    coupling_damping_ratio : float
        Viscous damping of each coupling as a fraction of critical for the
        ring on a fixed output [-].
    backlash : tuple of float or None
        Total normal backlash per ring [m]; None: `geometry.default_backlash`.
    transmission_error : float
        Amplitude of the pinion's transmission error at mesh frequency [m]
        (0 for an ideal drive). Default 1 um: an assumed first mesh harmonic of
        a ground gear (typically 0.5-2 um; ISO 1328-1 grade 6 allows a single
        pitch deviation of about 8 um for this pinion). It is what makes an
        unloaded drive rattle at constant speed.
    drag_torque : float
        Constant drag on the output [N m] (bearings, seals, churning), present
        under "no load". Default 0.01 N m, an estimate for a small drive; it
        keeps an unloaded mesh on its drive flank between rattle impacts.
    friction : Friction, None or "gearset"
        None for frictionless flanks; "gearset" (the default): the gear set's
        ``[friction]`` coefficients (`fe_impact.gears.gearset.FlankFriction`, the
        seed's 0.05 and 0.02 unless the set gives others; None where both are 0).
    drive : {"speed", "torque"}
        Pinion speed prescribed by the schedule, or pinion driven by the
        segments' input torque (with its inertia).
    ramp_time : float
        Blend time of speed and load steps [s].
    engage_position : float
        Where a newly engaged mesh starts within its free play, -1 (on the
        coast flank) .. 1 (on the drive flank); 0 = centred.
    mesh_phase : float
        Roll of the pinion at t = 0 as a fraction of the base pitch [-].
    rtol, length_tol, speed_tol : float
        Error control: relative tolerance, and absolute tolerances of the
        states expressed along the line of action [m], [m/s].
    max_step : float
        Largest integration step [s] (also limited to 1/8 of the tooth-pair
        passing period so that no pair is stepped over).
    laws : LawSet or None
        IMPACT-law tables; None: closed forms for this model's effective
        masses.
    corners : {"auto", "3d", "planar"}
        Where each ring's tip-corner gaps come from: the three-dimensional
        first touch of the rounded tip edges over the whole face
        (`geometry.solid_corner_gaps`), or the planar rack-and-pinion geometry;
        "auto" takes "3d" when both gears' tip edges are rounded, else "planar".
    """

    gearset: GearSet = field(default_factory=default_gearset)
    n_pinions: int | None = None
    pinion_inertia: float | None = None
    output_inertia: float | None = None
    coupling_stiffness: tuple[float, ...] | None = None
    coupling_damping_ratio: float = 0.02
    backlash: tuple[float, ...] | None = None
    transmission_error: float = 1e-6
    drag_torque: float = 0.01
    friction: Friction | None | str = "gearset"
    drive: str = "speed"
    ramp_time: float = 0.1
    engage_position: float = 0.0
    mesh_phase: float = 0.25
    rtol: float = 1e-7
    length_tol: float = 1e-10
    speed_tol: float = 1e-7
    max_step: float = 1e-4
    laws: LawSet | None = None
    corners: str = "auto"

    def __post_init__(self) -> None:
        if isinstance(self.friction, str):
            if self.friction != "gearset":
                raise CaseError(f"friction = {self.friction!r}: give a Friction, None "
                                "(frictionless) or 'gearset' (the gear set's [friction])")
            fr = self.gearset.friction
            object.__setattr__(self, "friction", Friction(fr.mu_static, fr.mu_dynamic)
                               if fr.active else None)
        if self.drive not in DRIVES:
            raise CaseError(f"drive = {self.drive!r}; pick one of {list(DRIVES)}")
        if self.corners not in ("auto", *CORNER_SOURCES):
            raise CaseError(f"corners = {self.corners!r}; pick one of "
                            f"{['auto', *CORNER_SOURCES]}")
        if self.corners == "3d" and not self._rounded:
            raise CaseError("corners = '3d' needs rounded tip edges (pinion.tip_edge_radius_mm "
                            "and face_gear.tip_edge_radius_mm > 0); use corners = 'planar'")
        n = len(self.gearset.stages)
        for name in ("coupling_stiffness", "backlash"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, tuple(float(v) for v in value))
                if len(getattr(self, name)) != n or min(getattr(self, name)) <= 0.0:
                    raise CaseError(f"{name} = {value!r} needs {n} positive values")
        for name in ("coupling_damping_ratio", "transmission_error", "ramp_time", "drag_torque"):
            if not getattr(self, name) >= 0.0:
                raise CaseError(f"{name} = {getattr(self, name)!r} must be >= 0")
        for name in ("rtol", "length_tol", "speed_tol", "max_step"):
            if not getattr(self, name) > 0.0:
                raise CaseError(f"{name} = {getattr(self, name)!r} must be > 0")
        if not -1.0 <= self.engage_position <= 1.0:
            raise CaseError(f"engage_position = {self.engage_position!r} must lie in [-1, 1]")
        for name in ("n_pinions",):
            value = getattr(self, name)
            if value is not None and (not isinstance(value, int) or value < 1):
                raise CaseError(f"{name} = {value!r} must be an integer >= 1")
        for name in ("pinion_inertia", "output_inertia"):
            value = getattr(self, name)
            if value is not None and not value > 0.0:
                raise CaseError(f"{name} = {value!r} kg m^2 must be > 0")

    # -- derived quantities ---------------------------------------------------------------
    @cached_property
    def geometry(self) -> MeshGeometry:
        """Line-of-action geometry with the planar corner gaps (the path is the same
        for every ring)."""
        return mesh_geometry(self.gearset)

    @property
    def _rounded(self) -> bool:
        return self.gearset.pinion.tip_edge_radius > 0.0 and \
            self.gearset.face_tip_edge_radius > 0.0

    @property
    def corner_source(self) -> str:
        """``corners`` resolved: "3d" or "planar"."""
        if self.corners == "auto":
            return "3d" if self._rounded else "planar"
        return self.corners

    def stage_geometry(self, stage: int) -> MeshGeometry:
        """Ring ``stage``'s geometry (1-based): :attr:`geometry` with its own corner gaps
        when they are three-dimensional (:attr:`corner_source`)."""
        if self.corner_source == "planar":
            return self.geometry
        return mesh_geometry(self.gearset, stage, "3d")

    @property
    def n_stages(self) -> int:
        return len(self.gearset.stages)

    @property
    def pinions(self) -> int:
        return self.gearset.n_pinions if self.n_pinions is None else self.n_pinions

    @property
    def pinion_j(self) -> float:
        """Inertia of one pinion [kg m^2]."""
        return self.gearset.pinion.inertia if self.pinion_inertia is None else self.pinion_inertia

    @cached_property
    def ring_inertias(self) -> np.ndarray:
        return np.array([s.inertia for s in self.gearset.stages])

    @property
    def output_j(self) -> float:
        """Output inertia [kg m^2]."""
        if self.output_inertia is None:
            return float(self.ring_inertias.sum())
        return self.output_inertia

    @cached_property
    def pitch_radii(self) -> np.ndarray:
        """Ring pitch radii ``m N_i / 2`` [m]."""
        return np.array([0.5 * self.gearset.module * s.teeth for s in self.gearset.stages])

    @cached_property
    def base_levers(self) -> np.ndarray:
        """Ring levers along the line of action ``r_i cos(alpha0)`` [m]."""
        return self.pitch_radii * math.cos(self.geometry.pressure_angle)

    @cached_property
    def couplings(self) -> np.ndarray:
        """Ring-to-output torsional stiffness [N m/rad].

        Default: a flat steel web of thickness 10 mm between a 40 mm hub and
        the ring's inner radius ``b``, twisted in its plane:
        ``k = 4 pi G t / (1/a^2 - 1/b^2)`` (shear of an annulus; Roark's
        Formulas for Stress and Strain, flat-plate torsion), about 2e7 N m/rad.
        """
        if self.coupling_stiffness is not None:
            return np.array(self.coupling_stiffness)
        material = self.gearset.material
        shear = material.youngs_modulus / (2.0 * (1.0 + material.poisson_ratio))
        inner = np.array([s.inner_radius for s in self.gearset.stages])
        return 4.0 * math.pi * shear * _WEB_THICKNESS / (1.0 / _HUB_RADIUS**2 - 1.0 / inner**2)

    @cached_property
    def coupling_damping(self) -> np.ndarray:
        """``2 zeta sqrt(k J_ring)`` [N m s/rad]."""
        return 2.0 * self.coupling_damping_ratio * np.sqrt(self.couplings * self.ring_inertias)

    @cached_property
    def backlashes(self) -> np.ndarray:
        """Total normal backlash per ring [m]."""
        if self.backlash is not None:
            return np.array(self.backlash)
        p = self.gearset.pinion
        return np.array([default_backlash(p.module, p.pitch_radius, r) for r in self.pitch_radii])

    def effective_mass(self, stage: int) -> float:
        """Mass of one mesh along its line of action [kg] (stage from 1).

        ``1 / (r_bp^2 / J_p + n r_bi^2 / J_i)`` for a free pinion; the ring's
        share ``J_i / (n r_bi^2)`` alone when the pinion speed is prescribed.
        Couplings are ignored: they are soft on the time scale of an impact.
        """
        i = stage - 1
        ring = self.ring_inertias[i] / (self.pinions * self.base_levers[i] ** 2)
        if self.drive == "speed":
            return float(ring)
        pinion = self.pinion_j / self.geometry.base_radius**2
        return float(1.0 / (1.0 / pinion + 1.0 / ring))

    @cached_property
    def law_set(self) -> LawSet:
        """The IMPACT-law tables in use."""
        if self.laws is not None:
            if self.laws.n_stages != self.n_stages:
                raise CaseError(f"laws cover {self.laws.n_stages} stages, the gear set has "
                                f"{self.n_stages}")
            return self.laws
        masses = [self.effective_mass(s) for s in range(1, self.n_stages + 1)]
        return closed_form_laws(self.gearset, masses)

    def with_laws(self, laws: LawSet) -> DriveModel:
        """A copy using ``laws``."""
        return replace(self, laws=laws)
