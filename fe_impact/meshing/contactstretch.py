"""The stretched space the tooth pair is meshed in: a smooth map along the ellipse.

Gmsh's fast 3-D mesher is isotropic; :class:`ContactStretch` shortens the
Hertz ellipse's major-axis coordinate near the contact so that isotropic
elements of the stretched space are ``factor`` times longer along the major
axis once mapped back (see :mod:`fe_impact.meshing.toothpair`). The map is
built from C2 polynomial steps and plateaus, so it is one-to-one and smooth.
Pure numpy, no gmsh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fe_impact.errors import MeshError

__all__ = ["ContactStretch"]


# -- smooth steps ------------------------------------------------------------------------
def _step(t: NDArray) -> NDArray:
    """C2 step: 0 for t <= 0, 1 for t >= 1, ``6t^5 - 15t^4 + 10t^3`` between."""
    t = np.clip(t, 0.0, 1.0)
    return t**3 * (10.0 + t * (-15.0 + 6.0 * t))


def _step_integral(t: NDArray) -> NDArray:
    """``int_-inf^t _step``: 0, then ``t^6 - 3t^5 + 2.5t^4``, then ``t - 1/2``."""
    c = np.clip(t, 0.0, 1.0)
    inside = c**4 * (2.5 + c * (-3.0 + c))
    return np.where(t >= 1.0, t - 0.5, inside)


def _plateau(x: NDArray, p: NDArray, q: NDArray, r: float) -> NDArray:
    """Smooth plateau: rises over ``[p, p + r]``, 1 up to ``q - r``, falls to 0 at ``q``."""
    return _step((x - p) / r) - _step((x - q + r) / r)


def _plateau_integral(x: NDArray, p: NDArray, q: NDArray, r: float) -> NDArray:
    """``int_-inf^x _plateau``; its total is ``q - p - r``."""
    return r * (_step_integral((x - p) / r) - _step_integral((x - q + r) / r))


# -- the anisotropic map -------------------------------------------------------------------
@dataclass(frozen=True)
class ContactStretch:
    """Smooth map shortening the major-axis coordinate near the contact.

    With contact-frame coordinates ``(xi, eta, zeta)`` along ``axes`` (major,
    minor, normal) about ``origin``, the map changes only ``xi``:
    ``xi' = xi - V(rho) D(xi)`` with ``rho = sqrt(eta^2 + zeta^2)``.
    ``D' = k = 1 - 1/factor`` on ``|xi| <= half_length - ramp`` (the fully
    compressed part of the zone) and ``D' = -c`` on ``half_length < |xi| <
    reach - ramp``, with ``c`` such that ``D`` returns to 0 at
    ``|xi| = reach`` (the map is the identity beyond); C2 steps of length
    ``ramp`` join the pieces (inside the zone, and before ``reach``). ``V`` is
    1 within ``core_radius`` of the major axis and falls smoothly to 0 at
    ``outer_radius``. Since
    ``1 - V D' >= 1/factor > 0`` the map is one-to-one; isotropic elements of
    size ``h`` in the mapped space are ``factor h`` long along the major axis
    in the zone. The largest shift is about ``k half_length``; the transverse
    fall-off spreads it as a shear of about ``1.9 k half_length /
    (outer_radius - core_radius)``.

    All lengths in metres, mesh frame.
    """

    origin: NDArray[np.float64]
    axes: NDArray[np.float64]
    factor: float
    half_length: float
    reach: float
    ramp: float
    core_radius: float
    outer_radius: float

    def __post_init__(self) -> None:
        # the zone's plateau must fit in [-a, a] and inside the full plateau
        if not (self.factor >= 1.0 and 0.0 < self.ramp <= self.half_length
                and self.half_length + self.ramp <= self.reach
                and 0.0 <= self.core_radius < self.outer_radius):
            raise MeshError(f"inconsistent contact stretch {self!r}")

    @property
    def _k(self) -> float:
        return 1.0 - 1.0 / self.factor

    @property
    def _c(self) -> float:
        """Compensation slope: the zone's shift is taken back over the rest of ``reach``."""
        a, big, r = self.half_length, self.reach, self.ramp
        return self._k * (2 * a - r) / (2 * (big - a))

    def _profile(self, xi: NDArray) -> tuple[NDArray, NDArray]:
        """``D(xi)`` and ``D'(xi)`` on the major axis."""
        a, big, r = self.half_length, self.reach, self.ramp
        j_zone = _plateau_integral(xi, -a, a, r) - 0.5 * (2 * a - r)
        j_all = _plateau_integral(xi, -big, big, r) - 0.5 * (2 * big - r)
        p_zone, p_all = _plateau(xi, -a, a, r), _plateau(xi, -big, big, r)
        k, c = self._k, self._c
        return k * j_zone - c * (j_all - j_zone), k * p_zone - c * (p_all - p_zone)

    def _weight(self, c: NDArray) -> NDArray:
        rho = np.hypot(c[:, 1], c[:, 2])
        return 1.0 - _step((rho - self.core_radius) / (self.outer_radius - self.core_radius))

    def _coords(self, x: NDArray) -> NDArray:
        return (np.asarray(x, float).reshape(-1, 3) - self.origin) @ self.axes.T

    def _points(self, c: NDArray) -> NDArray:
        return self.origin + c @ self.axes

    def to_mesh(self, x: NDArray) -> NDArray:
        """Physical points [m], shape (..., 3), to the stretched space."""
        shape = np.shape(x)
        c = self._coords(x)
        c[:, 0] -= self._weight(c) * self._profile(c[:, 0])[0]
        return self._points(c).reshape(shape)

    def to_physical(self, x: NDArray) -> NDArray:
        """Inverse of :meth:`to_mesh` (bisection, then Newton to rounding level)."""
        shape = np.shape(x)
        c = self._coords(x)
        v, target = self._weight(c), c[:, 0]
        bound = self._k * self.half_length + self.ramp
        lo, hi = target - bound, target + bound
        for _ in range(60):  # the bracket shrinks to rounding level
            mid = 0.5 * (lo + hi)
            too_far = mid - v * self._profile(mid)[0] > target
            hi = np.where(too_far, mid, hi)
            lo = np.where(too_far, lo, mid)
        xi = 0.5 * (lo + hi)
        for _ in range(2):
            d, slope = self._profile(xi)
            xi = xi - (xi - v * d - target) / (1.0 - v * slope)
        c[:, 0] = xi
        return self._points(c).reshape(shape)

    def mapped_interval(self, half: float) -> tuple[float, float]:
        """Stretched-space image of ``-half <= xi <= half`` on the major axis itself."""
        ends = np.array([-half, half])
        lo, hi = ends - self._profile(ends)[0]
        return float(lo), float(hi)

    def compressed_zone(self) -> tuple[float, float]:
        """Stretched-space range of the fully compressed part of the zone
        (``|xi| <= half_length - ramp``) on the major axis itself."""
        return self.mapped_interval(self.half_length - self.ramp)

