"""Small-strain J2 plasticity with linear isotropic hardening, as a correction to K u.

Material law (Simo and Hughes, Computational Inelasticity, 1998, box 3.1-3.2):
von Mises yield ``|s| <= sqrt(2/3) (Y + H alpha)`` with the deviatoric stress
``s``, the yield strength ``Y``, the hardening modulus ``H`` and the equivalent
plastic strain ``alpha``; associative flow. The uniaxial tangent is
``E_t = E H / (E + H)``. Backward-Euler radial return is exact for linear
hardening whenever the deviatoric stress keeps its direction within a step.

Internal force
--------------
Stress is ``sigma = C : (eps - eps_p)``, so the internal force splits into

    f_int(u) = K u - F_p,    F_p = sum_q B_q^T (C : eps_p,q) w_q,

with the elastic stiffness ``K`` unchanged and ``F_p`` summed over the
quadrature points of a :class:`PlasticZone`: the elements that may yield
(candidates, chosen with :func:`elements_near`). The quadrature is the
stiffness rule of ``model.basis``: P1 one point; P2 ``intorder = 2``, the
symmetric 4-point rule exact to degree 2 (barycentric 0.5854/0.1382), the
usual rule of 10-node tetrahedra (Abaqus C3D10 has the same). So ``F_p`` of
a plastic strain ``eps(u_h)`` equals ``K u_h`` to round-off, and plastic
strain lives at 1 (P1) or 4 (P2) points per element. The cost of a
step is the strains and the return mapping at every zone point and a scatter
over the points that have plastic strain: it scales with the zone, not the
mesh (numba kernel, one pass over the zone).

Conventions
-----------
Voigt order ``xx, yy, zz, yz, xz, xy``. Strain-like arrays (strain, plastic
strain) carry engineering shear strains ``gamma_ij = 2 eps_ij``; stresses
carry ``sigma_ij``; so ``sigma . eps`` is the work density and the 6x6
tangent maps engineering strain increments to stress increments.

Using it in the transient solver (reduced coordinates ``u = T z``)
----------------------------------------------------------------
Build the zone with ``transform=T``; every ``u`` argument is then ``z`` and
every force is a reduced force ``T^T F_p``.

Explicit (central difference): each step is accepted, so

    F_p = zone.update(z);  zone.commit()
    f_int = K @ z - F_p
    strain energy = 0.5 z . (K z) + zone.energy_correction(z)
    energy balance: kinetic + strain + contact + zone.dissipation() = initial

The plastic force does not change the stable step (the elastic-plastic
tangent is softer than the elastic one).

Newmark: ``K_eff`` stays the elastic one, factorised once. In a step, solve
``K_eff z = rhs0 + (1 + a) (F_p(z) + B^T lambda)`` (``a`` the HHT alpha), the
contact solved exactly for each ``F_p``, then ``zone.commit()``; the HHT term
is ``a (K z_n - F_p,n - f_c,n)`` in ``rhs0``. Two solvers, both keeping the
single factorisation:

- :func:`solve_newton` (default): Newton's method with the consistent
  (algorithmic) tangent ``K_ep = K - D``, ``D`` from
  :meth:`PlasticZone.tangent_product`; each correction by GMRES whose
  products are one elastic solve (two with contact). Quadratic convergence.
- :func:`solve_fixed_point`: modified Newton (the elastic tangent) with
  Anderson mixing, which converges linearly but needs no tangent products.

:meth:`PlasticZone.tangent_correction` forms ``D`` as a sparse matrix.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.spatial import cKDTree

logger = logging.getLogger(__name__)

SQRT23 = math.sqrt(2.0 / 3.0)
#: Voigt index -> tensor indices (xx, yy, zz, yz, xz, xy).
VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
_VOIGT_OF = np.array([[0, 5, 4], [5, 1, 3], [4, 3, 2]])
# Engineering shear: tensor component = voigt value * factor.
_STRAIN_FACTOR = np.array([1.0, 1.0, 1.0, 0.5, 0.5, 0.5])
_M = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])  # identity in Voigt form
# Symmetric identity and deviatoric projector acting on engineering strain.
_I_SYM = np.diag(_STRAIN_FACTOR)
_I_DEV = _I_SYM - np.outer(_M, _M) / 3.0


# -- material point ----------------------------------------------------------------


def voigt_to_tensor(v: np.ndarray, strain: bool = True) -> np.ndarray:
    """(n, 6) Voigt -> (n, 3, 3) tensor; ``strain`` halves the engineering shears."""
    v = np.asarray(v, dtype=float)
    t = v * _STRAIN_FACTOR if strain else v
    return t[..., _VOIGT_OF]


def tensor_to_voigt(t: np.ndarray, strain: bool = True) -> np.ndarray:
    """(n, 3, 3) symmetric tensor -> (n, 6) Voigt (engineering shears if ``strain``)."""
    t = np.asarray(t, dtype=float)
    v = np.stack([0.5 * (t[..., i, j] + t[..., j, i]) for i, j in VOIGT], axis=-1)
    return v / _STRAIN_FACTOR if strain else v


def _as_voigt(a: np.ndarray, name: str) -> tuple[np.ndarray, bool]:
    a = np.asarray(a, dtype=float)
    if a.ndim == 3 and a.shape[1:] == (3, 3):
        return tensor_to_voigt(a), True
    if a.ndim == 2 and a.shape[1] == 6:
        return a, False
    raise ValueError(f"{name} must have shape (n, 6) (Voigt) or (n, 3, 3), got {a.shape}")


def _moduli(E, nu) -> tuple[np.ndarray, np.ndarray]:
    E, nu = np.asarray(E, dtype=float), np.asarray(nu, dtype=float)
    return E / (3.0 * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu))


def _return_map(strain, eps_p_old, alpha_old, E, nu, Y, H):
    """Radial return in Voigt form; also the quantities the tangent needs."""
    eps, _ = _as_voigt(strain, "strain")
    ep, _ = _as_voigt(eps_p_old, "eps_p_old")
    n_pts = eps.shape[0]
    if ep.shape != eps.shape:
        raise ValueError(f"eps_p_old has shape {ep.shape}, strain {eps.shape}")
    if Y is None or np.any(np.asarray(Y) <= 0):
        raise ValueError("yield_strength must be positive (None means elastic: no return)")
    alpha = np.broadcast_to(np.asarray(alpha_old, dtype=float), (n_pts,))
    kappa, mu = (np.broadcast_to(x, (n_pts,)) for x in _moduli(E, nu))
    Y = np.broadcast_to(np.asarray(Y, dtype=float), (n_pts,))
    H = np.broadcast_to(np.asarray(H, dtype=float), (n_pts,))
    ee = eps - ep                                    # elastic strain (engineering)
    tr = ee[:, :3].sum(axis=1)
    s_tr = 2.0 * mu[:, None] * (ee * _STRAIN_FACTOR - np.outer(tr / 3.0, _M))
    norm = np.sqrt(np.einsum("ij,ij->i", s_tr, s_tr * (2.0 - _M)))   # |s| = sqrt(s:s)
    f = norm - SQRT23 * (Y + H * alpha)
    yielded = f > 0.0
    dgamma = np.where(yielded, f / (2.0 * mu + (2.0 / 3.0) * H), 0.0)
    n = np.divide(s_tr, norm[:, None], out=np.zeros_like(s_tr), where=norm[:, None] > 0)
    ep_new = ep + dgamma[:, None] * n / _STRAIN_FACTOR
    alpha_new = alpha + SQRT23 * dgamma
    stress = s_tr - 2.0 * mu[:, None] * dgamma[:, None] * n + np.outer(kappa * tr, _M)
    return stress, ep_new, alpha_new, yielded, (kappa, mu, H, dgamma, norm, n)


def radial_return(strain, eps_p_old, alpha_old, E, nu, yield_strength, hardening=0.0):
    """Backward-Euler return mapping of J2 plasticity with linear isotropic hardening.

    Parameters
    ----------
    strain : array, shape (n, 6) or (n, 3, 3)
        Total strain at the end of the step; Voigt ``xx, yy, zz, yz, xz, xy``
        with engineering shears, or tensors.
    eps_p_old : array, shape (n, 6) or (n, 3, 3)
        Plastic strain at the end of the previous (accepted) step.
    alpha_old : array, shape (n,)
        Equivalent plastic strain of the previous step.
    E, nu, yield_strength, hardening : float or array (n,)
        Young's modulus, Poisson's ratio, yield strength ``Y`` and hardening
        modulus ``H`` (Pa): the yield stress is ``Y + H alpha``.

    Returns
    -------
    stress : (n, 6) Voigt or (n, 3, 3), the format of ``strain``
    eps_p_new : plastic strain, the format of ``eps_p_old``
    alpha_new : (n,)
    yielded : (n,) bool, True where the step was plastic
    """
    stress, ep_new, alpha_new, yielded, _ = _return_map(strain, eps_p_old, alpha_old, E, nu,
                                                        yield_strength, hardening)
    if np.ndim(strain) == 3:
        stress = voigt_to_tensor(stress, strain=False)
    if np.ndim(eps_p_old) == 3:
        ep_new = voigt_to_tensor(ep_new)
    return stress, ep_new, alpha_new, yielded


def _tangent_voigt(kappa, mu, H, dgamma, norm, n) -> np.ndarray:
    """Consistent tangent (n, 6, 6) from the return-mapping data (Simo-Hughes box 3.2)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        theta = np.where(dgamma > 0, 1.0 - 2.0 * mu * dgamma / norm, 1.0)
    theta_bar = np.where(dgamma > 0, 1.0 / (1.0 + H / (3.0 * mu)) - (1.0 - theta), 0.0)
    C = (kappa[:, None, None] * np.outer(_M, _M)
         + (2.0 * mu * theta)[:, None, None] * _I_DEV
         - (2.0 * mu * theta_bar)[:, None, None] * np.einsum("ni,nj->nij", n, n))
    return C


def consistent_tangent(strain, eps_p_old, alpha_old, E, nu, yield_strength, hardening=0.0):
    """Algorithmic tangent d(stress)/d(strain) of :func:`radial_return`.

    Same arguments. Returns (n, 6, 6) acting on Voigt engineering strain for
    (n, 6) input, or (n, 3, 3, 3, 3) with minor symmetries for (n, 3, 3)
    input. Elastic points get the elastic tensor.
    """
    *_, data = _return_map(strain, eps_p_old, alpha_old, E, nu, yield_strength, hardening)
    C = _tangent_voigt(*data)
    if np.ndim(strain) != 3:
        return C
    # tensor form: C_ijkl = C_voigt[I(ij), J(kl)] (engineering columns need no factor)
    return C[:, _VOIGT_OF][:, :, :, _VOIGT_OF]


# -- element kernels -----------------------------------------------------------------


@njit(cache=True, fastmath=True, inline="always")
def _gradient(ue, Gq):
    """Displacement gradient ``du_c/dx_k`` (row-major g00 ... g22) at one point.

    ``ue`` (nb, 3) element nodal values, ``Gq`` (nb, 3) shape-function gradients.
    """
    g00 = g01 = g02 = g10 = g11 = g12 = g20 = g21 = g22 = 0.0
    for a in range(Gq.shape[0]):
        d0 = Gq[a, 0]
        d1 = Gq[a, 1]
        d2 = Gq[a, 2]
        u0 = ue[a, 0]
        u1 = ue[a, 1]
        u2 = ue[a, 2]
        g00 += u0 * d0
        g01 += u0 * d1
        g02 += u0 * d2
        g10 += u1 * d0
        g11 += u1 * d1
        g12 += u1 * d2
        g20 += u2 * d0
        g21 += u2 * d1
        g22 += u2 * d2
    return g00, g01, g02, g10, g11, g12, g20, g21, g22


@njit(cache=True, fastmath=True, inline="always")
def _add_stress_divergence(sxx, syy, szz, syz, sxz, sxy, Gq, fe):
    """fe += B^T s at one point (s already times the point's weight)."""
    for a in range(Gq.shape[0]):
        g0 = Gq[a, 0]
        g1 = Gq[a, 1]
        g2 = Gq[a, 2]
        fe[a, 0] += sxx * g0 + sxy * g1 + sxz * g2
        fe[a, 1] += sxy * g0 + syy * g1 + syz * g2
        fe[a, 2] += sxz * g0 + syz * g1 + szz * g2


#: An element without plastic strain is skipped while its bound on the trial
#: stress stays below this fraction of the yield radius (the bound is exact;
#: the margin covers rounding in it).
SCREEN_MARGIN = 1.0 - 1e-6


@njit(cache=True, fastmath=True)
def _update_kernel(u, ldofs, G, w, lam, mu, Y, H, ep_old, al_old, ep_new, al_new, dgam,
                   snorm, nflow, ylist, f, uref, sref, cbound):
    """Strains, radial return and plastic force of every zone point.

    ``u`` local DOF values; ``ldofs`` (ne, nb, 3) local DOFs; ``G`` (ne, nq, nb, 3)
    shape-function gradients; ``w`` (ne, nq) weights x |J|. Plastic strains are
    Voigt engineering; a point with ``al_old == 0`` has no plastic strain.
    At the points that yield, writes the trial state into ``ep_new``,
    ``al_new``, ``dgam`` (plastic multiplier), ``snorm`` (trial |s|), ``nflow``
    (the unit flow direction s/|s|, tensor components) and
    their flat indices ``e * nq + q`` into ``ylist``; the local plastic force
    goes into ``f``. Returns the plastic work of the step (J), the number of
    yielded points, ``sum w eps_p : C : eps_p / 2`` (J) of the trial state
    and the number of elements whose points were evaluated.

    Screening: an element without plastic strain has trial stress
    ``s = 2 mu dev(sym grad u)``, linear in its nodal values ``u_e``, and
    ``|s(u)| <= |s(u_ref)| + 2 mu |G_q|_F |u_e - u_ref|_F`` at each point
    (Cauchy-Schwarz on ``grad u = sum_a u_a G_a``; the deviatoric, symmetric
    part is no larger). ``uref`` (ne, nb, 3) and ``sref`` (ne,) hold the
    element's values and largest trial ``|s|`` when it was last evaluated
    (any call: they are facts about ``u_ref``, not state), ``cbound`` (ne,)
    ``2 mu max_q |G_q|_F``. While ``sref + cbound |u_e - u_ref|`` stays
    below the yield radius, no point of the element can yield and it has
    no plastic force, so it is skipped: the results are those of evaluating
    every point.
    """
    ne, nq, nb, _ = G.shape
    f[:] = 0.0
    work = 0.0
    energy = 0.0
    ny = 0
    evaluated = 0
    ue = np.empty((nb, 3))
    fe = np.empty((nb, 3))
    for e in range(ne):
        virgin = True
        for q in range(nq):
            if al_old[e, q] > 0.0:
                virgin = False
                break
        if virgin:
            d2 = 0.0     # read from u directly: most elements go no further
            for a in range(nb):
                for c in range(3):
                    d = u[ldofs[e, a, c]] - uref[e, a, c]
                    d2 += d * d
            if sref[e] + cbound[e] * math.sqrt(d2) < SCREEN_MARGIN * SQRT23 * Y[e]:
                continue
        for a in range(nb):
            for c in range(3):
                ue[a, c] = u[ldofs[e, a, c]]
        evaluated += 1
        smax = 0.0
        m2 = 2.0 * mu[e]
        hard = H[e]
        plastic = False
        for q in range(nq):
            g00, g01, g02, g10, g11, g12, g20, g21, g22 = _gradient(ue, G[e, q])
            a_old = al_old[e, q]
            if a_old > 0.0:
                p0 = ep_old[e, q, 0]
                p1 = ep_old[e, q, 1]
                p2 = ep_old[e, q, 2]
                p3 = ep_old[e, q, 3]
                p4 = ep_old[e, q, 4]
                p5 = ep_old[e, q, 5]
            else:
                p0 = p1 = p2 = p3 = p4 = p5 = 0.0
            # trial deviatoric stress from the elastic strain (tensor components)
            e0 = g00 - p0
            e1 = g11 - p1
            e2 = g22 - p2
            m = (e0 + e1 + e2) / 3.0
            s0 = m2 * (e0 - m)
            s1 = m2 * (e1 - m)
            s2 = m2 * (e2 - m)
            s3 = 0.5 * m2 * (g12 + g21 - p3)
            s4 = 0.5 * m2 * (g02 + g20 - p4)
            s5 = 0.5 * m2 * (g01 + g10 - p5)
            n2 = s0 * s0 + s1 * s1 + s2 * s2 + 2.0 * (s3 * s3 + s4 * s4 + s5 * s5)
            R = SQRT23 * (Y[e] + hard * a_old)
            nrm = math.sqrt(n2)
            smax = max(smax, nrm)
            if nrm > R:     # on the norm, not its square: dg > 0 strictly
                dg = (nrm - R) / (m2 + (2.0 / 3.0) * hard)
                r = dg / nrm
                p0 += r * s0
                p1 += r * s1
                p2 += r * s2
                p3 += 2.0 * r * s3
                p4 += 2.0 * r * s4
                p5 += 2.0 * r * s5
                ep_new[e, q, 0] = p0
                ep_new[e, q, 1] = p1
                ep_new[e, q, 2] = p2
                ep_new[e, q, 3] = p3
                ep_new[e, q, 4] = p4
                ep_new[e, q, 5] = p5
                a_new = a_old + SQRT23 * dg
                al_new[e, q] = a_new
                dgam[e, q] = dg
                snorm[e, q] = nrm
                nflow[e, q, 0] = s0 / nrm
                nflow[e, q, 1] = s1 / nrm
                nflow[e, q, 2] = s2 / nrm
                nflow[e, q, 3] = s3 / nrm
                nflow[e, q, 4] = s4 / nrm
                nflow[e, q, 5] = s5 / nrm
                ylist[ny] = e * nq + q
                ny += 1
                # int (Y + H alpha) d alpha over the step, exact for linear hardening
                work += w[e, q] * SQRT23 * dg * (Y[e] + 0.5 * hard * (a_old + a_new))
            elif a_old <= 0.0:
                continue   # no plastic strain, no force
            if not plastic:
                fe[:, :] = 0.0
                plastic = True
            energy += _accumulate(p0, p1, p2, p3, p4, p5, lam[e], mu[e], w[e, q], G[e, q],
                                  fe)
        if virgin:
            for a in range(nb):
                for c in range(3):
                    uref[e, a, c] = ue[a, c]
            sref[e] = smax
        if plastic:
            for a in range(nb):
                for c in range(3):
                    f[ldofs[e, a, c]] += fe[a, c]
    return work, ny, energy, evaluated


@njit(cache=True, fastmath=True, inline="always")
def _accumulate(p0, p1, p2, p3, p4, p5, lam, mu, wq, Gq, fe):
    """fe += w B^T (C : eps_p) at one point (eps_p Voigt engineering).

    Returns ``w eps_p : C : eps_p / 2``.
    """
    tr = wq * lam * (p0 + p1 + p2)
    wm2 = 2.0 * mu * wq
    sxx = wm2 * p0 + tr
    syy = wm2 * p1 + tr
    szz = wm2 * p2 + tr
    syz = mu * wq * p3
    sxz = mu * wq * p4
    sxy = mu * wq * p5
    _add_stress_divergence(sxx, syy, szz, syz, sxz, sxy, Gq, fe)
    return 0.5 * (sxx * p0 + syy * p1 + szz * p2 + syz * p3 + sxz * p4 + sxy * p5)


@njit(cache=True)
def _force_kernel(ldofs, G, w, lam, mu, ep, f):
    """Local plastic force of a plastic strain field (ne, nq, 6); returns its energy."""
    ne, nq, nb, _ = G.shape
    f[:] = 0.0
    energy = 0.0
    fe = np.empty((nb, 3))
    for e in range(ne):
        fe[:, :] = 0.0
        for q in range(nq):
            p = ep[e, q]
            energy += _accumulate(p[0], p[1], p[2], p[3], p[4], p[5], lam[e], mu[e], w[e, q],
                                  G[e, q], fe)
        for a in range(nb):
            for c in range(3):
                f[ldofs[e, a, c]] += fe[a, c]
    return energy


@njit(cache=True, fastmath=True)
def _tangent_kernel(x, ldofs, G, w, mu, H, dgam, snorm, nflow, ylist, ny, f):
    """``f = (K - K_ep) x`` over the points that yield in the pending update.

    At each yielding point ``C - C_alg = 2 mu (1 - theta) I_dev + 2 mu theta_bar n x n``
    (Simo and Hughes, box 3.2), ``n`` the flow direction (tensor components).
    """
    nq = G.shape[1]
    nb = G.shape[2]
    f[:] = 0.0
    ue = np.empty((nb, 3))
    fe = np.empty((nb, 3))
    for k in range(ny):
        e = ylist[k] // nq
        q = ylist[k] % nq
        for a in range(nb):
            for c in range(3):
                ue[a, c] = x[ldofs[e, a, c]]
        g00, g01, g02, g10, g11, g12, g20, g21, g22 = _gradient(ue, G[e, q])
        # tensor strain components
        e3 = 0.5 * (g12 + g21)
        e4 = 0.5 * (g02 + g20)
        e5 = 0.5 * (g01 + g10)
        m = (g00 + g11 + g22) / 3.0
        dg = dgam[e, q]
        m2 = 2.0 * mu[e]
        theta = 1.0 - m2 * dg / snorm[e, q]
        theta_bar = 1.0 / (1.0 + H[e] / (3.0 * mu[e])) - (1.0 - theta)
        n0 = nflow[e, q, 0]
        n1 = nflow[e, q, 1]
        n2 = nflow[e, q, 2]
        n3 = nflow[e, q, 3]
        n4 = nflow[e, q, 4]
        n5 = nflow[e, q, 5]
        c1 = m2 * (1.0 - theta) * w[e, q]
        c2 = m2 * theta_bar * w[e, q] * (n0 * g00 + n1 * g11 + n2 * g22
                                         + 2.0 * (n3 * e3 + n4 * e4 + n5 * e5))
        sxx = c1 * (g00 - m) + c2 * n0
        syy = c1 * (g11 - m) + c2 * n1
        szz = c1 * (g22 - m) + c2 * n2
        syz = c1 * e3 + c2 * n3
        sxz = c1 * e4 + c2 * n4
        sxy = c1 * e5 + c2 * n5
        fe[:, :] = 0.0
        _add_stress_divergence(sxx, syy, szz, syz, sxz, sxy, G[e, q], fe)
        for a in range(nb):
            for c in range(3):
                f[ldofs[e, a, c]] += fe[a, c]


# -- the zone ---------------------------------------------------------------------------


class PlasticZone:
    """J2 plasticity on a subset of the elements of an :class:`ElasticModel`.

    Parameters
    ----------
    model : ElasticModel
    elements : array of int
        Candidate elements; those whose material has no ``yield_strength``
        are dropped (they stay elastic).
    transform : sparse matrix (n_dofs, n), optional
        ``u = T z``: with it, every displacement argument is ``z`` and every
        force is returned as ``T^T F``, length ``n``.

    State: plastic strain (engineering Voigt) and equivalent plastic strain
    at every quadrature point, committed by :meth:`commit`; :meth:`update`
    computes a trial state from the committed one and never changes it.
    """

    def __init__(self, model, elements: Iterable[int], transform: sp.spmatrix | None = None):
        from skfem import CellBasis

        self.model = model
        self.n_dofs = model.n_dofs
        elements = np.unique(np.asarray(list(elements) if not isinstance(elements, np.ndarray)
                                        else elements, dtype=np.int64))
        ys = np.array([np.nan if m.yield_strength is None else m.yield_strength
                       for m in model.materials])
        mat = model.material[elements]
        keep = np.isfinite(ys[mat])
        if not keep.all():
            logger.info("plastic zone: %d of %d elements have no yield strength, kept elastic",
                        int((~keep).sum()), len(elements))
        self.elements = elements[keep]
        mat = mat[keep]
        ne = len(self.elements)
        X, W = model.basis.X, model.basis.W
        nq = X.shape[1]
        scalar = model.basis.elem.elem          # the scalar element of ElementVector
        nb = scalar.doflocs.shape[0]
        if ne:
            sb = CellBasis(model.basis.mesh, scalar, quadrature=(X, W),
                           elements=self.elements)
            # (ne, nq, nb, 3) gradients; weights x |J|
            G = np.stack([sb.basis[a][0].grad for a in range(nb)], axis=0)  # (nb,3,ne,nq)
            self._G = np.ascontiguousarray(G.transpose(2, 3, 0, 1))
            self._w = np.ascontiguousarray(sb.dx)
            gdofs = 3 * sb.element_dofs.T[:, :, None] + np.arange(3)       # (ne, nb, 3)
        else:
            self._G = np.zeros((0, nq, nb, 3))
            self._w = np.zeros((0, nq))
            gdofs = np.zeros((0, nb, 3), dtype=np.int64)
        #: global DOFs the zone touches; ``ldofs`` index into them
        self.dofs, inv = np.unique(gdofs, return_inverse=True)
        self._ldofs = np.ascontiguousarray(inv.reshape(gdofs.shape).astype(np.int64))
        E = np.array([m.youngs_modulus for m in model.materials])[mat]
        nu = np.array([m.poisson_ratio for m in model.materials])[mat]
        self._kappa, self._mu = _moduli(E, nu)
        self._lam = self._kappa - 2.0 * self._mu / 3.0
        self._Y = ys[mat].astype(float)
        self._H = np.array([m.hardening_modulus for m in model.materials], dtype=float)[mat]
        if np.any(self._Y <= 0) or np.any(self._H < 0):
            raise ValueError("plasticity needs yield_strength > 0 and hardening_modulus >= 0")
        self.nq = nq
        # committed state; trial state (valid at the yielded points of the last update)
        self._ep = np.zeros((ne, nq, 6))
        self._al = np.zeros((ne, nq))
        self._ep_t = np.zeros((ne, nq, 6))
        self._al_t = np.zeros((ne, nq))
        self._dg = np.zeros((ne, nq))
        self._sn = np.zeros((ne, nq))
        self._nf = np.zeros((ne, nq, 6))
        self._ylist = np.zeros(ne * nq, dtype=np.int64)
        self._ny = 0
        self._f = np.zeros(len(self.dofs))       # trial local F_p
        self._f_c = np.zeros(len(self.dofs))     # committed local F_p
        self._energy_t = self._energy_c = 0.0    # sum w eps_p : C : eps_p / 2
        self._work = 0.0
        self._work_t = 0.0
        self._pending = False
        # the update's screening of elements far from yield (see _update_kernel)
        self._uref = np.zeros((ne, nb, 3))
        self._sref = np.full(ne, 1e300)    # finite (fastmath): evaluated at the first update
        self._cbound = 2.0 * self._mu * np.sqrt((self._G ** 2).sum(axis=(2, 3))).max(
            axis=1, initial=0.0)
        self.evaluated = 0      # elements the last update evaluated
        # zone elements sharing a node with an element outside the zone
        cells = model.mesh.cells
        inside = np.zeros(len(cells), dtype=bool)
        inside[self.elements] = True
        outer_nodes = np.zeros(model.mesh.n_points, dtype=bool)
        outer_nodes[cells[~inside].ravel()] = True
        self.boundary = outer_nodes[cells[self.elements]].any(axis=1)
        self.set_transform(transform)

    # -- coordinates ------------------------------------------------------------------
    def set_transform(self, transform: sp.spmatrix | None) -> None:
        """Use ``u = T z`` (or the DOFs themselves with ``None``) from now on."""
        if transform is None:
            self._T = self._TT = None
            self.n = self.n_dofs
        else:
            if transform.shape[0] != self.n_dofs:
                raise ValueError(f"transform has {transform.shape[0]} rows, the model "
                                 f"{self.n_dofs} DOFs")
            self._T = sp.csr_matrix(transform)[self.dofs].tocsr()
            self._TT = self._T.T.tocsr()
            self.n = transform.shape[1]

    def _local(self, u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if u.shape != (self.n,):
            raise ValueError(f"displacement has shape {u.shape}, expected ({self.n},)")
        return self._T @ u if self._T is not None else u[self.dofs]

    def _global(self, f_loc: np.ndarray) -> np.ndarray:
        if self._TT is not None:
            return self._TT @ f_loc
        out = np.zeros(self.n)
        out[self.dofs] = f_loc
        return out

    # -- sizes -----------------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        return len(self.elements)

    @property
    def n_points(self) -> int:
        return self.n_elements * self.nq

    @property
    def weights(self) -> np.ndarray:
        """Quadrature weight x |J| (m^3) of every point, shape (n_elements, nq)."""
        return self._w

    # -- mechanics ---------------------------------------------------------------------
    def strains(self, u: np.ndarray) -> np.ndarray:
        """Total strain (n_elements, nq, 6), Voigt with engineering shears."""
        ul = self._local(u)[self._ldofs]                       # (ne, nb, 3)
        gu = np.einsum("eac,eqak->eqck", ul, self._G)          # du_c/dx_k
        return tensor_to_voigt(gu)

    def stresses(self, u: np.ndarray) -> np.ndarray:
        """Stress C : (eps - eps_p) (n_elements, nq, 6) with the committed plastic strain."""
        ee = self.strains(u) - self._ep
        tr = ee[..., :3].sum(axis=-1)
        return (2.0 * self._mu[:, None, None] * ee * _STRAIN_FACTOR
                + (self._lam[:, None] * tr)[..., None] * _M)

    def von_mises(self, u: np.ndarray) -> np.ndarray:
        """Element-mean von Mises stress (Pa) of the zone's elements, (n_elements,).

        Same averaging as :func:`fe_impact.fe.elasticity.von_mises`, which is
        wrong inside the zone once it has plastic strain: overwrite its
        values at :attr:`elements` with these.
        """
        s = self.stresses(u)
        dev = s.copy()
        dev[..., :3] -= s[..., :3].mean(axis=-1, keepdims=True)
        vm = np.sqrt(1.5 * ((dev[..., :3] ** 2).sum(axis=-1) + 2 * (dev[..., 3:] ** 2).sum(-1)))
        return (vm * self._w).sum(axis=1) / self._w.sum(axis=1)

    def update(self, u: np.ndarray) -> np.ndarray:
        """Return mapping at ``u`` from the committed state; the plastic force ``F_p``.

        The trial state is kept for :meth:`commit`, :meth:`tangent_correction`
        and :meth:`energy_correction`; the committed state is not touched.
        """
        ul = np.ascontiguousarray(self._local(u))
        if self.n_elements:
            self._work_t, self._ny, self._energy_t, self.evaluated = _update_kernel(
                ul, self._ldofs, self._G, self._w, self._lam, self._mu, self._Y, self._H,
                self._ep, self._al, self._ep_t, self._al_t, self._dg, self._sn, self._nf,
                self._ylist, self._f, self._uref, self._sref, self._cbound)
        self._pending = True
        return self._global(self._f)

    @property
    def _yield_idx(self) -> np.ndarray:
        """Flat point indices that yielded in the pending update."""
        return self._ylist[:self._ny] if self._pending else self._ylist[:0]

    def commit(self) -> None:
        """Accept the state of the last :meth:`update` (no-op without one)."""
        if not self._pending:
            return
        idx = self._yield_idx
        self._ep.reshape(-1, 6)[idx] = self._ep_t.reshape(-1, 6)[idx]
        self._al.reshape(-1)[idx] = self._al_t.reshape(-1)[idx]
        self._work += self._work_t
        self._f, self._f_c = self._f_c, self._f
        self._energy_c = self._energy_t
        self._pending = False

    def _latest(self) -> tuple[np.ndarray, np.ndarray]:
        """Plastic strain and alpha of the pending update, else the committed ones."""
        if not self._pending:
            return self._ep, self._al
        ep, al = self._ep.copy(), self._al.copy()
        idx = self._yield_idx
        ep.reshape(-1, 6)[idx] = self._ep_t.reshape(-1, 6)[idx]
        al.reshape(-1)[idx] = self._al_t.reshape(-1)[idx]
        return ep, al

    def plastic_force(self, eps_p: np.ndarray | None = None) -> np.ndarray:
        """``F_p`` of a plastic strain field (n_elements, nq, 6); default the committed one."""
        if eps_p is None:
            return self._global(self._f_c)
        ep = np.array(np.broadcast_to(eps_p, self._ep.shape), dtype=float, order="C")
        f = np.zeros(len(self.dofs))
        if self.n_elements:
            _force_kernel(self._ldofs, self._G, self._w, self._lam, self._mu, ep, f)
        return self._global(f)

    def set_state(self, eps_p: np.ndarray, alpha: np.ndarray) -> None:
        """Overwrite the committed state (restarts, tests); drops a pending update.

        Points with ``alpha == 0`` must have zero plastic strain (the kernel
        skips them).
        """
        ep = np.array(np.broadcast_to(eps_p, self._ep.shape), dtype=float, order="C")
        al = np.array(np.broadcast_to(alpha, self._al.shape), dtype=float, order="C")
        if np.any(ep[al <= 0] != 0.0):
            raise ValueError("plastic strain at points with alpha = 0")
        self._ep, self._al = ep, al
        self._energy_c = (_force_kernel(self._ldofs, self._G, self._w, self._lam, self._mu,
                                        ep, self._f_c) if self.n_elements else 0.0)
        self._pending = False

    @property
    def plastic_strain(self) -> np.ndarray:
        """Committed plastic strain (n_elements, nq, 6), Voigt engineering."""
        return self._ep

    @property
    def alpha(self) -> np.ndarray:
        """Committed equivalent plastic strain (n_elements, nq)."""
        return self._al

    def yielded(self) -> np.ndarray:
        """Points that yielded in the pending update (n_elements, nq) bool."""
        out = np.zeros(self._al.shape, dtype=bool)
        out.reshape(-1)[self._yield_idx] = True
        return out

    @property
    def n_yielded(self) -> int:
        """Number of points that yielded in the pending update."""
        return self._ny if self._pending else 0

    def boundary_yielded(self) -> bool:
        """True if an element on the zone's boundary has plastic strain: zone too small."""
        return bool((self._latest()[1][self.boundary] > 0).any())

    def dissipation(self) -> float:
        """Plastic work of the committed steps, sum of w int sigma : d eps_p (J).

        For linear hardening this is ``int (Y + H alpha) d alpha`` per point,
        evaluated exactly along each step's return path. It includes the
        (mechanically unrecoverable) hardening energy ``H alpha^2 / 2``.
        """
        return self._work

    def energy_correction(self, u: np.ndarray) -> float:
        """Elastic strain energy minus ``u . K u / 2`` (J), with the latest plastic strain.

        ``int (eps - eps_p) : C : (eps - eps_p) / 2 = u.Ku/2 - u.F_p + int eps_p:C:eps_p/2``;
        the latest state is the pending update's, else the committed one. Costs
        one dot product.
        """
        f, energy = ((self._f, self._energy_t) if self._pending
                     else (self._f_c, self._energy_c))
        return float(-(self._local(u) @ f) + energy)

    def equivalent_plastic_strain(self, reduce: str = "max") -> np.ndarray:
        """Committed equivalent plastic strain per element of the whole mesh (0 outside).

        ``reduce`` is ``"max"`` or ``"mean"`` (volume-weighted) over the element's points.
        """
        out = np.zeros(len(self.model.mesh.cells))
        if reduce == "max":
            out[self.elements] = self._al.max(axis=1, initial=0.0)
        elif reduce == "mean":
            if self.n_elements:
                out[self.elements] = (self._al * self._w).sum(axis=1) / self._w.sum(axis=1)
        else:
            raise ValueError(f"reduce must be 'max' or 'mean', got {reduce!r}")
        return out

    def tangent_product(self, x: np.ndarray) -> np.ndarray:
        """``tangent_correction() @ x`` without forming the matrix (pending update).

        One pass over the yielding points (numba): the cheap product for
        Krylov solvers, where the matrix would be formed for a few products.
        """
        f = np.zeros(len(self.dofs))
        ny = self.n_yielded
        if ny:
            _tangent_kernel(np.ascontiguousarray(self._local(x)), self._ldofs, self._G,
                            self._w, self._mu, self._H, self._dg, self._sn, self._nf,
                            self._ylist, ny, f)
        return self._global(f)

    def tangent_correction(self, u: np.ndarray | None = None) -> sp.csr_matrix:
        """``K_el - K_ep`` of the zone (symmetric positive semi-definite) at ``u``.

        Runs :meth:`update` at ``u`` if given, else uses the pending update
        (none after :meth:`commit`: zero). The consistent tangent stiffness is
        ``K - tangent_correction(u)``; the matrix is in the coordinates of
        ``u`` (``T^T D T`` with a transform). Only points yielding in the
        step contribute: elastic steps of plastic points have the elastic tangent.
        """
        if u is not None:
            self.update(u)
        n_loc = len(self.dofs)
        e_idx, q_idx = np.divmod(self._yield_idx, self.nq)
        if len(e_idx) == 0:
            D = sp.csr_matrix((n_loc, n_loc))
        else:
            mu, H, dg, sn = (self._mu[e_idx], self._H[e_idx], self._dg[e_idx, q_idx],
                             self._sn[e_idx, q_idx])
            n = self._nf[e_idx, q_idx]           # unit flow direction, tensor components
            theta = 1.0 - 2.0 * mu * dg / sn
            theta_bar = 1.0 / (1.0 + H / (3.0 * mu)) - (1.0 - theta)
            # C - C_alg = 2 mu (1 - theta) I_dev + 2 mu theta_bar n x n
            Dq = ((2.0 * mu * (1.0 - theta))[:, None, None] * _I_DEV
                  + (2.0 * mu * theta_bar)[:, None, None] * np.einsum("pi,pj->pij", n, n))
            B = _b_matrices(self._G[e_idx, q_idx])                 # (p, 6, nb*3)
            Ke = np.einsum("pia,pij,pjb->pab", B, Dq, B) * self._w[e_idx, q_idx][:, None, None]
            ld = self._ldofs[e_idx].reshape(len(e_idx), -1)
            rows = np.repeat(ld, ld.shape[1], axis=1).ravel()
            cols = np.tile(ld, (1, ld.shape[1])).ravel()
            D = sp.csr_matrix((Ke.ravel(), (rows, cols)), shape=(n_loc, n_loc))
        if self._T is not None:
            return (self._TT @ D @ self._T).tocsr()
        P = sp.csr_matrix((np.ones(n_loc), (self.dofs, np.arange(n_loc))),
                          shape=(self.n_dofs, n_loc))
        return (P @ D @ P.T).tocsr()


def _b_matrices(Gp: np.ndarray) -> np.ndarray:
    """Strain-displacement matrices (p, 6, nb*3) from gradients (p, nb, 3).

    Columns follow ``ldofs`` (node a, component c -> 3 a + c); rows are Voigt
    engineering strains.
    """
    p, nb, _ = Gp.shape
    B = np.zeros((p, 6, nb, 3))
    for i, (k, m) in enumerate(VOIGT):
        B[:, i, :, k] += Gp[:, :, m]
        if k != m:
            B[:, i, :, m] += Gp[:, :, k]
    return B.reshape(p, 6, 3 * nb)


# -- candidate elements ----------------------------------------------------------------------


def elements_near(mesh, points: np.ndarray, radius: float,
                  volumes: Iterable[str] | None = None) -> np.ndarray:
    """Elements with a node within ``radius`` of any of ``points`` (m).

    ``points`` (n, 3) or (3,): e.g. the initial contact point(s). ``volumes``
    restricts the choice to named volume groups. For a Hertz contact of
    radius ``a`` the first yield is at depth 0.48 a and the plastic zone
    of a fully plastic contact reaches about 1-2 a deep, so a radius of
    2-3 times the largest expected contact radius is a safe candidate set;
    :meth:`PlasticZone.boundary_yielded` tells when it was too small.
    """
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    d, _ = cKDTree(pts).query(mesh.points, distance_upper_bound=radius)
    near = np.isfinite(d)
    sel = near[mesh.cells].any(axis=1)
    if volumes is not None:
        allowed = np.zeros(len(mesh.cells), dtype=bool)
        for v in volumes:
            allowed[mesh.volume(v)] = True
        sel &= allowed
    return np.flatnonzero(sel)


# -- implicit steps -----------------------------------------------------------------------


def solve_fixed_point(step: Callable[[np.ndarray], np.ndarray], zone: PlasticZone,
                      z0: np.ndarray, tol: float = 1e-8, max_iter: int = 100,
                      memory: int = 5, reference: np.ndarray | None = None
                      ) -> tuple[np.ndarray, int]:
    """Solve ``z = step(zone.update(z))`` by Anderson-accelerated modified Newton.

    ``step(F_p)`` is one elastic solve with the plastic force on the right
    (Newmark: ``K_eff^-1 (rhs0 + (1 + a) F_p)`` plus the condensed contact).
    With ``memory = 0`` it is plain modified Newton, contracting by the
    ratio of plastic softening to elastic stiffness per iteration (close to
    1 for a nearly perfectly plastic, unconfined zone). Anderson mixing
    (Walker and Ni, SIAM J. Numer. Anal. 49, 2011) over the last ``memory``
    iterates acts like GMRES preconditioned by the elastic solve, with no
    second factorisation. Converged when one more iteration changes ``z`` by
    less than ``tol`` times ``|z - reference|`` (``reference``: e.g. the
    displacement at the start of the step, so rigid motion does not loosen
    the test; default zero). The trial state of ``zone`` is that of the
    returned ``z``: call :meth:`PlasticZone.commit` next.

    Returns ``(z, iterations)``; raises ``RuntimeError`` if not converged.
    """
    z = np.asarray(z0, dtype=float).copy()
    ref = 0.0 if reference is None else np.asarray(reference, dtype=float)
    dG: list[np.ndarray] = []
    dR: list[np.ndarray] = []
    g_prev = r_prev = None
    for it in range(1, max_iter + 1):
        g = step(zone.update(z))
        r = g - z
        scale = max(float(np.linalg.norm(g - ref)), 1e-300)
        if float(np.linalg.norm(r)) <= tol * scale:
            zone.update(g)
            return g, it
        if memory > 0 and g_prev is not None:
            dG.append(g - g_prev)
            dR.append(r - r_prev)
            if len(dG) > memory:
                dG.pop(0)
                dR.pop(0)
        g_prev, r_prev = g, r
        if dR:
            gamma = np.linalg.lstsq(np.column_stack(dR), r, rcond=None)[0]
            z = g - np.column_stack(dG) @ gamma
        else:
            z = g
    raise RuntimeError(f"plastic iterations did not converge in {max_iter} iterations")


def solve_newton(step: Callable[[np.ndarray], np.ndarray],
                 dstep: Callable[[np.ndarray], np.ndarray], zone: PlasticZone,
                 z0: np.ndarray, tol: float = 1e-8, max_iter: int = 30,
                 reference: np.ndarray | None = None, krylov_tol: float = 0.1,
                 residuals: list[float] | None = None) -> tuple[np.ndarray, int, int]:
    """Solve ``z = step(zone.update(z))`` by Newton's method with the consistent tangent.

    ``step(F_p)`` is one elastic solve with the plastic force on the right;
    ``dstep(w)`` its derivative along a force increment ``w`` (linear: the
    same solve without the constant part, at the last call's contact active
    set). With ``D = K - K_ep`` the zone's consistent tangent correction
    (:meth:`PlasticZone.tangent_correction`), the residual
    ``r(z) = step(F_p(z)) - z`` has the Jacobian ``dstep D - I``, so each
    Newton correction solves (``D x`` by :meth:`PlasticZone.tangent_product`)

        (I - dstep D) dz = step(F_p(z)) - z

    by GMRES to a relative residual ``eta`` (Eisenstat and Walker's forcing,
    at most ``krylov_tol``): every product is one ``dstep`` (one or two
    back-substitutions), with the elastic factorisation as the preconditioner
    built into ``step``. Converges quadratically once the yielding set
    settles (the radial return's flow direction still turns with the strain,
    so it is not one step). Convergence test as :func:`solve_fixed_point`;
    ``residuals`` (optional list) receives ``|r|`` of every iteration.

    Returns ``(z, newton_iterations, krylov_products)``; raises
    ``RuntimeError`` if not converged.
    """
    from scipy.sparse.linalg import LinearOperator, gmres

    z = np.asarray(z0, dtype=float).copy()
    ref = 0.0 if reference is None else np.asarray(reference, dtype=float)
    products = 0

    def jac(x):   # D at the pending update: the latest iterate's
        nonlocal products
        products += 1
        return x - dstep(zone.tangent_product(x))

    op = LinearOperator((len(z), len(z)), matvec=jac, dtype=float)
    eta, norm_prev = krylov_tol, None
    for it in range(1, max_iter + 1):
        g = step(zone.update(z))
        r = g - z
        norm = float(np.linalg.norm(r))
        if residuals is not None:
            residuals.append(norm)
        goal = tol * max(float(np.linalg.norm(g - ref)), 1e-300)
        if norm <= goal:
            zone.update(g)
            return g, it, products
        if norm_prev is not None:
            # Eisenstat-Walker forcing (choice 2, gamma 0.9): solve as tightly as
            # the quadratic rate can use, and no tighter than the tolerance needs
            eta = min(krylov_tol, 0.9 * (norm / norm_prev) ** 2)
        eta = min(max(eta, 0.5 * goal / norm), 0.5)
        norm_prev = norm
        # info > 0 (not at eta after 600 products) still gives a usable inexact step
        dz, info = gmres(op, r, rtol=eta, atol=0.0, restart=60, maxiter=10)
        if info < 0 or not np.all(np.isfinite(dz)):
            raise RuntimeError(f"GMRES failed (info {info}) in Newton iteration {it}")
        z = z + dz
    raise RuntimeError(f"Newton iterations did not converge in {max_iter} iterations")
