"""Exceptions raised for user mistakes; the CLI prints them without a traceback."""


class FeImpactError(Exception):
    """Base class: a problem with user input or a run that the user can fix."""


class CaseError(FeImpactError):
    """An invalid case file: the message names the key, the value and what is allowed."""


class MeshError(FeImpactError):
    """A mesh that cannot be used: missing file, unsupported cells, missing groups."""


class ContactError(FeImpactError):
    """Contact could not be resolved (no convergence, contact outside the search zone)."""


class SolverError(FeImpactError):
    """A solve failed: singular stiffness (unconstrained body), divergence, NaN."""


class GeometryError(FeImpactError):
    """An invalid gear set or a tooth geometry that cannot be generated."""


class CalibrationError(FeImpactError):
    """A calibration that cannot be carried out or fitted."""
