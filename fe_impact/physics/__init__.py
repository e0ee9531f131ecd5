"""Closed forms and lumped contact laws: Hertz contact and impact theory, the
ADAMS IMPACT/STEP law, hysteresis-damping models. No finite elements here."""
