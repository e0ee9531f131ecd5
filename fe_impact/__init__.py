"""fe-impact: finite-element tooth impact for face-gear transmissions.

The package follows the data flow of a calibration: gear set -> tooth
surfaces -> mesh -> assembly -> contact -> time integration -> calibration
-> lumped model -> results.
"""

__version__ = "0.3.1"
