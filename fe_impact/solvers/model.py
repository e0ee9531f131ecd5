"""Model set-up shared by the static and the transient solver.

Both solvers load the mesh, assemble the elastic model, split the DOFs into
free and prescribed ones, build the contact pairs and start from a contact
zone of the faces within a search distance of the master surface:

- :class:`Prescribed`: the static solver's prescribed DOFs (supports and
  ``[[displacements]]``, per load step) and free DOFs. The transient
  solver's reduction to free DOFs and rigid bodies is
  :class:`~fe_impact.fe.kinematics.Kinematics`.
- :class:`ContactSetup`: the pairs' undeformed gaps, search distances and
  initial :class:`~fe_impact.contact.zone.ContactZone`; the search distance
  is the case's or derived by :func:`displacement_reach` (static) or
  :func:`gap_reach` (impact).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from fe_impact.contact.surfaces import ContactPair, GapState
from fe_impact.contact.zone import ContactZone, face_size, reference_states
from fe_impact.errors import CaseError, ContactError
from fe_impact.fe.case import Case
from fe_impact.fe.kinematics import rigid_mode, surface_dofs
from fe_impact.fe.mesh import FEMesh


@dataclass(frozen=True, eq=False)
class Prescribed:
    """Prescribed and free DOFs of a static case.

    Attributes
    ----------
    fixed, free : ndarray of int
        DOFs with a prescribed value (supports, ``[[displacements]]`` and the
        surfaces of ``[[rigid_bodies]]``) and the others.
    values : ndarray, shape (len(fixed), n_steps)
        The prescribed values (m) at each load step; a load-controlled rigid
        body's DOFs are zero here, its motion is ``q * modes[k]``.
    free_index : ndarray, shape (n_dofs,)
        Position of each DOF in ``free``, -1 for prescribed DOFs.
    loaded : list of ndarray
        The DOFs of each ``[[displacements]]`` entry (their reactions are measured).
    modes : list of ndarray, shape (len(fixed),)
        Each rigid body's displacement per unit coordinate on the fixed DOFs
        (zero off its surface); its reaction is ``modes[k] . f_fixed``.
    coordinates : ndarray, shape (n_bodies, n_steps)
        Each rigid body's prescribed coordinate (m or rad); NaN for a
        load-controlled body, whose coordinate the solver finds.
    """

    fixed: np.ndarray
    free: np.ndarray
    values: np.ndarray
    free_index: np.ndarray
    loaded: list[np.ndarray]
    modes: list[np.ndarray] = field(default_factory=list)
    coordinates: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))

    @classmethod
    def build(cls, case: Case, mesh: FEMesh, n_dofs: int) -> Prescribed:
        """Refuses two groups prescribing different values to a shared node."""
        n = case.n_steps
        values = np.full((n_dofs, n), np.nan)
        owner: dict[int, str] = {}
        for s in case.supports:
            for c in s.fix:
                _prescribe(case, values, owner, surface_dofs(mesh, s.surface, c), s.surface,
                           np.zeros((1, n)), "xyz"[c])
        for d in case.displacements:
            _prescribe(case, values, owner, surface_dofs(mesh, d.surface, d.component),
                       d.surface, np.array(d.values)[None, :], "xyz"[d.component])
        body_modes, coords = [], np.full((len(case.rigid_bodies), n), np.nan)
        for k, b in enumerate(case.rigid_bodies):
            pts = mesh.surface_points(b.surface)
            dofs = (3 * mesh.point_dof[pts][:, None] + np.arange(3)).ravel()
            mode = rigid_mode(b, mesh.points[pts]).ravel()
            if not b.load_controlled:
                coords[k] = b.values
            q = np.nan_to_num(coords[k])
            _prescribe(case, values, owner, dofs, b.surface, mode[:, None] * q[None, :],
                       "xyz", varies=(mode != 0.0) if b.load_controlled else None)
            body_modes.append((dofs, mode))
        is_fixed = ~np.isnan(values[:, 0])
        fixed, free = np.flatnonzero(is_fixed), np.flatnonzero(~is_fixed)
        free_index = -np.ones(n_dofs, dtype=np.int64)
        free_index[free] = np.arange(len(free))
        loaded = [surface_dofs(mesh, d.surface, d.component) for d in case.displacements]
        modes = []
        for dofs, mode in body_modes:
            m = np.zeros(n_dofs)
            m[dofs] = mode
            modes.append(m[fixed])
        return cls(fixed, free, values[fixed], free_index, loaded, modes, coords)

    def field(self, step: int, q: np.ndarray | None = None) -> np.ndarray:
        """Prescribed values at a load step, with the load-controlled coordinates ``q``."""
        u = self.values[:, step].copy()
        if q is not None:
            for k in np.flatnonzero(np.isnan(self.coordinates[:, step])):
                u += q[k] * self.modes[k]
        return u


def _prescribe(case: Case, values: np.ndarray, owner: dict[int, str], dofs: np.ndarray,
               surface: str, vals: np.ndarray, comps: str,
               varies: np.ndarray | None = None) -> None:
    """Set ``values`` of some DOFs of a surface, refusing a clash with an earlier group.

    ``vals``: (1 or len(dofs), n_steps). ``varies``: the DOFs whose values are
    not known yet (those a load-controlled body moves): any earlier group
    holding one of them clashes.
    """
    known = ~np.isnan(values[dofs, 0])
    vals = np.broadcast_to(vals, (len(dofs), values.shape[1]))
    clash = known & np.any(values[dofs] != vals, axis=1)
    if varies is not None:
        clash |= known & varies
    if clash.any():
        other = owner[int(dofs[np.flatnonzero(clash)[0]])]
        raise CaseError(f"{case.path.name}: surface '{surface}' and '{other}' "
                        f"prescribe different values to component(s) {comps} of "
                        f"{int(clash.sum())} shared node DOFs")
    values[dofs] = vals
    owner.update(dict.fromkeys(dofs.tolist(), surface))


#: A search-distance rule: (pair, its undeformed gap state) -> distance (m).
ReachRule = Callable[[ContactPair, GapState], float]


def displacement_reach(reach: float) -> ReachRule:
    """Static rule: 1.25 x the largest prescribed displacement ``reach`` (m).

    The approach cannot exceed the largest prescribed displacement; the zone
    grows by itself if a face outside it touches.
    """
    return lambda pair, state: 1.25 * reach


def gap_reach(mesh: FEMesh) -> ReachRule:
    """Impact rule: the initial gap plus one face.

    The zone grows by itself when faces outside it come close.
    """
    def rule(pair: ContactPair, state: GapState) -> float:
        g0 = float(np.min(state.gap))
        if not np.isfinite(g0):
            raise ContactError(f"contact {pair.slave.name} -> {pair.master.name}: no slave "
                               "node lies opposite the master surface")
        return max(g0, 0.0) + face_size(mesh, pair.slave)
    return rule


@dataclass(frozen=True, eq=False)
class ContactSetup:
    """The contact pairs' undeformed gaps, search distances and initial zone."""

    pairs: list[ContactPair]
    states: list[GapState]   # every slave node against the whole master, undeformed
    reach: list[float]       # search distance of each pair (m)
    zone: ContactZone

    @classmethod
    def build(cls, case: Case, mesh: FEMesh, pairs: list[ContactPair],
              rule: ReachRule) -> ContactSetup:
        """``[[contacts]] search_distance`` where given, else ``rule``'s."""
        states = reference_states(mesh, pairs)
        reach = [spec.search_distance if spec.search_distance is not None else rule(pair, st)
                 for spec, pair, st in zip(case.contacts, pairs, states, strict=True)]
        zone = ContactZone.initial(mesh, pairs, reach, states)
        if not any(len(f) for f in zone.slave_faces):
            spec, st, r = case.contacts[0], states[0], reach[0]
            closest = float(np.min(st.gap)) if len(st.gap) else math.inf
            raise CaseError(
                f"{case.path.name}: [[contacts]] {spec.slave} on {spec.master}: no slave node "
                f"comes within the search distance {r:.4g} m of the master (the closest is "
                f"{closest:.4g} m away): the bodies do not touch in this case; bring them "
                "closer, load them further or set the contact's search_distance")
        return cls(pairs, states, reach, zone)
