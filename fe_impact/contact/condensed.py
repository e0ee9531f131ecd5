"""The contact problem of an implicit step, condensed onto the contact zone.

An implicit step solves ``K_eff z = rhs + f B^T lambda`` (``f = 1 + alpha``
for HHT-alpha) with the penalty forces ``lambda = eps w <-g(z)>`` on the
linearised gaps of :class:`~fe_impact.contact.linearised.ContactModel`.
``K_eff`` is factorised once; the Schur complement of ``K_eff`` on the zone
nodes' normal coordinates gives the compliance ``G`` of those coordinates,
so contact in each step is the small dense complementarity problem of
:func:`~fe_impact.contact.lcp.solve_penalty_lcp`, solved exactly (as in the
static solver), plus one more back-substitution.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.linalg import cho_factor, cho_solve

from fe_impact.contact.lcp import solve_penalty_lcp
from fe_impact.contact.linearised import ContactModel, ZoneFrames, zone_frames
from fe_impact.fe.kinematics import Kinematics
from fe_impact.fe.linalg import SPDSolver, condensed_compliance
from fe_impact.fe.mesh import FEMesh

logger = logging.getLogger(__name__)


class StepContact(NamedTuple):
    """Solution of one implicit step with contact."""

    lam: np.ndarray                 # penalty forces (N) on the contact model's rows
    z: np.ndarray                   # reduced displacement (m)
    active: np.ndarray | None       # rows in compression (the next solve's warm start)


class CondensedContact:
    """Contact forces of ``K_eff z = rhs + f B^T lambda`` by the condensed LCP.

    Parameters
    ----------
    K_eff : csr_matrix
        The step's effective stiffness in reduced coordinates.
    solver : SPDSolver
        Its factorisation.
    force_factor : float
        ``f``, the weight of the contact forces of the new step (``1 + alpha``).
    """

    def __init__(self, mesh: FEMesh, kin: Kinematics, contact: ContactModel,
                 K_eff: sp.csr_matrix, solver: SPDSolver, force_factor: float) -> None:
        self.mesh, self.kin, self.contact = mesh, kin, contact
        self.K_eff, self.solver = K_eff, solver
        self.force_factor = force_factor
        self.seconds = 0.0                  # wall time of the condensations so far
        self.cpu_seconds = 0.0              # and their CPU time
        self.frames, self.G = self._condensation()
        self._delassus = np.zeros((0, 0))   # f B G B^T of the current projection
        self._delassus_at = -1              # the projection it belongs to

    @property
    def coordinates(self) -> np.ndarray:
        """The condensed reduced coordinates (rotated into the zone frames)."""
        return self.frames.condensed

    def condense(self) -> None:
        """Condense anew after the contact zone changed."""
        self.frames, self.G = self._condensation()
        self._delassus_at = -1

    def _condensation(self) -> tuple[ZoneFrames, np.ndarray]:
        """Schur complement of ``K_eff`` on the zone nodes' normal coordinates.

        The gap Jacobian keeps only each zone node's normal component (see
        :func:`~fe_impact.contact.linearised.zone_frames`), so the condensed
        compliance has one coordinate per node instead of three: a third of
        the size, a 27th of the factorisation work. What is dropped is the
        tangential coupling ``(n_q - n_a) . du_a`` within a node's support, of
        relative size h / R (h the face size, R the relative radius of
        curvature), and the gaps are re-projected exactly whenever the zone
        has deformed by 5% of a face.
        """
        t, c = time.perf_counter(), time.process_time()
        frames = zone_frames(self.mesh, self.kin, self.contact)
        self.contact.set_projector(frames.projector)
        K_rot = (frames.R.T @ self.K_eff @ frames.R).tocsr()
        # The compliance G once per zone; after each projection B G B^T is then a
        # sparse-dense product (a triangular solve with the Schur factor per
        # projection cost 4.5 s on a 145k-DOF tooth pair, this 0.5 s).
        G = condensed_compliance(K_rot, frames.condensed)
        logger.info("contact zone: %d reduced coordinates condensed", len(frames.condensed))
        self.seconds += time.perf_counter() - t
        self.cpu_seconds += time.process_time() - c
        return frames, G

    def _delassus_matrix(self) -> np.ndarray:
        """``f B G B^T`` on the rows with a gap, rebuilt after each projection."""
        c = self.contact
        if self._delassus_at != c.n_projections:
            Bc = (c.B @ self.frames.R)[:, self.frames.condensed][c.active_rows].tocsr()
            BG = Bc @ self.G
            self._delassus = self.force_factor * np.asarray(Bc @ BG.T)
            self._delassus_at = c.n_projections
        return self._delassus

    def solve(self, rhs: np.ndarray, active: np.ndarray | None) -> StepContact:
        """The step's displacement and contact forces; ``active`` warm-starts the LCP."""
        c = self.contact
        z_star = self.solver.solve(rhs)
        h = c.gaps(z_star)
        if not np.any(h < 0) and (active is None or not active.any()):
            return StepContact(np.zeros(len(h)), z_star, None)
        ok = c.active_rows
        C = self._delassus_matrix()
        lam = np.zeros(len(h))
        lam[ok], _ = solve_penalty_lcp(None, None, h[ok], c.eps_w[ok],
                                       None if active is None or len(active) != len(h)
                                       else active[ok], C=C)
        if not np.any(lam > 0):
            return StepContact(lam, z_star, lam > 0)
        z_new = self.solver.solve(rhs + self.force_factor * (c.BT @ lam))
        return StepContact(lam, z_new, lam > 0)

    def linearisation(self, lam: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """``w -> dz``: the step's response to a force ``w`` at a fixed active set.

        With the active rows ``S`` (``lam > 0``) the penalty forces satisfy
        ``(diag(1/eps_S) + C_SS) lam_S = -h_S``, ``h`` the gaps of the
        contact-free solve, so ``dz = K^-1 w + f K^-1 B_S^T dlam_S`` with
        ``dlam_S = -(diag(1/eps_S) + C_SS)^-1 B_S K^-1 w``. Valid after a
        :meth:`solve` that returned ``lam``.
        """
        c = self.contact
        ok = np.flatnonzero(c.active_rows)
        on = lam[ok] > 0
        if not on.any():
            return self.solver.solve
        rows = ok[on]
        B_S = c.B[rows]
        fac = cho_factor(self._delassus[np.ix_(on, on)] + np.diag(1.0 / c.eps_w[rows]))
        BT_S = B_S.T.tocsr()
        f = self.force_factor

        def apply(w):
            dz = self.solver.solve(w)
            dlam = -cho_solve(fac, B_S @ dz)
            return dz + f * self.solver.solve(BT_S @ dlam)

        return apply
