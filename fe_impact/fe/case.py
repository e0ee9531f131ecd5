"""Case files: a TOML description of a contact problem on a Gmsh mesh.

Example (all lengths in metres, stresses in Pa)::

    [mesh]
    file = "sphere_block.msh"      # relative to the case file
    unit = "mm"                    # length unit of the mesh: m or mm

    [[materials]]
    volumes = ["sphere", "block"]
    youngs_modulus = 212e9
    poisson_ratio = 0.289
    density = 7860

    [[contacts]]
    slave = "sphere_contact"
    master = "block_contact"
    penalty = "auto"               # or a value in Pa/m
    multiplier = "linear"          # contact pressure on 6-node faces, or "split"

    [[supports]]
    surface = "block_bottom"
    fix = ["z"]

    [[displacements]]              # applied in turn, one load step per value
    surface = "sphere_equator"
    component = "z"
    values = [-5e-6, -1e-5]

    [analysis]
    type = "static"

A static case may also hold a surface on a rigid body (a hub on its shaft)
and prescribe its rotation (rad) or translation (m) at each load step, or the
torque (N m) or force (N) it carries; the reaction along it is reported::

    [[rigid_bodies]]
    surface = "pinion_hub"
    motion = "rotation"
    direction = [0.0, 0.0, 1.0]     # rotation axis (or translation direction)
    point = [0.0, 0.0, 0.0]         # a point on the axis, m
    loads = [10.0, 20.0]            # N m per load step; or values = [...] in rad

A transient impact (``type = "dynamic"``) replaces ``[[displacements]]`` by
initial velocities and rigid bodies::

    [analysis]
    type = "dynamic"
    integrator = "newmark"          # or "explicit"
    duration = 1.0e-4               # s
    time_step = "auto"              # or a value in s
    output_interval = 1.0e-6        # s, for fields and history
    plastic_solver = "newton"       # Newmark with plasticity, or "anderson"

    [[initial_velocities]]
    volumes = ["sphere"]
    value = [0.0, 0.0, -1.0]        # m/s

    [[rigid_bodies]]
    surface = "hemisphere_top"
    motion = "translation"          # or "rotation"
    direction = [0.0, 0.0, 1.0]     # translation direction, or rotation axis
    point = [0.0, 0.0, 0.0]         # a point on the rotation axis, m
    inertia = 0.5                   # kg, or kg m^2 for a rotation
    initial_velocity = -1.0         # m/s or rad/s along/about the direction
    carries = ["sphere"]            # volumes that start in the body's motion (optional)

A body's ``carries`` start with its rigid velocity field (``initial_velocity``
times ``direction``, or times ``direction x (x - point)`` for a rotation): a
gear on its rotor turns with it from the first instant. Volumes not carried
and not in ``[[initial_velocities]]`` start at rest even where the body's
surface drags them (a rod struck by a mass tied to its end). A volume takes
one initial velocity: it may be carried by one body at most, and not also
listed in ``[[initial_velocities]]``. A carried volume moves with its body
alone: no support holds it and no other rigid body's surface lies on it.

Parsing checks every key and value; :meth:`Case.check_groups` then checks the
group names against a loaded mesh. :func:`fe_impact.fe.casefile.write_case`
writes a :class:`Case` back to such a file; variants of a case are made in
memory with :func:`dataclasses.replace`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from fe_impact.errors import CaseError, MeshError
from fe_impact.fe.mesh import UNITS, FEMesh
from fe_impact.inputs import MAX_DENSITY, MAX_YOUNGS_MODULUS, Reader, read_document

COMPONENTS = {"x": 0, "y": 1, "z": 2}
ANALYSIS_TYPES = ("static", "dynamic")
INTEGRATORS = ("newmark", "explicit")
#: Newmark's plasticity iteration: Newton with the consistent tangent, or
#: Anderson-accelerated modified Newton on the elastic factorisation.
PLASTIC_SOLVERS = ("newton", "anderson")
MOTIONS = ("translation", "rotation")
#: Contact pressure (multiplier) interpolation on 6-node slave faces: linear
#: between the corners (stable with quadratic displacements), or linear on the
#: four sub-triangles (twice the resolution, but the pressure oscillates at
#: stiff penalties); see :mod:`fe_impact.contact.surfaces`.
MULTIPLIERS = ("linear", "split")
_TOP_KEYS = {"mesh", "materials", "contacts", "supports", "displacements", "analysis",
             "initial_velocities", "rigid_bodies"}
#: Upper bounds of values that are finite but far outside anything the
#: solvers are meant for; beyond them a value is a unit mistake (Young's
#: modulus and density: `fe_impact.inputs.MAX_YOUNGS_MODULUS`, `MAX_DENSITY`).
#: Penalty: 1e8 x that of a 0.1 mm element of steel (E/h = 2e15 Pa/m);
#: displacements: 1 m (a small-strain model); speeds: 1e4 m/s (or rad/s),
#: above the speed of sound in steel; rigid-body inertia: 1e9 kg (kg m^2),
#: a ship's propeller shaft is 1e5 kg m^2. Prescribed rotations of a static
#: rigid body: 0.1 rad (the rigid-body map is a small rotation, exact to
#: first order: at 0.1 rad the second-order error is 0.5% of the arc); loads:
#: 1e9 N or N m.
MAX_PENALTY = 1e23
MAX_ROTATION = 0.1
MAX_LOAD = 1e9
MAX_INERTIA = 1e9
MAX_DISPLACEMENT = 1.0
MAX_SPEED = 1e4
#: Coulomb coefficients above this are refused as a mistake (dry clean metals
#: in vacuum reach about 1-2; greased gear flanks 0.02-0.05).
MAX_FRICTION = 5.0
#: Slip speed (m/s) over which the coefficient falls from static to dynamic, by
#: default: the lumped switching model's transition speed (:class:`fe_impact.
#: switching.model.Friction`).
DEFAULT_TRANSITION_SPEED = 1e-2


@dataclass(frozen=True)
class MaterialSpec:
    """Linear elastic isotropic material on some volume groups."""

    volumes: tuple[str, ...]
    youngs_modulus: float
    poisson_ratio: float
    density: float
    yield_strength: float | None = None    # Pa; None: elastic
    hardening_modulus: float = 0.0         # Pa, linear isotropic hardening


@dataclass(frozen=True)
class ContactSpec:
    """A contact pair; ``penalty=None`` means derive it (``"auto"``).

    Coulomb friction (:mod:`fe_impact.contact.friction`): ``mu_static`` at zero
    slip speed, blending to ``mu_dynamic`` at ``transition_speed`` (m/s) and
    above (the seed's eqs. 9-10 with a regularised transition). Both zero:
    frictionless (the default). ``friction = mu`` in a case file sets both.
    """

    slave: str
    master: str
    penalty: float | None = None
    search_distance: float | None = None
    multiplier: str = "linear"             # one of MULTIPLIERS
    mu_static: float = 0.0
    mu_dynamic: float = 0.0
    transition_speed: float = DEFAULT_TRANSITION_SPEED

    @property
    def friction(self) -> bool:
        """True if the pair has Coulomb friction."""
        return self.mu_static > 0.0 or self.mu_dynamic > 0.0


@dataclass(frozen=True)
class SupportSpec:
    """Zero displacement of the listed components on a surface."""

    surface: str
    fix: tuple[int, ...]


@dataclass(frozen=True)
class DisplacementSpec:
    """Prescribed displacement of one component on a surface, one value per load step."""

    surface: str
    component: int
    values: tuple[float, ...]


@dataclass(frozen=True)
class InitialVelocitySpec:
    """Uniform initial velocity (m/s) of the listed volume groups."""

    volumes: tuple[str, ...]
    value: tuple[float, float, float]


@dataclass(frozen=True)
class RigidBodySpec:
    """A surface tied to a rigid body with one degree of freedom.

    ``translation``: the surface nodes move by ``q * direction``; ``rotation``:
    by ``theta * direction x (x - point)`` (small rotation about the axis
    through ``point``). ``inertia`` is a mass (kg) or a moment of inertia
    (kg m^2) added to that of the tied nodes (transient cases).

    In a static case the body's coordinate is prescribed at each load step,
    either directly (``values``: m or rad) or through the force or torque it
    carries (``loads``: N or N m along/about ``direction``); exactly one of
    the two is given.
    """

    surface: str
    motion: str
    direction: tuple[float, float, float]
    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: float = 0.0
    initial_velocity: float = 0.0
    carries: tuple[str, ...] = ()      # dynamic: volumes starting in the body's motion
    values: tuple[float, ...] = ()     # static: coordinate per load step (m or rad)
    loads: tuple[float, ...] = ()      # static: force or torque per load step (N, N m)

    @property
    def load_controlled(self) -> bool:
        return bool(self.loads)


@dataclass(frozen=True)
class AnalysisSpec:
    """``[analysis]``: solution type and its controls (times in s)."""

    type: str = "static"
    max_iterations: int = 30
    tolerance: float = 1e-6
    integrator: str = "newmark"
    duration: float | None = None
    time_step: float | None = None          # None: automatic
    output_interval: float | None = None    # None: duration / 100
    hht_alpha: float = 0.0
    safety_factor: float = 0.9              # explicit: dt = safety * stable limit
    energy_limit: float = 0.05              # stop if energy grows by more (relative)
    plastic_zone: float | None = None       # m around the contact; None: automatic
    # End the run this long after the bodies separate, as a fraction of the
    # contact duration (None: run to the duration).
    stop_after_separation: float | None = None
    plastic_solver: str = "newton"          # Newmark with plasticity: see PLASTIC_SOLVERS

    @property
    def dynamic(self) -> bool:
        return self.type == "dynamic"

    @property
    def output_step(self) -> float:
        """The output interval in s: ``output_interval``, or a hundredth of the duration."""
        return self.output_interval or self.duration / 100.0


@dataclass(frozen=True)
class Case:
    """A contact problem on a mesh: what a case file holds.

    Read by :func:`load_case`, written by :func:`fe_impact.fe.casefile.write_case`,
    or built in memory (variants with :func:`dataclasses.replace`). ``path``
    is the case file (read, or to be written; messages name it) and
    ``mesh_file`` the absolute path of the mesh in ``unit``; the solvers take
    the mesh itself, loaded by the caller.
    """

    path: Path
    mesh_file: Path
    unit: str
    materials: tuple[MaterialSpec, ...]
    contacts: tuple[ContactSpec, ...] = ()
    supports: tuple[SupportSpec, ...] = ()
    displacements: tuple[DisplacementSpec, ...] = ()
    analysis: AnalysisSpec = field(default_factory=AnalysisSpec)
    initial_velocities: tuple[InitialVelocitySpec, ...] = ()
    rigid_bodies: tuple[RigidBodySpec, ...] = ()

    @property
    def n_steps(self) -> int:
        counts = [len(d.values) for d in self.displacements]
        counts += [len(b.values or b.loads) for b in self.rigid_bodies if b.values or b.loads]
        return max(counts, default=1)

    def check_groups(self, mesh: FEMesh) -> None:
        """Raise :class:`CaseError` if a case group is missing or of the wrong kind."""
        try:
            for i, m in enumerate(self.materials):
                for v in m.volumes:
                    _group(mesh.volume, v, f"materials[{i}].volumes")
            for i, c in enumerate(self.contacts):
                _group(mesh.surface, c.slave, f"contacts[{i}].slave")
                _group(mesh.surface, c.master, f"contacts[{i}].master")
            for i, s in enumerate(self.supports):
                _group(mesh.surface, s.surface, f"supports[{i}].surface")
            for i, d in enumerate(self.displacements):
                _group(mesh.surface, d.surface, f"displacements[{i}].surface")
            for i, v in enumerate(self.initial_velocities):
                for name in v.volumes:
                    _group(mesh.volume, name, f"initial_velocities[{i}].volumes")
            for i, b in enumerate(self.rigid_bodies):
                _group(mesh.surface, b.surface, f"rigid_bodies[{i}].surface")
                for name in b.carries:
                    _group(mesh.volume, name, f"rigid_bodies[{i}].carries")
        except MeshError as exc:
            raise CaseError(f"{self.path.name}: {exc}") from exc
        assigned = [v for m in self.materials for v in m.volumes]
        missing = sorted(set(mesh.volumes) - set(assigned))
        if missing:
            raise CaseError(f"{self.path.name}: volume groups {missing} have no material; "
                            "list them in a [[materials]] volumes entry")
        dup = sorted({v for v in assigned if assigned.count(v) > 1})
        if dup:
            raise CaseError(f"{self.path.name}: volume groups {dup} have more than one material")
        self._check_carried(mesh)

    def _check_carried(self, mesh: FEMesh) -> None:
        """A carried volume moves with its body only: no support holds it and no other
        rigid body's surface lies on it (it would start against them)."""
        import numpy as np

        holders = [(f"supports[{j}]", s.surface) for j, s in enumerate(self.supports)]
        for i, b in enumerate(self.rigid_bodies):
            if not b.carries:
                continue
            others = [(f"rigid_bodies[{j}]", o.surface) for j, o in enumerate(self.rigid_bodies)
                      if j != i]
            for name in b.carries:
                points = np.unique(mesh.cells[mesh.volume(name)])
                for where, surface in holders + others:
                    if np.isin(mesh.surface_points(surface), points).any():
                        raise CaseError(
                            f"{self.path.name}: [rigid_bodies[{i}]] carries = '{name}', which "
                            f"{where} (surface '{surface}') also moves or holds: a carried "
                            "volume must move with its body alone")


def _group(getter, name: str, where: str) -> None:
    try:
        getter(name)
    except MeshError as exc:
        raise MeshError(f"{where} = '{name}': {exc}") from None


def load_case(path: str | Path) -> Case:
    """Read and validate a case file (the mesh itself is not read here)."""
    path = Path(path)
    return parse_case(read_document(path, "case file", CaseError, "toml"), path)


def parse_case(data: dict[str, Any], path: Path) -> Case:
    """Validate a parsed TOML document; ``path`` locates relative files."""
    r = Reader(str(path), CaseError, "toml")
    r.keys(data, "", _TOP_KEYS, required={"mesh", "materials"})
    mesh = r.table(data, "", "mesh")
    r.keys(mesh, "mesh", {"file", "unit"}, required={"file"})
    unit = r.choice(mesh, "mesh", "unit", tuple(UNITS), default="m")
    mesh_file = (path.parent / r.string(mesh, "mesh", "file")).resolve()
    if mesh_file.is_dir():
        raise r.fail("mesh", "file", mesh["file"], f"is a directory ({mesh_file}); give a "
                     "Gmsh .msh file")
    if not mesh_file.is_file():
        raise r.fail("mesh", "file", mesh["file"], f"no such file (looked for {mesh_file})")
    analysis = _analysis(r, r.table(data, "", "analysis", default={}))
    if analysis.dynamic and data.get("displacements"):
        raise r.problem("[[displacements]] apply to static analysis; a dynamic case moves "
                        "the bodies with [[initial_velocities]] and [[rigid_bodies]]")
    if not analysis.dynamic and data.get("initial_velocities"):
        raise r.problem('[[initial_velocities]] needs [analysis] type = "dynamic"')

    def each(key: str, read, required: bool = False) -> tuple:
        return tuple(read(r, t, f"{key}[{i}]")
                     for i, t in enumerate(r.array(data, "", key, required=required)))

    initial_velocities = each("initial_velocities", _initial_velocity)
    rigid_bodies = _rigid_bodies(r, r.array(data, "", "rigid_bodies"), analysis.dynamic,
                                 _displacement_steps(data))
    _one_initial_velocity(r, initial_velocities, rigid_bodies)
    return Case(
        path=path, mesh_file=mesh_file, unit=unit,
        materials=each("materials", _material, required=True),
        contacts=each("contacts", _contact),
        supports=each("supports", _support),
        displacements=_displacements(r, r.array(data, "", "displacements")),
        analysis=analysis,
        initial_velocities=initial_velocities,
        rigid_bodies=rigid_bodies,
    )


def _one_initial_velocity(r: Reader, given: tuple[InitialVelocitySpec, ...],
                          bodies: tuple[RigidBodySpec, ...]) -> None:
    """A volume carried by a rigid body has no other initial velocity."""
    owner: dict[str, str] = {}
    for i, v in enumerate(given):
        for name in v.volumes:
            owner.setdefault(name, f"initial_velocities[{i}]")
    for i, b in enumerate(bodies):
        for name in b.carries:
            if name in owner:
                raise r.problem(f"[rigid_bodies[{i}]] carries = '{name}', which already has "
                                f"its initial velocity from [{owner[name]}]; a volume starts "
                                "with one initial velocity")
            owner[name] = f"rigid_bodies[{i}]"


def _displacement_steps(data: dict) -> int | None:
    """Load steps of the (already checked) ``[[displacements]]``, if any."""
    tables = data.get("displacements") or []
    return len(tables[0]["values"]) if tables else None


def _rigid_bodies(r: Reader, tables: list, dynamic: bool, steps: int | None
                  ) -> tuple[RigidBodySpec, ...]:
    bodies = tuple(_rigid_body(r, t, f"rigid_bodies[{i}]", dynamic)
                   for i, t in enumerate(tables))
    if dynamic:
        return bodies
    lengths = {len(b.values or b.loads) for b in bodies}
    if steps is not None:
        lengths.add(steps)
    if len(lengths) > 1:
        raise r.problem(f"[[rigid_bodies]] and [[displacements]] have different numbers of "
                        f"values {sorted(lengths)}: every entry needs one value per load step")
    if sum(b.load_controlled for b in bodies) > 1:
        raise r.problem("more than one [[rigid_bodies]] entry has loads: at most one body "
                        "can be load-controlled; prescribe the others' values")
    return bodies


def _material(r: Reader, t: dict, where: str) -> MaterialSpec:
    r.keys(t, where, {"volumes", "youngs_modulus", "poisson_ratio", "density",
                      "yield_strength", "hardening_modulus"},
           required={"volumes", "youngs_modulus", "poisson_ratio"})
    E = r.number(t, where, "youngs_modulus", low=0.0, high=MAX_YOUNGS_MODULUS, low_open=True,
                 hint="(Pa)")
    nu = r.number(t, where, "poisson_ratio", low=-1.0, high=0.5, low_open=True,
                  high_open=True)
    rho = r.number(t, where, "density", low=0.0, high=MAX_DENSITY, low_open=True,
                   default=7860.0, hint="(kg/m^3)")
    yield_ = None
    if "yield_strength" in t:
        yield_ = r.number(t, where, "yield_strength", low=0.0, high=E, low_open=True,
                          hint="(Pa, below the Young's modulus)")
    hard = r.number(t, where, "hardening_modulus", low=0.0, high=E, high_open=True,
                    default=0.0, hint="(below the Young's modulus)")
    return MaterialSpec(tuple(r.strings(t, where, "volumes")), E, nu, rho, yield_, hard)


def _initial_velocity(r: Reader, t: dict, where: str) -> InitialVelocitySpec:
    r.keys(t, where, {"volumes", "value"}, required={"volumes", "value"})
    value = r.vector(t, where, "value", "m/s")
    if max(abs(c) for c in value) > MAX_SPEED:
        raise r.fail(where, "value", t["value"], f"components must be in [-{MAX_SPEED:g}, "
                     f"{MAX_SPEED:g}] m/s")
    return InitialVelocitySpec(tuple(r.strings(t, where, "volumes")), value)


def _rigid_body(r: Reader, t: dict, where: str, dynamic: bool = True) -> RigidBodySpec:
    common = {"surface", "motion", "direction", "point"}
    if dynamic:
        r.keys(t, where, common | {"inertia", "initial_velocity", "carries"},
               required={"surface", "motion", "direction"})
    else:
        dynamic_keys = sorted({"inertia", "initial_velocity", "carries"} & set(t))
        if dynamic_keys:
            raise r.problem(f'[{where}] {" and ".join(dynamic_keys)} need [analysis] type = '
                            '"dynamic"; a static case prescribes the body\'s values or loads')
        r.keys(t, where, common | {"values", "loads"},
               required={"surface", "motion", "direction"})
    motion = r.choice(t, where, "motion", MOTIONS)
    d = r.vector(t, where, "direction", "")
    norm = math.sqrt(sum(c * c for c in d))
    if norm == 0.0:
        raise r.fail(where, "direction", t["direction"], "must be a non-zero vector")
    point = r.vector(t, where, "point", "m") if "point" in t else (0.0, 0.0, 0.0)
    spec = RigidBodySpec(r.string(t, where, "surface"), motion,
                         tuple(c / norm for c in d), point)
    if not dynamic:
        return _static_motion(r, t, where, spec)
    inertia = r.number(t, where, "inertia", low=0.0, high=MAX_INERTIA, default=0.0,
                       hint="(kg, or kg m^2 for a rotation)")
    v0 = r.number(t, where, "initial_velocity", low=-MAX_SPEED, high=MAX_SPEED, default=0.0,
                  hint="(m/s, or rad/s for a rotation)")
    carries = tuple(r.strings(t, where, "carries")) if "carries" in t else ()
    return replace(spec, inertia=inertia, initial_velocity=v0, carries=carries)


def _static_motion(r: Reader, t: dict, where: str, spec: RigidBodySpec) -> RigidBodySpec:
    """``values`` (m or rad) or ``loads`` (N or N m) of a static case's rigid body."""
    given = [k for k in ("values", "loads") if k in t]
    if len(given) != 1:
        raise r.problem(f"[{where}] needs exactly one of values (the body's "
                        f"{'rotation, rad' if spec.motion == 'rotation' else 'displacement, m'} "
                        f"per load step) and loads (its "
                        f"{'torque, N m' if spec.motion == 'rotation' else 'force, N'}); "
                        f"got {given or 'neither'}")
    rotation = spec.motion == "rotation"
    if "values" in t:
        limit = MAX_ROTATION if rotation else MAX_DISPLACEMENT
        values = r.numbers(t, where, "values", unit="(rad)" if rotation else "(m)")
        if max(abs(v) for v in values) > limit:
            raise r.fail(where, "values", t["values"],
                         f"must be in [-{limit:g}, {limit:g}] "
                         f"{'rad (small rotations)' if rotation else 'm (a small-strain model)'}")
        return replace(spec, values=values)
    loads = r.numbers(t, where, "loads", unit="(N m)" if rotation else "(N)")
    if max(abs(v) for v in loads) > MAX_LOAD:
        raise r.fail(where, "loads", t["loads"], f"must be in [-{MAX_LOAD:g}, {MAX_LOAD:g}] "
                     f"{'N m' if rotation else 'N'}")
    return replace(spec, loads=loads)


def _contact(r: Reader, t: dict, where: str) -> ContactSpec:
    r.keys(t, where, {"slave", "master", "penalty", "search_distance", "multiplier",
                      "friction", "mu_static", "mu_dynamic", "transition_speed"},
           required={"slave", "master"})
    penalty = search = None
    if t.get("penalty", "auto") != "auto":
        penalty = r.number(t, where, "penalty", low=0.0, high=MAX_PENALTY, low_open=True,
                           hint='(Pa/m) or "auto"')
    if t.get("search_distance", "auto") != "auto":
        search = r.number(t, where, "search_distance", low=0.0, low_open=True,
                          hint='or "auto"')
    slave, master = r.string(t, where, "slave"), r.string(t, where, "master")
    if slave == master:
        raise r.problem(f"[{where}] slave and master are both '{slave}': a contact pair "
                        "needs two different surfaces")
    multiplier = r.choice(t, where, "multiplier", MULTIPLIERS, default="linear")
    return ContactSpec(slave, master, penalty, search, multiplier, *_friction(r, t, where))


def _friction(r: Reader, t: dict, where: str) -> tuple[float, float, float]:
    """``(mu_static, mu_dynamic, transition_speed)`` of a ``[[contacts]]`` table.

    ``friction = mu`` gives one coefficient; ``mu_static`` and ``mu_dynamic``
    (both) a static and a dynamic one with the ``transition_speed`` (m/s)
    between them.
    """
    pair = [k for k in ("mu_static", "mu_dynamic") if k in t]
    if "friction" in t and pair:
        raise r.problem(f"[{where}] friction and {' and '.join(pair)} are both given: set "
                        "friction = mu for one coefficient, or mu_static and mu_dynamic")
    if len(pair) == 1:
        other = ({"mu_static", "mu_dynamic"} - set(pair)).pop()
        raise r.problem(f"[{where}] {pair[0]} is given without {other}: give both, or "
                        "friction = mu for one coefficient")
    hint = "(Coulomb coefficient; 0 is frictionless)"
    speed = r.number(t, where, "transition_speed", low=0.0, high=MAX_SPEED, low_open=True,
                     default=DEFAULT_TRANSITION_SPEED,
                     hint="(m/s: the slip speed at which mu has fallen from mu_static to "
                          "mu_dynamic)")
    if "friction" in t:
        mu = r.number(t, where, "friction", low=0.0, high=MAX_FRICTION, hint=hint)
        return mu, mu, speed
    if not pair:
        if "transition_speed" in t:
            raise r.problem(f"[{where}] transition_speed needs mu_static and mu_dynamic")
        return 0.0, 0.0, speed
    mu_s = r.number(t, where, "mu_static", low=0.0, high=MAX_FRICTION, hint=hint)
    mu_d = r.number(t, where, "mu_dynamic", low=0.0, high=MAX_FRICTION, hint=hint)
    if mu_s < mu_d:
        raise r.fail(where, "mu_static", t["mu_static"],
                     f"must be at least mu_dynamic = {mu_d!r} (the static coefficient is "
                     "never below the dynamic one: swap them?)")
    return mu_s, mu_d, speed


def _support(r: Reader, t: dict, where: str) -> SupportSpec:
    r.keys(t, where, {"surface", "fix"}, required={"surface", "fix"})
    comps = r.strings(t, where, "fix", what="components")
    if any(c not in COMPONENTS for c in comps):
        raise r.fail(where, "fix", comps, f"components must be a non-empty list of "
                                          f"{list(COMPONENTS)}")
    return SupportSpec(r.string(t, where, "surface"), tuple(COMPONENTS[c] for c in comps))


def _displacements(r: Reader, tables: list) -> tuple[DisplacementSpec, ...]:
    out = []
    for i, t in enumerate(tables):
        where = f"displacements[{i}]"
        r.keys(t, where, {"surface", "component", "values"},
               required={"surface", "component", "values"})
        comp = r.choice(t, where, "component", tuple(COMPONENTS))
        values = r.numbers(t, where, "values", unit="(m)")
        if max(abs(v) for v in values) > MAX_DISPLACEMENT:
            raise r.fail(where, "values", t["values"], f"must be in [-{MAX_DISPLACEMENT:g}, "
                         f"{MAX_DISPLACEMENT:g}] m (a small-strain model)")
        out.append(DisplacementSpec(r.string(t, where, "surface"), COMPONENTS[comp], values))
    lengths = {len(d.values) for d in out}
    if len(lengths) > 1:
        raise r.problem(f"[[displacements]] have different numbers of values "
                        f"{sorted(lengths)}: every entry needs one value per load step")
    return tuple(out)


_STATIC_KEYS = {"type", "max_iterations", "tolerance"}
_DYNAMIC_KEYS = _STATIC_KEYS | {"integrator", "duration", "time_step", "output_interval",
                                "hht_alpha", "safety_factor", "energy_limit", "plastic_zone",
                                "stop_after_separation", "plastic_solver"}


def _analysis(r: Reader, t: dict) -> AnalysisSpec:
    kind = r.choice(t, "analysis", "type", ANALYSIS_TYPES, default="static")
    r.keys(t, "analysis", _DYNAMIC_KEYS if kind == "dynamic" else _STATIC_KEYS,
           required={"duration"} if kind == "dynamic" else set())
    iters = r.integer(t, "analysis", "max_iterations", low=1, default=30)
    tol = r.number(t, "analysis", "tolerance", low=0.0, high=1.0, low_open=True,
                   default=1e-6)
    if kind == "static":
        return AnalysisSpec(kind, iters, tol)
    w = "analysis"
    integrator = r.choice(t, w, "integrator", INTEGRATORS, default="newmark")
    duration = r.number(t, w, "duration", low=0.0, low_open=True, hint="(s)")
    dt = None
    if t.get("time_step", "auto") != "auto":
        dt = r.number(t, w, "time_step", low=0.0, high=duration, low_open=True,
                      hint='(s, at most the duration) or "auto"')
    out_dt = None
    if "output_interval" in t:
        out_dt = r.number(t, w, "output_interval", low=0.0, high=duration, low_open=True,
                          hint="(s, at most the duration)")
    alpha = r.number(t, w, "hht_alpha", low=-1.0 / 3.0, high=0.0, default=0.0,
                     hint="(HHT-alpha; 0 is Newmark's average acceleration)")
    if alpha != 0.0 and integrator != "newmark":
        raise r.fail(w, "hht_alpha", alpha, 'applies to integrator = "newmark" only')
    safety = r.number(t, w, "safety_factor", low=0.0, high=1.0, low_open=True, default=0.9)
    energy = r.number(t, w, "energy_limit", low=0.0, low_open=True, default=0.05,
                      hint="(relative energy growth that stops the run)")
    zone = None
    if t.get("plastic_zone", "auto") != "auto":
        zone = r.number(t, w, "plastic_zone", low=0.0, low_open=True,
                        hint='(m, radius of the plastic zone around the contact) or "auto"')
    stop = None
    if "stop_after_separation" in t:
        stop = r.number(t, w, "stop_after_separation", low=0.0,
                        hint="(fraction of the contact duration to run on after the bodies "
                             "separate)")
    solver = r.choice(t, w, "plastic_solver", PLASTIC_SOLVERS, default="newton")
    if "plastic_solver" in t and integrator != "newmark":
        raise r.fail(w, "plastic_solver", solver, 'applies to integrator = "newmark" only')
    return AnalysisSpec(kind, iters, tol, integrator, duration, dt, out_dt, alpha, safety,
                        energy, zone, stop, solver)
