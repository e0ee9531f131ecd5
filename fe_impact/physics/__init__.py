"""Closed forms and lumped contact laws: Hertz contact and impact theory (`hertz`), the
ADAMS IMPACT/STEP law written once as compiled scalar functions (`impact_law`), the
hysteresis-damping models and the 1-DOF impact (`laws`), the seed's eqs. 12-17 (`seed`).
No finite elements here."""
