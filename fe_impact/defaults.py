"""Constants the command line needs before any heavy module is loaded.

``fe-impact --help`` and a mistaken option build the whole parser, whose
help texts and checks quote these values; importing them from the modules
that use them loaded numba, scipy.optimize and the switching kernels first
(1.4-2.8 s before a help text or a one-line error). Those modules import
them from here, so each value is written once.
"""

from __future__ import annotations

#: Refinement levels a pair can be meshed at (their element sizes:
#: :data:`fe_impact.meshing.sizing.LEVELS`).
LEVEL_NAMES = ("coarse", "default", "fine")
#: Allowed :attr:`~fe_impact.gears.pairanalysis.PairSpec.refinement` (a level's
#: sizes divided by it).
REFINEMENT_RANGE = (0.5, 4.0)
#: Default time-series sampling interval of a switching study [s].
SAMPLE_INTERVAL = 2e-4
#: The seed's largest load torque on the output [N m]: 1000 N mm (section 4.2,
#: Table 4, and the variable-load run); the load at which the mesh cycle's
#: nominal force is taken. The presets' schedules carry the same largest load
#: (:func:`fe_impact.switching.presets.seed_load_torque`, checked by a test).
SEED_LOAD_TORQUE = 1.0
