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

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fe_impact.contact.surfaces import ContactPair, GapState
from fe_impact.contact.zone import ContactZone, face_size, reference_states
from fe_impact.errors import CaseError, ContactError
from fe_impact.fe.case import Case
from fe_impact.fe.kinematics import surface_dofs
from fe_impact.fe.mesh import FEMesh


@dataclass(frozen=True, eq=False)
class Prescribed:
    """Prescribed and free DOFs of a static case.

    Attributes
    ----------
    fixed, free : ndarray of int
        DOFs with a prescribed value (supports and ``[[displacements]]``) and the others.
    values : ndarray, shape (len(fixed), n_steps)
        The prescribed values (m) at each load step.
    free_index : ndarray, shape (n_dofs,)
        Position of each DOF in ``free``, -1 for prescribed DOFs.
    loaded : list of ndarray
        The DOFs of each ``[[displacements]]`` entry (their reactions are measured).
    """

    fixed: np.ndarray
    free: np.ndarray
    values: np.ndarray
    free_index: np.ndarray
    loaded: list[np.ndarray]

    @classmethod
    def build(cls, case: Case, mesh: FEMesh, n_dofs: int) -> Prescribed:
        """Refuses two groups prescribing different values to a shared node."""
        values = np.full((n_dofs, case.n_steps), np.nan)
        owner: dict[int, str] = {}
        for s in case.supports:
            for c in s.fix:
                _prescribe(case, mesh, values, owner, s.surface, c, np.zeros(case.n_steps))
        for d in case.displacements:
            _prescribe(case, mesh, values, owner, d.surface, d.component, np.array(d.values))
        is_fixed = ~np.isnan(values[:, 0])
        fixed, free = np.flatnonzero(is_fixed), np.flatnonzero(~is_fixed)
        free_index = -np.ones(n_dofs, dtype=np.int64)
        free_index[free] = np.arange(len(free))
        loaded = [surface_dofs(mesh, d.surface, d.component) for d in case.displacements]
        return cls(fixed, free, values[fixed], free_index, loaded)


def _prescribe(case: Case, mesh: FEMesh, values: np.ndarray, owner: dict[int, str],
               surface: str, comp: int, vals: np.ndarray) -> None:
    """Set ``values`` of one component of a surface, refusing a clash with an earlier group."""
    dofs = surface_dofs(mesh, surface, comp)
    known = ~np.isnan(values[dofs, 0])
    clash = known & np.any(values[dofs] != vals[None, :], axis=1)
    if clash.any():
        other = owner[int(dofs[np.flatnonzero(clash)[0]])]
        raise CaseError(f"{case.path.name}: surface '{surface}' and '{other}' "
                        f"prescribe different values to component {'xyz'[comp]} of "
                        f"{int(clash.sum())} shared nodes")
    values[dofs] = vals[None, :]
    owner.update(dict.fromkeys(dofs.tolist(), surface))


#: A search-distance rule: (pair, its undeformed gap state) -> distance (m).
ReachRule = Callable[[ContactPair, GapState], float]


def displacement_reach(case: Case) -> ReachRule:
    """Static rule: 1.25 x the largest prescribed displacement.

    The approach cannot exceed the largest prescribed displacement; the zone
    grows by itself if a face outside it touches.
    """
    reach = max((abs(v) for d in case.displacements for v in d.values), default=0.0)
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
        return cls(pairs, states, reach, ContactZone.initial(mesh, pairs, reach, states))
