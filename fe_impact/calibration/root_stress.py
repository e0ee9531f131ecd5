"""Tooth-root bending stress from the finite elements, against the ISO 6336-3 style value.

- :func:`vertex_stresses`, :func:`peak_tension`: the stress tensor of a solved
  displacement at the vertices of chosen elements (the gradient of the
  element's own polynomial evaluated there, scikit-fem's basis on a vertex
  quadrature), averaged at each vertex over the chosen elements sharing it,
  and the largest maximum principal stress.
- :func:`fe_root_stress`: a stage's tooth pair at the pitch point, meshed
  (:func:`~fe_impact.meshing.toothpair.build_pair`) and pressed by the normal
  force quasi-statically (the mesh cycle's
  :func:`~fe_impact.calibration.meshcycle.solve_static_pair`), and the peak
  tension in each root: the pinion's loaded-side fillet (root circle to
  root-form circle) and the face gear's loaded-side root (root plane to
  :data:`FACE_ROOT_BAND` modules above it); with the pinion's ISO 6336-3
  style ``sigma_F0`` for the same load at the same point
  (:mod:`fe_impact.gears.root_stress`) and the allowable ``2 sigma_Flim``.
- :func:`report_lines`: the calibration report's section.

Mesh resolution: the peak is read at vertices, so it is only as good as the
elements at the fillet; where they are larger than the fillet radius (the
coarse level's far-field size is 1.25 modules) it is underestimated, and each
peak carries its element size. The face gear's flank is continued to a sharp
corner at the root plane (:mod:`fe_impact.meshing.toothpair`), where the
elastic stress is singular: its peak grows as the mesh is refined and is
reported with the element size as a mesh-dependent figure, not a fillet
stress.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fe_impact.errors import GeometryError
from fe_impact.gears.root_stress import Y_ST, IsoSection, iso_for_contact, pinion_frame

logger = logging.getLogger(__name__)

__all__ = [
    "FACE_ROOT_BAND",
    "RootPeak",
    "StageRootStress",
    "fe_root_stress",
    "peak_tension",
    "report_lines",
    "vertex_stresses",
]

#: Height of the face gear's root region above its root plane, in modules.
FACE_ROOT_BAND = 0.5


# -- stresses of a solved displacement -------------------------------------------------
def vertex_stresses(skfem_mesh, order: int, u_dofs: NDArray, elements: NDArray,
                    lame: tuple[float, float]) -> NDArray:
    """Cauchy stress at the four vertices of each element in ``elements`` [Pa].

    The displacement gradient of each element's own polynomial evaluated at its
    vertices (scikit-fem's :class:`~skfem.CellBasis` on a quadrature made of
    the reference tetrahedron's vertices); linear isotropic elasticity
    ``sigma = lambda tr(eps) I + 2 mu eps``.

    Parameters
    ----------
    skfem_mesh : skfem.MeshTet or skfem.MeshTet2
    order : {1, 2}
        Element order of ``u_dofs``.
    u_dofs : ndarray
        Displacement DOF vector of the vector basis (scikit-fem's numbering) [m].
    elements : ndarray of int
        The elements.
    lame : (float, float)
        Lame's ``lambda`` and ``mu`` [Pa].

    Returns
    -------
    ndarray, shape (len(elements), 4, 3, 3)
    """
    from skfem import CellBasis, ElementTetP1, ElementTetP2, ElementVector

    vertices = np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    element = ElementVector(ElementTetP2() if order == 2 else ElementTetP1())
    basis = CellBasis(skfem_mesh, element, elements=np.asarray(elements),
                      quadrature=(vertices, np.full(4, 1.0 / 24.0)))
    grad = basis.interpolate(u_dofs).grad                   # (3, 3, n_elements, 4)
    eps = 0.5 * (grad + np.swapaxes(grad, 0, 1))
    lam, mu = lame
    sigma = 2.0 * mu * eps + lam * np.einsum("iiek->ek", eps)[None, None] \
        * np.eye(3)[:, :, None, None]
    return np.moveaxis(sigma, (0, 1), (2, 3))


@dataclass(frozen=True)
class RootPeak:
    """The largest maximum principal stress of a region and where it is.

    Attributes
    ----------
    stress : float
        Largest maximum principal stress, vertex-averaged [Pa].
    point : ndarray, shape (3,)
        Its vertex [m].
    element_size : float
        Mean edge length of the region's elements at that vertex [m].
    n_elements : int
        Elements in the region.
    """

    stress: float
    point: NDArray
    element_size: float
    n_elements: int


def peak_tension(skfem_mesh, order: int, u_dofs: NDArray, elements: NDArray,
                 lame: tuple[float, float]) -> RootPeak:
    """The largest maximum principal stress over the vertices of ``elements``.

    Each vertex's stress is the mean of :func:`vertex_stresses` over the given
    elements that share it (the plain nodal averaging of FE post-processors);
    its largest eigenvalue is the maximum principal stress. Arguments as
    :func:`vertex_stresses`.
    """
    elements = np.asarray(elements)
    if elements.size == 0:
        raise GeometryError("root region: no element lies in it")
    sigma = vertex_stresses(skfem_mesh, order, u_dofs, elements, lame)
    verts = skfem_mesh.t[:4, elements].T                     # (n, 4)
    flat = verts.ravel()
    nodes, inverse = np.unique(flat, return_inverse=True)
    total = np.zeros((len(nodes), 3, 3))
    np.add.at(total, inverse, sigma.reshape(-1, 3, 3))
    counts = np.bincount(inverse, minlength=len(nodes))
    principal = np.linalg.eigvalsh(total / counts[:, None, None])[:, -1]
    k = int(np.argmax(principal))
    at = np.flatnonzero(np.any(verts == nodes[k], axis=1))
    p = skfem_mesh.p
    edges = [np.linalg.norm(p[:, verts[e, i]] - p[:, verts[e, j]])
             for e in at for i in range(4) for j in range(i + 1, 4)]
    return RootPeak(stress=float(principal[k]), point=p[:, nodes[k]].copy(),
                    element_size=float(np.mean(edges)), n_elements=int(len(elements)))


# -- a stage's tooth pair ----------------------------------------------------------------
@dataclass(frozen=True)
class StageRootStress:
    """FE and ISO-style root stresses of one stage under one normal force (SI units).

    Attributes
    ----------
    stage : int
    normal_force : float
        Normal force of the single pair at the pitch point [N].
    level : str
        Mesh level; ``refinement`` divides its element sizes.
    refinement : float
    pinion, face : RootPeak
        The FE's peak tension in the pinion's fillet and the face gear's root.
    iso : IsoSection
        The pinion's ISO 6336-3 section for the load at the FE's contact radius.
    iso_stress : float
        ``sigma_F0`` [Pa].
    face_width : float
        ``b`` of ``sigma_F0``: the face gear's face width [m].
    allowable : float
        ``Y_ST sigma_Flim`` [Pa].
    contact_force : float
        The FE's contact force at the step [N] (the load it was pressed with).
    """

    stage: int
    normal_force: float
    level: str
    refinement: float
    pinion: RootPeak
    face: RootPeak
    iso: IsoSection
    iso_stress: float
    face_width: float
    allowable: float
    contact_force: float

    def fe_rows(self) -> dict:
        """The ``fe_*`` rows of :func:`iso_root_bending`'s dict (SI units)."""
        return {"fe_pinion_Pa": self.pinion.stress,
                "fe_pinion_element_m": self.pinion.element_size,
                "fe_face_Pa": self.face.stress, "fe_face_element_m": self.face.element_size,
                "fe_ratio": self.pinion.stress / self.allowable,
                "fe_over_iso": self.pinion.stress / self.iso_stress}

    def to_dict(self) -> dict:
        """JSON-ready dict (SI units); :meth:`from_dict` reads it back."""
        def peak(p: RootPeak) -> dict:
            return {"stress_Pa": p.stress, "point_m": [float(c) for c in p.point],
                    "element_size_m": p.element_size, "n_elements": p.n_elements}

        iso = self.iso
        return {"stage": self.stage, "normal_force_N": self.normal_force,
                "level": self.level, "refinement": self.refinement,
                "contact_force_N": self.contact_force,
                "pinion_fe": peak(self.pinion), "face_fe": peak(self.face),
                "iso": {"load_radius_m": iso.load_radius, "s_Fn_m": iso.s_fn,
                        "h_Fe_m": iso.h_fe, "rho_F_m": iso.rho_f,
                        "alpha_Fen_rad": iso.alpha_fen, "section_radius_m": iso.section_radius,
                        "Y_F": iso.y_f, "Y_S": iso.y_s, "q_s": iso.q_s},
                "iso_sigma_F0_Pa": self.iso_stress, "iso_face_width_m": self.face_width,
                "allowable_Pa": self.allowable}

    @classmethod
    def from_dict(cls, data: dict) -> StageRootStress:
        """The record :meth:`to_dict` wrote."""
        def peak(d: dict) -> RootPeak:
            return RootPeak(stress=float(d["stress_Pa"]), point=np.array(d["point_m"], float),
                            element_size=float(d["element_size_m"]),
                            n_elements=int(d["n_elements"]))

        iso = data["iso"]
        return cls(
            stage=int(data["stage"]), normal_force=float(data["normal_force_N"]),
            level=str(data["level"]), refinement=float(data["refinement"]),
            pinion=peak(data["pinion_fe"]), face=peak(data["face_fe"]),
            iso=IsoSection(load_radius=iso["load_radius_m"], s_fn=iso["s_Fn_m"],
                           h_fe=iso["h_Fe_m"], rho_f=iso["rho_F_m"],
                           alpha_fen=iso["alpha_Fen_rad"],
                           section_radius=iso["section_radius_m"], y_f=iso["Y_F"],
                           y_s=iso["Y_S"]),
            iso_stress=float(data["iso_sigma_F0_Pa"]),
            face_width=float(data["iso_face_width_m"]), allowable=float(data["allowable_Pa"]),
            contact_force=float(data["contact_force_N"]))


def _pinion_root(pair, analysis, centroids: NDArray) -> NDArray:
    """Mask of the centroids in the loaded pinion tooth's loaded-side fillet: from the
    root circle to the root-form circle, from the centreline to mid-space."""
    pinion = pair.pinion
    local = pinion_frame(pair, centroids, analysis.pinion_roll_placed)
    radius = np.hypot(local[:, 0], local[:, 1])
    polar = np.arctan2(local[:, 0], local[:, 1])
    slack = 0.05 * pinion.module
    return ((radius > pinion.root_radius - slack) & (radius < pinion.form_radius + slack)
            & (polar > 0.0) & (polar < np.pi / pinion.teeth))


def _face_root(pair, analysis, centroids: NDArray) -> NDArray:
    """Mask of the centroids in the loaded face-gear tooth's loaded-side root: from the
    root plane to ``FACE_ROOT_BAND`` modules above it, tooth centre to mid-space."""
    face = pair.face
    local = centroids @ pair.face_rotation(analysis.contact.face_angle)
    polar = np.arctan2(local[:, 0], local[:, 2])
    height = local[:, 1]
    slack = 0.05 * face.module
    return ((height > face.root_height - slack)
            & (height < face.root_height + FACE_ROOT_BAND * face.module)
            & (polar > 0.0) & (polar < np.pi / face.teeth))


def fe_root_stress(gearset, stage: int, normal_force: float, *, level: str = "coarse",
                   refinement: float = 1.0, cache: str | Path = "cache") -> StageRootStress:
    """Root stresses of ``stage``'s tooth pair at the pitch point under ``normal_force``.

    Parameters
    ----------
    gearset : GearSet
    stage : int
        From 1.
    normal_force : float
        Normal force of the single pair [N] (> 0).
    level : {"coarse", "default", "fine"}
        Mesh level; ``refinement`` divides its element sizes
        (:class:`~fe_impact.gears.pairanalysis.PairSpec`).
    cache : str or Path
        Mesh cache folder (the pair is kept under ``meshes/root_<key>``).

    Returns
    -------
    StageRootStress
    """
    from fe_impact.calibration.meshcycle import PAIR_GAP, solve_static_pair
    from fe_impact.fe.elasticity import lame_from_youngpoisson
    from fe_impact.gears.pairanalysis import PairSpec, analyse_stage_pair
    from fe_impact.meshing.toothpair import build_pair, pair_key

    if not (math.isfinite(normal_force) and normal_force > 0.0):
        raise GeometryError(f"normal force {normal_force:g} N: must be a number > 0")
    options = dict(design_force=float(normal_force), refinement=float(refinement))
    spec = PairSpec(stage=stage, roll_angle_deg=0.0, level=level, order=2, gap=PAIR_GAP,
                    impact_speed=0.1, **options)
    folder = Path(cache) / "meshes" / f"root_{pair_key(gearset, spec)}"
    pair_mesh = build_pair(gearset, stage, 0.0, level, 2, PAIR_GAP, 0.1, folder, reuse=True,
                           **options)
    pair, analysis = analyse_stage_pair(gearset, spec)
    _, result = solve_static_pair(gearset, pair_mesh, (float(normal_force),))
    step, mesh = result.steps[-1], result.mesh
    skm = mesh.skfem_mesh
    u_dofs = np.zeros(result.model.n_dofs)
    used = mesh.point_dof >= 0
    for c in range(3):
        u_dofs[3 * mesh.point_dof[used] + c] = step.u[used, c]
    centroids = skm.p[:, skm.t[:4]].mean(axis=1).T
    mat = gearset.material
    lame = lame_from_youngpoisson(mat.youngs_modulus, mat.poisson_ratio)
    peaks = []
    for body, region in (("pinion", _pinion_root), ("face_gear", _face_root)):
        cells = mesh.volume(body)
        cells = cells[region(pair, analysis, centroids[cells])]
        peaks.append(peak_tension(skm, mesh.order, u_dofs, cells, lame))
    iso = iso_for_contact(pair, analysis.contact)
    face_width = pair.face.face_outer - pair.face.face_inner
    return StageRootStress(
        stage=stage, normal_force=float(normal_force), level=level, refinement=refinement,
        pinion=peaks[0], face=peaks[1], iso=iso,
        iso_stress=iso.nominal_stress(normal_force, face_width, pair.pinion.module,
                                      pair.pinion.pressure_angle),
        face_width=float(face_width), allowable=Y_ST * gearset.material.bending_stress_limit,
        contact_force=float(step.contact_force[0]))


# -- the report's section ---------------------------------------------------------------
def report_lines(results: list[StageRootStress]) -> list[str]:
    """A Markdown section: per stage the FE's peak root tensions, the ISO-style nominal
    stress and the allowable, with the element size at each peak."""
    if not results:
        return []
    r0 = results[0]
    lines = [
        "## Tooth-root bending stress", "",
        f"Each stage's tooth pair at the pitch point, pressed quasi-statically by the "
        f"largest mesh force on one pair ({r0.level} mesh"
        + (f", sizes / {r0.refinement:g}" if r0.refinement != 1.0 else "") + "). "
        "FE: the largest maximum principal stress in the loaded-side root of the loaded "
        "tooth (vertex stresses averaged over the elements sharing the vertex). ISO: "
        "ISO 6336-3 method B's sigma_F0 = F_t/(b m) Y_F Y_S of the pinion, 30 deg "
        "tangent section on its generated fillet, load at the FE's contact point, b the "
        "face gear's face width. Allowable: Y_ST sigma_Flim = 2 sigma_Flim (ISO 6336-5; "
        "material.bending_stress_limit_pa).", "",
        "| stage | F_n [N] | pinion FE [MPa] | element at peak [mm] | ISO sigma_F0 [MPa] "
        "| FE / ISO | Y_F | Y_S | face gear FE [MPa] | element at peak [mm] "
        "| allowable [MPa] | pinion FE / allowable |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        lines.append(
            f"| {r.stage} | {r.normal_force:.4g} | {r.pinion.stress * 1e-6:.4g} | "
            f"{r.pinion.element_size * 1e3:.3g} | {r.iso_stress * 1e-6:.4g} | "
            f"{r.pinion.stress / r.iso_stress:.3g} | {r.iso.y_f:.3f} | {r.iso.y_s:.3f} | "
            f"{r.face.stress * 1e-6:.4g} | {r.face.element_size * 1e3:.3g} | "
            f"{r.allowable * 1e-6:.4g} | {r.pinion.stress / r.allowable:.3f} |")
    lines += [
        "",
        "Mesh resolution: the peak is read at vertices, on elements of the size shown; "
        "a coarse mesh at the fillet underestimates it (the pinion's fillet radius "
        f"rho_F is {r0.iso.rho_f * 1e3:.3g} mm on stage {r0.stage}). The face gear's "
        "root is modelled as a sharp corner, where the elastic stress is singular: its "
        "figure grows with refinement and is no fillet stress. FE / ISO above 1 is "
        "expected: the localised contact loads a shorter length of the face than b.", ""]
    return lines
