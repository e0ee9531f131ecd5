"""The package's version, in a module of its own so that any module can read it
without importing :mod:`fe_impact` (whose ``__init__`` imports the API)."""

__version__ = "0.5.0"
