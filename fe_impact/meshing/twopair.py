"""Two tooth pairs in contact at once: a sector with two pinion teeth, meshed at both contacts.

Inside the two-pair zone of the path of contact (the contact ratio is above
1) two adjacent tooth pairs carry the load, one angular pitch apart.
:func:`build_two_pair` meshes a pinion sector with two adjacent teeth and a
face-gear sector with the two mating teeth (``n_face_teeth = 2``; each sector
with ``neighbour_teeth`` unloaded teeth on each side and cut half a pitch
beyond them, as the single pair's is), both
contacts refined as :func:`~fe_impact.meshing.toothpair.build_pair` refines
its one (each contact with its own design ellipse, element sizes and
stretch). *Pair 1* is the pair at the larger roll angle; *pair 2* the next
one, at ``roll_1 - 360/N_p``: its pinion tooth is the first one turned back
by one angular pitch and its face-gear tooth the first one's neighbour
towards ``-x``. With unmodified profiles the transmission error is zero, so
both pairs touch at the same pinion rotation.

Stretched space of two contacts. The map is the composition of the two
pairs' :class:`~fe_impact.meshing.contactstretch.ContactStretch` maps, each
with its transverse fall-off (``outer_radius``) shortened to end before the
refined core of the other contact (:func:`_capped`): near each contact the
map is exactly that pair's single-pair map, and the shear of the fall-off,
away from both contacts, grows (on the seed set from 0.95 to 1.2-1.3;
without the shortening the overlapping fall-offs turn elements inside out).
The steeper fall-off leaves more elements near the quality limit: on the
seed set at the coarse level two of three two-pair meshes come out below
:data:`~fe_impact.meshing.stretchmesh.MIN_SICN` at stretch 8 and are made
again at stretch 5, as a single pair would be (stretch 5 instead of 8
changes a single pair's load-approach curve by under 1%, measured).

Physical groups: volumes ``pinion`` and ``face_gear``; surfaces
``pinion_flank_1``, ``pinion_flank_2``, ``face_flank_1``, ``face_flank_2``
(the flanks of pairs 1 and 2), ``pinion_hub`` (rim arc and both side cuts)
and ``face_hub``. The coast flanks (pair 2's pinion tooth backs onto pair
1's face-gear tooth) form no contact pair: the unmodified teeth have no
backlash, a real drive has some.

:func:`two_pair_static_case` is the quasi-static case: the face-gear hub
held, the pinion hub a rigid rotor loaded by torque, one contact pair per
tooth pair (or only one of them, to measure one pair's curve on the same
mesh).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fe_impact.errors import GeometryError, MeshError
from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    MaterialSpec,
    RigidBodySpec,
    SupportSpec,
)
from fe_impact.gears.pairanalysis import PairAnalysis, PairSpec
from fe_impact.gears.tca import GearPair
from fe_impact.meshing.cache import cached_summary, mesh_key
from fe_impact.meshing.contactstretch import ContactStretch
from fe_impact.meshing.pairgeometry import MM, add_sectors, snap_flanks
from fe_impact.meshing.sizing import (
    REACH,
    PairDesign,
    box_distance,
    design_pair,
    level_of,
    refine_terms,
    set_size_field,
    zone_half_widths,
)
from fe_impact.meshing.stretchmesh import (
    MIN_SICN,
    InvertedMesh,
    MeshStats,
    map_nodes,
    mesh_statistics,
    mesh_with_retries,
    reload_as_discrete,
    turned_balls,
    volume_mesh,
)

logger = logging.getLogger(__name__)

__all__ = [
    "FACE_GROUPS",
    "PINION_GROUPS",
    "TwoPairDesign",
    "TwoPairMesh",
    "TwoZoneStretch",
    "build_two_pair",
    "design_two_pair",
    "pair_roll_angles",
    "two_pair_key",
    "two_pair_static_case",
    "two_pair_zone",
]

#: Pinion surface groups and the section pieces they are made of
#: (:func:`~fe_impact.meshing.pairgeometry._pinion_section`: tooth ``k`` has suffix ``_k``).
PINION_GROUPS = {"pinion_flank_1": ("flank_right",), "pinion_flank_2": ("flank_right_1",),
                 "pinion_hub": ("hub_left", "hub_right", "hub_rim")}
#: Face-gear surface groups (tooth ``j`` of the sector, counted towards ``-x``).
FACE_GROUPS = {"face_flank_1": ("flank_plus_0",), "face_flank_2": ("flank_plus_1",),
               "face_hub": ("hub_left", "hub_right", "hub_bottom")}
#: The fall-off of a contact's stretch may be shortened to this fraction of
#: its width at most (its shear grows by the inverse; about 1.9 at most).
MIN_FALL_OFF_FRACTION = 0.5


# -- where the two pairs are ----------------------------------------------------------------
def _path_ends_deg(gearset, stage: int, axial: float | None = None) -> tuple[float, float]:
    """Smallest and largest roll angle (deg) of the stage's path of contact."""
    from fe_impact.gears.report import contact_path_ends

    ends = contact_path_ends(GearPair.from_gearset(gearset, stage, axial))
    lo, hi = sorted((math.degrees(ends["first_roll_rad"]), math.degrees(ends["last_roll_rad"])))
    return lo, hi


def two_pair_zone(gearset, stage: int = 1) -> tuple[float, float]:
    """Roll angles (deg) of pair 1 over which pair 2, one pitch behind, is in contact too."""
    lo, hi = _path_ends_deg(gearset, stage)
    pitch = 360.0 / gearset.pinion.teeth
    if hi - lo <= pitch:
        raise GeometryError(f"stage {stage}: the path of contact spans {hi - lo:.3f} deg of "
                            f"pinion roll, under one angular pitch ({pitch:.3f} deg): one "
                            "pair at a time, no two-pair zone")
    return lo + pitch, hi


def pair_roll_angles(gearset, stage: int, roll_angle_deg: float,
                     axial: float | None = None) -> tuple[float, float]:
    """Roll angles (deg) of pair 1 and pair 2 when one pair is at ``roll_angle_deg``.

    The other pair is one angular pitch (``360/N_p``) away, on whichever side
    lies on the path of contact; pair 1 is the one at the larger angle.

    Raises
    ------
    GeometryError
        If only one pair is in contact at ``roll_angle_deg``.
    """
    lo, hi = _path_ends_deg(gearset, stage, axial)
    pitch = 360.0 / gearset.pinion.teeth
    roll = float(roll_angle_deg)
    if lo <= roll <= hi:
        for other in (roll - pitch, roll + pitch):
            if lo <= other <= hi:
                return max(roll, other), min(roll, other)
    raise GeometryError(
        f"roll angle = {roll:g} deg: two pairs are in contact only for roll angles "
        f"{lo:.3f} .. {hi - pitch:.3f} deg and {lo + pitch:.3f} .. {hi:.3f} deg (stage "
        f"{stage}'s path of contact runs over {lo:.3f} .. {hi:.3f} deg, one angular pitch "
        f"is {pitch:.3f} deg)")


# -- design: both contacts, one stretched space ---------------------------------------------
@dataclass(frozen=True)
class TwoZoneStretch:
    """The stretched space of two contacts: ``second`` after ``first``.

    Each map is one-to-one, so the composition is; where one map is the
    identity (beyond its fall-off) the other acts alone.
    """

    first: ContactStretch
    second: ContactStretch

    def to_mesh(self, x: NDArray) -> NDArray:
        """Physical points [m] to the stretched space."""
        return self.second.to_mesh(self.first.to_mesh(x))

    def to_physical(self, x: NDArray) -> NDArray:
        """Inverse of :meth:`to_mesh`."""
        return self.first.to_physical(self.second.to_physical(x))


def _capped(own: ContactStretch, other: ContactStretch) -> ContactStretch:
    """``own`` with its fall-off ending before ``other``'s refined core.

    The core is the cylinder of radius ``other.core_radius`` about the other
    contact's major axis over its zone (``|xi| <= half_length``); the map
    moves only points nearer than ``outer_radius`` to its own axis with
    ``|xi| < reach``.
    """
    s = np.linspace(-other.half_length, other.half_length, 401)
    c = (other.origin + s[:, None] * other.axes[0] - own.origin) @ own.axes.T
    inside = np.abs(c[:, 0]) < own.reach
    if not inside.any():
        return own
    clearance = float(np.hypot(c[inside, 1], c[inside, 2]).min()) - other.core_radius
    if clearance >= own.outer_radius:
        return own
    width = own.outer_radius - own.core_radius
    if clearance - own.core_radius < MIN_FALL_OFF_FRACTION * width:
        raise MeshError(
            f"the two contacts are {clearance * 1e3:.3g} mm apart (less their refined cores): "
            f"too close to refine both (a contact's stretch needs {own.core_radius * 1e3:.3g} "
            f"mm plus {MIN_FALL_OFF_FRACTION:g} x {width * 1e3:.3g} mm to fall off)")
    return replace(own, outer_radius=clearance)


@dataclass(frozen=True)
class TwoPairDesign:
    """Both pairs' designs (their stretches capped, :func:`_capped`) and the joint map.

    ``designs[k].analysis`` is pair ``k + 1``'s analysis *as placed*: pair 2's
    pinion roll angle and face-gear angle are pair 1's turned back by one
    angular pitch of each gear, and its gap is what that placement leaves.
    """

    designs: tuple[PairDesign, PairDesign]
    stretch: TwoZoneStretch
    #: Balls of smaller elements in the stretched space, ``(x, y, z, size)`` [m]
    #: (:attr:`~fe_impact.meshing.sizing.PairDesign.refine`).
    refine: tuple[tuple[float, float, float, float], ...] = ()

    @property
    def pair(self) -> GearPair:
        return self.designs[0].pair

    @property
    def analyses(self) -> tuple[PairAnalysis, PairAnalysis]:
        return self.designs[0].analysis, self.designs[1].analysis

    @property
    def factor(self) -> float:
        """The larger stretch factor of the two contacts."""
        return max(d.sizes["factor"] for d in self.designs)

    def sizes(self) -> dict[str, float]:
        """Element sizes of both contacts [m] (``minor_1``, ``major_1``, ...) and ``far``."""
        out = {f"{k}_{i}": v for i, d in enumerate(self.designs, 1)
               for k, v in d.sizes.items() if k != "far"}
        return {**out, "far": self.designs[0].sizes["far"]}


def design_two_pair(gearset, spec: PairSpec, max_stretch: float | None = None,
                    reach: float = REACH) -> TwoPairDesign:
    """Designs of both pairs when one is at ``spec.roll_angle_deg`` (:func:`pair_roll_angles`).

    Each pair is designed as :func:`~fe_impact.meshing.sizing.design_pair`
    designs a single pair at its roll angle (same level, gap and design
    force); the stretch factors are capped at ``max_stretch`` too if given,
    the maps' compensation ending ``reach`` zone half-lengths from each contact.
    """
    if spec.n_face_teeth < 2:
        raise MeshError(f"n_face_teeth = {spec.n_face_teeth}: a two-pair sector needs 2 or 3 "
                        "face-gear teeth")
    r1, r2 = pair_roll_angles(gearset, spec.stage, spec.roll_angle_deg,
                              spec.pinion_axial_position)
    d1 = design_pair(gearset, replace(spec, roll_angle_deg=r1), max_stretch, reach)
    d2 = design_pair(gearset, replace(spec, roll_angle_deg=r2), max_stretch, reach)
    a1, a2 = d1.analysis, d2.analysis
    l1, l2 = a1.masses.pinion_lever, a2.masses.pinion_lever
    if l1 * l2 <= 0.0:
        raise MeshError(f"the pinion's lever arms at the two contacts have opposite signs "
                        f"({l1:.4g}, {l2:.4g} m): one torque cannot press both pairs")
    pitch_p = 2.0 * np.pi / d1.pair.pinion.teeth
    pitch_f = 2.0 * np.pi / d1.pair.face.teeth
    placed = a1.pinion_roll_placed - pitch_p
    gap2 = (placed - a2.contact.roll_angle) * l2      # = gap l2 / l1: zero transmission error
    a2 = replace(a2, spec=replace(a2.spec, gap=float(gap2)), pinion_roll_placed=placed,
                 contact=replace(a2.contact, face_angle=a1.contact.face_angle - pitch_f))
    s1, s2 = _capped(d1.stretch, d2.stretch), _capped(d2.stretch, d1.stretch)
    return TwoPairDesign(designs=(replace(d1, stretch=s1), replace(d2, analysis=a2, stretch=s2)),
                         stretch=TwoZoneStretch(s1, s2))


# -- size fields of both contacts ----------------------------------------------------------------
def _reference_size_field(model, design: TwoPairDesign) -> None:
    """Physical-space sizes of the reference surface mesh, both contacts
    (:func:`~fe_impact.meshing.sizing.reference_size_field` for each)."""
    level = level_of(design.designs[0].analysis.spec)
    terms = []
    for d in design.designs:
        st = d.stretch
        width, depth = zone_half_widths(d)
        half = (st.half_length * MM, width * MM, depth * MM)
        terms.append((0.7 * d.sizes["minor"] * MM, box_distance(st.axes, st.origin * MM, half)))
    set_size_field(model, terms, 0.5 * level.gradation, 0.5 * design.designs[0].sizes["far"] * MM)


def _size_field(model, design: TwoPairDesign) -> None:
    """Stretched-space sizes, both contacts (:func:`~fe_impact.meshing.sizing.size_field`
    for each: near a contact the joint map is that contact's own)."""
    level = level_of(design.designs[0].analysis.spec)
    terms = []
    for d in design.designs:
        st = d.stretch
        width, depth = zone_half_widths(d)
        lo, hi = st.mapped_interval(st.half_length)
        centre = (st.origin + 0.5 * (lo + hi) * st.axes[0]) * MM
        half = (0.5 * (hi - lo) * MM, width * MM, depth * MM)
        terms.append((d.sizes["minor"] * MM, box_distance(st.axes, centre, half)))
    set_size_field(model, [*terms, *refine_terms(design.refine)], level.gradation,
                    design.designs[0].sizes["far"] * MM)


# -- meshing ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class TwoPairMesh:
    """What :func:`build_two_pair` made.

    Attributes
    ----------
    mesh_path, summary_path : Path
        ``two_pair.msh`` (millimetres) and ``two_pair.json`` (SI units).
    key : str
        Hash of the gear set and the :class:`PairSpec` (same key, same files).
    stats : MeshStats
    design : TwoPairDesign
    """

    mesh_path: Path
    summary_path: Path
    key: str
    stats: MeshStats
    design: TwoPairDesign = field(repr=False)

    @property
    def analyses(self) -> tuple[PairAnalysis, PairAnalysis]:
        """Both pairs' analyses as placed (pair 1, pair 2)."""
        return self.design.analyses

    @property
    def roll_angles_deg(self) -> tuple[float, float]:
        """Roll angles of the two contacts (deg)."""
        return tuple(a.spec.roll_angle_deg for a in self.analyses)


def two_pair_key(gearset, spec: PairSpec) -> str:
    """The key of the two-pair mesh of ``spec`` (:func:`~fe_impact.meshing.cache.mesh_key`)."""
    return mesh_key(gearset, spec, two_pair=1)


def _mesh(model, design: TwoPairDesign, spec: PairSpec, path: Path, started: float) -> MeshStats:
    """The steps of :mod:`~fe_impact.meshing.stretchmesh`, for two contacts."""
    from fe_impact.meshing.session import write_msh

    d1 = design.designs[0]
    volumes, groups = add_sectors(model, d1.pair, d1.analysis, pinion_teeth=2,
                                  pinion_groups=PINION_GROUPS, face_groups=FACE_GROUPS)
    _reference_size_field(model, design)
    model.mesh.generate(2)
    map_nodes(model, design.stretch.to_mesh)
    reload_as_discrete(model, path)
    _size_field(model, design)
    volume_mesh(model, volumes, design.stretch)
    if spec.order == 2:
        model.mesh.setOrder(2)
    for k, d in enumerate(design.designs, 1):
        moves = snap_flanks(model, d.pair, d.analysis,
                            {"pinion_flank": groups[f"pinion_flank_{k}"],
                             "face_flank": groups[f"face_flank_{k}"]})
        logger.info("pair %d: flank nodes moved onto the exact flanks by at most %.3g um "
                    "(pinion), %.3g um (face gear)", k, moves[0] * 1e6, moves[1] * 1e6)
    for name, tag in volumes.items():
        model.addPhysicalGroup(3, [tag], name=name)
    for name, faces in groups.items():
        model.addPhysicalGroup(2, faces, name=name)
    stats = mesh_statistics(model, volumes, time.perf_counter() - started, design.sizes())
    if stats.min_sicn <= MIN_SICN:
        raise InvertedMesh(
            f"the {spec.level} two-pair mesh has an element of quality {stats.min_sicn:.3g} "
            f"(minimum SICN; {MIN_SICN} required) at stretch factor {design.factor:.3g}",
            turned_balls(model, volumes, design.stretch))
    write_msh(path)
    return stats


def _mesh_with_retries(gearset, spec: PairSpec, path: Path, key: str, verbose: bool,
                       started: float) -> tuple[TwoPairDesign, MeshStats]:
    """:func:`~fe_impact.meshing.stretchmesh.mesh_with_retries` for two tooth pairs."""
    return mesh_with_retries(
        f"stage {spec.stage} two pairs at {spec.roll_angle_deg:+.3f} deg roll",
        f"two_pair_{key}", lambda cap, reach: design_two_pair(gearset, spec, cap, reach),
        lambda model, design: _mesh(model, design, spec, path, started),
        lambda design: design.factor, verbose, started)


def _summary(gearset, design: TwoPairDesign, key: str, stats: MeshStats) -> dict:
    """Content of two_pair.json (SI units)."""
    return {
        "key": key, "gearset": gearset.name,
        "roll_angles_deg": [a.spec.roll_angle_deg for a in design.analyses],
        "pairs": [d.analysis.to_dict() for d in design.designs],
        "stretch_factors": [d.sizes["factor"] for d in design.designs],
        "stretch_outer_radii_m": [d.stretch.outer_radius for d in design.designs],
        "mesh": asdict(stats),
    }


def build_two_pair(gearset, stage: int = 1, roll_angle_deg: float = 10.0,
                   level: str = "default", order: int = 2, gap: float = 1e-6,
                   out_dir: str | Path = ".", *, reuse: bool = False, verbose: bool = False,
                   **options) -> TwoPairMesh:
    """Mesh two adjacent tooth pairs in contact; write ``two_pair.msh`` and ``two_pair.json``.

    Parameters
    ----------
    gearset : GearSet
    stage, level, order, gap
        See :class:`~fe_impact.gears.pairanalysis.PairSpec` (``gap``: pair
        1's initial normal gap, m).
    roll_angle_deg : float
        Roll angle of one of the pairs; the other is one angular pitch away
        (:func:`pair_roll_angles`).
    out_dir : str or Path
        Folder of the files (created).
    reuse : bool
        Return the files already in ``out_dir`` if they were written for the
        same :func:`two_pair_key`.
    verbose : bool
        Let gmsh print its log.
    **options
        Further :class:`PairSpec` fields (``n_face_teeth``: 2, the default,
        or 3; ``design_force``, ``rim_modules``, ``pinion_axial_position``).

    Raises
    ------
    GeometryError, MeshError
        For invalid options (the message names the option and what is
        allowed) and meshes that cannot be made.
    """
    from fe_impact.atomic import atomic_folder, write_json

    started = time.perf_counter()
    options.setdefault("n_face_teeth", 2)
    try:
        spec = PairSpec(stage=stage, roll_angle_deg=roll_angle_deg, level=level, order=order,
                        gap=gap, **options)
    except TypeError as exc:
        raise MeshError(f"{exc}; options are the fields of PairSpec") from exc
    out = Path(out_dir)
    key = two_pair_key(gearset, spec)
    mesh_path, summary_path = out / "two_pair.msh", out / "two_pair.json"
    cached = cached_summary((mesh_path,), summary_path, key) if reuse else None
    if cached is not None:
        design = design_two_pair(gearset, spec, max(cached["stretch_factors"]))
        stats = MeshStats(**cached["mesh"])
    else:
        with atomic_folder(out, "two_pair") as tmp:
            design, stats = _mesh_with_retries(gearset, spec, tmp / mesh_path.name, key,
                                               verbose, started)
            (tmp / mesh_path.name).replace(mesh_path)
        write_json(summary_path, _summary(gearset, design, key, stats))
        logger.info("wrote %s (%d elements, %d DOFs, %.1f s)", mesh_path,
                    stats.n_elements["total"], stats.n_dofs, stats.seconds)
    return TwoPairMesh(mesh_path, summary_path, key, stats, design)


# -- the static case ---------------------------------------------------------------------------
def two_pair_static_case(gearset, mesh: TwoPairMesh, case_path: Path,
                         torques: tuple[float, ...], pairs: tuple[int, ...] = (1, 2)) -> Case:
    """The quasi-static case: the pinion pressed on the face gear by ``torques``.

    The face-gear hub is held; the pinion hub is tied to a rigid rotor loaded,
    step by step, by the torques (N m, magnitudes: the sense that closes the
    gaps, ``T = -F l_1`` as in :func:`~fe_impact.meshing.paircase.static_case`).
    ``pairs``: the tooth pairs given a contact pair (1, 2 or both); a pair
    left out is let through each other (no contact), which gives the other
    pair's own curve on the same mesh.

    Each contact's zone takes every face whose gap is below its initial gap
    plus 1.25 Hertz approaches at the whole largest torque on that pair
    alone (the solver grows it if the patch spreads further).
    """
    if not pairs or not set(pairs) <= {1, 2} or len(set(pairs)) != len(pairs):
        raise MeshError(f"pairs = {pairs!r}: pick 1, 2 or both")
    if not torques or min(torques) < 0.0:
        raise MeshError(f"torques = {torques!r}: need one or more magnitudes >= 0 (N m)")
    mat = gearset.material
    analyses = mesh.analyses
    point, direction = mesh.design.pair.pinion_axis
    contacts = []
    for k in pairs:
        a = analyses[k - 1]
        lever, design = a.masses.pinion_lever, a.design_ellipse
        bound = max(torques) / abs(lever)
        approach = design.approach * (bound / design.force) ** (2.0 / 3.0)
        contacts.append(ContactSpec(f"pinion_flank_{k}", f"face_flank_{k}",
                                    search_distance=a.gap + 1.25 * approach))
    sense = -math.copysign(1.0, analyses[0].masses.pinion_lever)
    return Case(
        path=case_path, mesh_file=mesh.mesh_path.resolve(), unit="mm",
        materials=(MaterialSpec(("pinion", "face_gear"), float(mat.youngs_modulus),
                                float(mat.poisson_ratio), float(mat.density)),),
        contacts=tuple(contacts),
        supports=(SupportSpec("face_hub", (0, 1, 2)),),
        rigid_bodies=(RigidBodySpec("pinion_hub", "rotation",
                                    direction=tuple(float(c) for c in direction),
                                    point=tuple(float(c) for c in point),
                                    loads=tuple(float(sense * t) for t in torques)),),
        analysis=AnalysisSpec(type="static"),
    )
