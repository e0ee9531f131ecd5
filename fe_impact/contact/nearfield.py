"""Contact near field on a fine surface grid: half-space influence coefficients.

The pressure of a small contact patch is solved on a regular grid of
rectangular cells in the common tangent plane, from the normal surface
displacement of an elastic half-space under a pressure uniform on each cell
(Love 1929; Johnson, *Contact Mechanics*, 1985, section 3.4, eq. 3.25):

    w(x, y) = (1 - nu^2) p / (pi E) * sum over the four corners (+ - - +) of
              F(x - xi, y - eta),   F(s, t) = s asinh(t / |s|) + t asinh(s / |t|),

the rectangle's corners being (xi, eta). For a square of half-side ``a`` the
centre displacement is ``8 (1 - nu^2) p a ln(1 + sqrt 2) / (pi E)``, and far
from the cell it tends to Boussinesq's point load ``(1 - nu^2) P / (pi E r)``.
For two bodies in contact the coefficients of both add, with the effective
modulus ``1 / E* = (1 - nu_1^2) / E_1 + (1 - nu_2^2) / E_2``.

The influence is a convolution on the grid, applied by FFT with zero padding
to twice the grid in each direction (DC-FFT: Liu, Wang and Liu, Wear 243,
2000, 101-111), so one application costs O(n log n) for n cells instead of
the dense n^2. The pressure is found by the conjugate-gradient method of
Polonsky and Keer (Wear 231, 1999, 206-219): non-negative pressure,
zero gap where it is positive, the total force given; the rigid approach is
the mean of the deformed separation over the contact (the CG's multiplier).

The same machinery carries the depth term of the combined model
(:mod:`fe_impact.contact.nearfield_fe`): Boussinesq's axial displacement
at a depth ``z`` under a point load, ``P (1 + nu) / (2 pi E) (2 (1 - nu) /
rho + z^2 / rho^3)`` with ``rho = sqrt(r^2 + z^2)`` (Johnson eq. 3.21a).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

logger = logging.getLogger(__name__)

#: Relative change of the pressure (L1, against the load) at which the
#: conjugate-gradient iteration stops; Polonsky and Keer use 1e-10 to 1e-6.
PRESSURE_TOLERANCE = 1e-8
#: Iteration cap of one pressure solve (it converges in tens of iterations
#: on grids of 10^4 cells).
MAX_ITERATIONS = 2000


def _antiderivative(s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``F(s, t) = s asinh(t/|s|) + t asinh(s/|t|)``: the mixed antiderivative of 1/r (m).

    ``d^2 F / ds dt = 1 / sqrt(s^2 + t^2)``; each term is 0 where its
    prefactor is (the limit ``s asinh(t/|s|) -> 0`` as ``s -> 0``).
    """
    s = np.asarray(s, dtype=float)
    t = np.asarray(t, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(s != 0.0, s * np.arcsinh(t / np.abs(s)), 0.0)
        b = np.where(t != 0.0, t * np.arcsinh(s / np.abs(t)), 0.0)
    return a + b


def love_rectangle(x, y, half_x: float, half_y: float) -> np.ndarray:
    """Integral of ``1/r`` over the rectangle ``|xi| <= half_x, |eta| <= half_y`` seen from (x, y).

    Multiplied by ``p (1 - nu^2) / (pi E)`` it is the normal surface
    displacement (m) of a half-space under a pressure ``p`` uniform on the
    rectangle (Love 1929; Johnson 1985, eq. 3.25). ``x, y`` (m), any shape.

    Returns
    -------
    ndarray
        The integral (m), the broadcast shape of ``x`` and ``y``.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    return (_antiderivative(x + half_x, y + half_y) - _antiderivative(x + half_x, y - half_y)
            - _antiderivative(x - half_x, y + half_y) + _antiderivative(x - half_x, y - half_y))


def effective_modulus(e1: float, nu1: float, e2: float, nu2: float) -> float:
    """``E*`` of two bodies (Pa): ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` (Johnson eq. 4.22)."""
    return 1.0 / ((1.0 - nu1 ** 2) / e1 + (1.0 - nu2 ** 2) / e2)


def depth_displacement(r, z: float, youngs: float, poisson: float) -> np.ndarray:
    """Axial displacement at depth ``z`` and radius ``r`` under a unit normal point load (m/N).

    Boussinesq (Johnson 1985, eq. 3.21a): ``(1 + nu) / (2 pi E) (2 (1 - nu)
    / rho + z^2 / rho^3)``, ``rho = sqrt(r^2 + z^2)``; ``z > 0``.
    """
    rho = np.sqrt(np.asarray(r, dtype=float) ** 2 + z ** 2)
    return (1.0 + poisson) / (2.0 * np.pi * youngs) * (2.0 * (1.0 - poisson) / rho
                                                        + z ** 2 / rho ** 3)


@dataclass(frozen=True)
class Grid:
    """A regular grid of rectangular cells on the contact plane.

    Attributes
    ----------
    nx, ny : int
        Cells along x and y.
    dx, dy : float
        Cell sizes (m).
    x0, y0 : float
        Centre of the first cell (m).
    """

    nx: int
    ny: int
    dx: float
    dy: float
    x0: float
    y0: float

    @classmethod
    def centred(cls, half_x: float, half_y: float, nx: int, ny: int) -> Grid:
        """The grid covering ``[-half_x, half_x] x [-half_y, half_y]`` (m)."""
        if nx < 2 or ny < 2:
            raise ValueError(f"near-field grid: nx, ny = {nx}, {ny}; at least 2 cells each")
        dx, dy = 2.0 * half_x / nx, 2.0 * half_y / ny
        return cls(nx, ny, dx, dy, -half_x + dx / 2, -half_y + dy / 2)

    @property
    def cell_area(self) -> float:
        return self.dx * self.dy

    @property
    def shape(self) -> tuple[int, int]:
        return (self.nx, self.ny)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell-centre coordinates ``X, Y`` (m), each of shape (nx, ny)."""
        x = self.x0 + self.dx * np.arange(self.nx)
        y = self.y0 + self.dy * np.arange(self.ny)
        return np.meshgrid(x, y, indexing="ij")

    def offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """Centre-to-centre offsets in DC-FFT's wrap-around order, shape (2 nx, 2 ny).

        Index ``i`` holds offset ``i dx`` for ``i < nx``, ``(i - 2 nx) dx``
        above ``nx``; the row and column ``nx`` (``ny``) are padding (their
        kernel is set to zero by :func:`convolution`).
        """
        i = np.arange(2 * self.nx)
        j = np.arange(2 * self.ny)
        sx = np.where(i < self.nx, i, i - 2 * self.nx) * self.dx
        sy = np.where(j < self.ny, j, j - 2 * self.ny) * self.dy
        return np.meshgrid(sx, sy, indexing="ij")


class Convolution:
    """A translation-invariant influence on a :class:`Grid` applied by DC-FFT.

    ``kernel(sx, sy)`` gives the displacement (m) at offset ``(sx, sy)`` from
    a cell carrying a unit pressure (1 Pa); :meth:`apply` maps the cell
    pressures (Pa, shape ``grid.shape``) to the displacement at the centres.
    """

    def __init__(self, grid: Grid, kernel: Callable[[np.ndarray, np.ndarray], np.ndarray]):
        self.grid = grid
        sx, sy = grid.offsets()
        k = kernel(sx, sy)
        k[grid.nx, :] = 0.0
        k[:, grid.ny] = 0.0
        self._kernel = k
        self._spectrum = np.fft.rfft2(k)

    def apply(self, p: np.ndarray) -> np.ndarray:
        nx, ny = self.grid.shape
        w = np.fft.irfft2(np.fft.rfft2(p, s=(2 * nx, 2 * ny)) * self._spectrum,
                          s=(2 * nx, 2 * ny))
        return w[:nx, :ny]

    def dense(self) -> np.ndarray:
        """The influence matrix (m/Pa), shape (n, n), cells in C order (for checks)."""
        nx, ny = self.grid.shape
        i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
        di = (i.ravel()[:, None] - i.ravel()[None, :]) % (2 * nx)
        dj = (j.ravel()[:, None] - j.ravel()[None, :]) % (2 * ny)
        return self._kernel[di, dj]


def surface_kernel(grid: Grid, e_star: float) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Love's cell influence of two bodies of effective modulus ``e_star`` (Pa)."""
    def kernel(sx, sy):
        return love_rectangle(sx, sy, grid.dx / 2, grid.dy / 2) / (np.pi * e_star)
    return kernel


def depth_kernel(grid: Grid, depth: float, youngs: float,
                 poisson: float) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Axial displacement at ``depth`` (m) under a cell of unit pressure, by Boussinesq.

    The cell's load is taken at its centre over a 3 x 3 Gauss rule: at a
    depth of several cells the error is far below the rule's (h/z)^6.
    """
    g, w = np.polynomial.legendre.leggauss(3)
    def kernel(sx, sy):
        out = np.zeros_like(sx)
        for gi, wi in zip(g, w, strict=True):
            for gj, wj in zip(g, w, strict=True):
                r = np.hypot(sx + gi * grid.dx / 2, sy + gj * grid.dy / 2)
                out += wi * wj / 4.0 * depth_displacement(r, depth, youngs, poisson)
        return out * grid.cell_area
    return kernel


@dataclass(frozen=True)
class PressureSolution:
    """Outcome of a near-field pressure solve.

    Attributes
    ----------
    pressure : ndarray, shape grid.shape
        Cell pressures (Pa), non-negative.
    approach : float
        Rigid approach (m): the separation closed by the bodies' far points.
    force : float
        Total normal force (N).
    iterations : int
    residual : float
        Largest |gap| over the loaded cells (m) at the end.
    """

    pressure: np.ndarray
    approach: float
    force: float
    iterations: int
    residual: float

    def contact_area(self, grid: Grid) -> float:
        """Area of the cells with a positive pressure (m^2)."""
        return float(np.count_nonzero(self.pressure > 0.0) * grid.cell_area)

    def contact_radius(self, grid: Grid) -> float:
        """``sqrt(area / pi)`` (m): the radius of a circle of the contact area."""
        return float(np.sqrt(self.contact_area(grid) / np.pi))


def solve_pressure(separation: np.ndarray, compliance: Callable[[np.ndarray], np.ndarray],
                   force: float, cell_area: float, tol: float = PRESSURE_TOLERANCE,
                   start: np.ndarray | None = None,
                   allowed: np.ndarray | None = None) -> PressureSolution:
    """Polonsky-Keer conjugate gradient for the contact pressure under a given force.

    Finds ``p >= 0`` with ``sum(p) cell_area = force`` and a gap
    ``g = separation + compliance(p) - approach`` that is zero where
    ``p > 0`` and non-negative elsewhere.

    Parameters
    ----------
    separation : ndarray
        Initial separation of the two surfaces at each cell (m).
    compliance : callable
        Pressure (Pa) -> combined normal displacement (m); symmetric
        positive definite (the CG relies on it).
    force : float
        Total normal force (N), positive.
    cell_area : float
        Area of a cell (m^2).
    start : ndarray, optional
        A starting pressure (a previous solution): fewer iterations.
    allowed : ndarray of bool, optional
        Cells where both surfaces exist (default all): the others, beyond
        the end of a flank, carry no pressure whatever their gap.
    """
    if force <= 0.0:
        raise ValueError(f"near-field solve: force {force} N; give a positive force")
    h = np.asarray(separation, dtype=float)
    if allowed is None:
        allowed = np.ones(h.shape, dtype=bool)
    if not np.any(allowed):
        raise ValueError("near-field solve: no grid cell lies on both surfaces; "
                         "centre the grid on the contact")
    h = np.where(allowed, h, np.inf)
    if start is not None and np.sum(start[allowed]) > 0:
        p = np.where(allowed, start, 0.0)
        p = p * (force / (np.sum(p) * cell_area))
    else:
        p = np.where(allowed, force / (np.count_nonzero(allowed) * cell_area), 0.0)
    t = np.zeros_like(p)
    g_old, delta = 1.0, 0.0
    it, change = 0, np.inf
    while it < MAX_ITERATIONS:
        it += 1
        g = h + compliance(p)
        on = p > 0.0
        gbar = float(np.mean(g[on]))
        g -= gbar
        G = float(np.sum(g[on] ** 2))
        t = np.where(on, g + delta * (G / g_old) * t, 0.0)
        g_old = G
        r = compliance(t)
        r -= np.mean(r[on])
        denom = float(np.sum(r[on] * t[on]))
        tau = float(np.sum(g[on] * t[on]) / denom) if denom != 0.0 else 0.0
        p_old = p
        p = np.where(on, p - tau * t, p)
        p = np.maximum(p, 0.0)
        overlap = (p == 0.0) & (g < 0.0)
        if np.any(overlap):
            delta = 0.0
            p = np.where(overlap, p - tau * g, p)
        else:
            delta = 1.0
        p *= force / (np.sum(p) * cell_area)
        change = cell_area * float(np.sum(np.abs(p - p_old))) / force
        if change < tol:
            break
    if change >= tol:
        logger.warning("near-field pressure: no convergence in %d iterations (change %.2e)",
                       MAX_ITERATIONS, change)
    g = h + compliance(p)
    on = p > 0.0
    approach = float(np.mean(g[on]))
    residual = float(np.abs(g[on] - approach).max())
    return PressureSolution(p, approach, force, it, residual)


def solve_approach(separation: np.ndarray, compliance: Callable[[np.ndarray], np.ndarray],
                   approach: float, cell_area: float, force_guess: float,
                   rtol: float = 1e-9) -> PressureSolution:
    """The pressure under a given rigid approach (m): :func:`secant_on_force`."""
    def at(force, start=None):
        return solve_pressure(separation, compliance, force, cell_area, start=start)
    return secant_on_force(at, approach, force_guess, rtol)


def secant_on_force(at: Callable[..., PressureSolution], approach: float, force_guess: float,
                    rtol: float = 1e-9) -> PressureSolution:
    """Find the force whose solve ``at(force, start)`` gives ``approach`` (m).

    The approach grows monotonically with the force, like ``F^(2/3)`` for a
    Hertz contact, so the secant runs on ``log F`` against ``log approach``.
    """
    if approach <= 0.0:
        raise ValueError(f"near-field solve: approach {approach} m; give a positive approach")
    f0 = force_guess
    s0 = at(f0)
    f1 = f0 * (approach / s0.approach) ** 1.5
    s1 = at(f1, s0.pressure)
    for _ in range(50):
        if abs(s1.approach / approach - 1.0) < rtol:
            return s1
        x0, x1 = np.log(f0), np.log(f1)
        y0, y1 = np.log(s0.approach / approach), np.log(s1.approach / approach)
        x2 = x1 - y1 * (x1 - x0) / (y1 - y0) if y1 != y0 else x1 - 1.5 * y1
        f0, s0 = f1, s1
        f1 = float(np.exp(x2))
        s1 = at(f1, s0.pressure)
    logger.warning("near-field approach search: %.3e of %.3e m after 50 solves",
                   s1.approach, approach)
    return s1
