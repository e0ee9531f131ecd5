"""The seed study's impact statistics, transcribed for side-by-side comparison.

Source: "Study on Impact Characteristics of Multistage Double Crown Face
Gear Pairs considering Ratio Switching under Variable Conditions", Shock and
Vibration 2020, article 8880093 (``/work/shared/seed``): Tables 1-4 and the
statistics given in the text of sections 5.1 and 5.2. Values are in the
seed's units (`SEED_UNITS`), exactly as printed; obvious misprints are kept
and listed in each table's ``notes``.

The seed computed them in ADAMS (IMPACT contact, force exponent 1.5,
"damping 10", "penetration depth 0.1", friction 0.02/0.05), with output every
0.01 s (5 s, 500 steps), on its own definitions of the quantities, which it
does not state.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "QUANTITIES",
    "SEED_TABLES",
    "SEED_UNITS",
    "STATISTICS",
    "SeedTable",
    "TO_SEED_UNITS",
]

QUANTITIES = ("elastic_displacement", "impact_speed", "impact_force", "potential_energy")
STATISTICS = ("average", "maximum", "minimum")
#: The seed's row labels and units.
LABELS = {
    "elastic_displacement": "Elastic displacement",
    "impact_speed": "Impact speed",
    "impact_force": "Impact force",
    "potential_energy": "Potential energy",
}
SEED_UNITS = {
    "elastic_displacement": "mm",
    "impact_speed": "mm/s",
    "impact_force": "N",
    "potential_energy": "N mm",
}
#: Factor from SI (m, m/s, N, J) to the seed's units.
TO_SEED_UNITS = {
    "elastic_displacement": 1e3,
    "impact_speed": 1e3,
    "impact_force": 1.0,
    "potential_energy": 1e3,
}

Row = tuple[float | None, ...]


@dataclass(frozen=True)
class SeedTable:
    """One table of the seed: statistics per quantity for a few conditions.

    Attributes
    ----------
    key : str
        Short name (``"table1"`` ... ``"section5.2"``).
    source : str
        Where in the seed it is printed.
    title : str
        The seed's caption (or our description for the text values).
    conditions : tuple of str
        Column labels, in the seed's order.
    values : dict
        ``(quantity, statistic) -> row``, one value per condition, seed
        units; None where the seed gives nothing.
    notes : tuple of str
        Transcription remarks (misprints, inconsistencies).
    """

    key: str
    source: str
    title: str
    conditions: tuple[str, ...]
    values: dict[tuple[str, str], Row]
    notes: tuple[str, ...] = ()

    def value(self, quantity: str, statistic: str, condition: str) -> float | None:
        """The seed's value, or None if it gives none."""
        row = self.values.get((quantity, statistic))
        if row is None:
            return None
        return row[self.conditions.index(condition)]


def _table(rows: list[Row]) -> dict[tuple[str, str], Row]:
    """Rows in the seed's order: each quantity's average, maximum, minimum."""
    keys = [(q, s) for q in QUANTITIES for s in STATISTICS]
    return dict(zip(keys, rows, strict=True))


_SPEEDS = ("100 r/min", "300 r/min", "1000 r/min")
_LOADS = ("50 N mm", "200 N mm", "500 N mm", "1000 N mm")
_STAGES = ("stage 1", "stage 2", "stage 3", "all stages")

TABLE1 = SeedTable(
    "table1", "Table 1",
    "Impact characteristics of first-stage face gear pair without load",
    _SPEEDS,
    _table([
        (-8.0199e-9, -6.2775e-9, -6.5348e-9),
        (1.0025e-5, 1.0025e-5, 1.0025e-5),
        (-1.0025e-5, -1.0025e-5, -1.0025e-5),
        (2.1584e-9, 9.9828e-14, 3.0602e-12),
        (8.7977e-11, 2.7733e-10, 1.08e-9),
        (-1.7088e-10, -5.2114e-10, -7.494e-10),
        (3256.1729, 9866.4246, -13394.779),
        (5.5148e5, 1.706e6, 2.7373e6),
        (4.7126e5, -2.8154e6, -2.9636e6),
        (-1.0159e-11, -4.2425e-13, -9.8202e-12),
        (3.0774e-12, 1.2347e-11, 3.4151e-12),
        (-2.4337e-11, -1.4861e-11, -2.3118e-11),
    ]),
    notes=(
        "100 r/min: the average impact speed 2.1584e-9 exceeds the maximum 8.7977e-11.",
        "100 r/min: the minimum impact force is printed positive (4.7126e5) and above the "
        "average; a lost minus sign is likely.",
        "Potential-energy averages and minima are negative, impossible for an elastic energy.",
    ),
)

TABLE2 = SeedTable(
    "table2", "Table 2",
    "Impact characteristics of second-stage face gear pair without load",
    _SPEEDS,
    _table([
        (-1.7049e-8, -7.0152e-9, -1.159e-8),
        (1.0025e-5, 1.0025e-5, 1.0026e-5),
        (-1.0025e-5, -1.0025e-5, -1.0026e-5),
        (6.4462e-7, 2.396e-6, 4.3966e-6),
        (7.8611e-5, 7.062e-4, 0.0074),
        (-7.8611e-5, -7.062e-4, -0.0074),
        (-1562.3735, -1405.1084, -5081.029),
        (12697.6068, 1.3269e6, 4.3211e6),
        (-8.8042e5, -1.7125e6, -3.178e6),
        (3.8642e-12, 3.2022e-12, 2.7812e-12),
        (1.251e-12, 9.0937e-12, 8.3118e-12),
        (-8.8742e-13, -5.3641e-12, -7.2312e-12),
    ]),
    notes=(
        "1000 r/min minimum impact force printed 'v3.178e+6'; read as -3.178e6.",
        "100 r/min: the average potential energy 3.8642e-12 exceeds the maximum 1.251e-12.",
    ),
)

TABLE3 = SeedTable(
    "table3", "Table 3",
    "Impact characteristics of third-stage face gear pair without load",
    _SPEEDS,
    _table([
        (-1.8876e-8, -1.15e-8, -1.1099e-8),
        (1.7158e-5, 1.7158e-5, 1.7159e-5),
        (-1.7158e-5, -1.7158e-5, -1.7159e-5),
        (-7.816e-7, 3.3185e-6, 1.6834e-7),
        (7.4697e-5, 6.7111e-4, 0.007),
        (-7.4697e-5, -6.7114e-4, -0.007),
        (489.4656, -12606.378, 5424.4439),
        (2.7706e5, 1.7801e6, 3.2413e6),
        (-2.5713e5, -3.2257e6, -3.2271e6),
        (-9.6468e-12, -1.4576e-11, 1.6241e-11),
        (7.1451e-12, 1.691e-12, 3.5178e-11),
        (-2.7449e-11, -3.3082e-11, -8.336e-13),
    ]),
    notes=(
        "Elastic displacement extremes are 1.7158e-5 mm here, 1.0025e-5 mm in Tables 1-2.",
        "Negative potential energies, impossible for an elastic energy (also Tables 1, 2, 4).",
    ),
)

TABLE4 = SeedTable(
    "table4", "Table 4",
    "Impact characteristics of second-stage face gear pair at 300 r/min (printed: "
    "'with no loading', '1800 d') under loads 50-1000 N mm",
    _LOADS,
    _table([
        (2.7812e-12, -6.2655e-9, -6.1767e-9, -6.0065e-9),
        (8.3118e-12, 1.0025e-5, 1.0026e-5, 1.0026e-5),
        (-7.2312e-12, -1.0025e-5, -1.0026e-5, -1.0026e-5),
        (-3.6226e-6, -7.5672e-7, 1.9293e-6, 9.9178e-12),
        (7.062e-4, 5.8584e-4, 6.6586e-4, 6.774e-4),
        (-7.062e-4, -7.062e-4, -7.062e-4, -4.9694e-4),
        (-7331.2135, -9540.3287, 12724.0843, -9526.0254),
        (3.1548e6, 2.3528e6, 4.1946e6, 3.2087e6),
        (-1.8003e6, -2.4418e6, -2.5312e6, -2.2345e6),
        (-9.8052e-12, -2.8836e-12, 9.3807e-13, 2.6048e-12),
        (2.8218e-13, 7.6622e-12, 6.9592e-12, 9.04e-12),
        (-1.6372e-11, -8.8735e-12, -5.7774e-12, -6.4243e-12),
    ]),
    notes=(
        "The caption says 'with no loading'; the columns are the loads of section 4.2.",
        "'1800 d' is 1800 deg/s = 300 r/min.",
        "The 50 N mm elastic displacements (2.7812e-12, 8.3118e-12, -7.2312e-12) repeat "
        "Table 2's 1000 r/min potential energies: probably a copy error.",
    ),
)

SECTION_5_1 = SeedTable(
    "section5.1", "Section 5.1 (text)",
    "Multistage drive, variable speed 100/300/1000 r/min, no load, 5 s per segment",
    _STAGES,
    _table([
        (None, None, None, -1.4103e-7),
        (None, None, None, 1.7158e-5),
        (None, None, None, -1.7158e-5),
        (-3.0556e-12, 7.2625e-12, 1.2286e-12, None),
        (4.0268e-9, 3.0316e-9, 4.0452e-9, None),
        (-3.192e-9, -2.7292e-9, -5.5955e-9, None),
        (-3522.2826, -2226.9693, 1438.7766, None),
        (4.0564e6, 4.112e6, 2.6672e6, None),
        (-3.2795e6, -3.2088e6, -2.7074e6, None),
        (4.9842e-11, 4.2229e-11, 8.6744e-12, None),
        (1.104e-10, 1.2835e-10, 7.6e-11, None),
        (-1.0296e-11, -2.7808e-13, -2.2555e-11, None),
    ]),
    notes=("The elastic displacement is given for the whole drive only.",),
)

SECTION_5_2 = SeedTable(
    "section5.2", "Section 5.2 (text)",
    "Multistage drive, constant 300 r/min ('1800 d'), loads 50/200/500/1000 N mm in 5 s "
    "steps",
    _STAGES,
    _table([
        (None, None, None, -4.0544e-9),
        (None, None, None, 1.7158e-5),
        (None, None, None, -1.7158e-5),
        (-2.0046e-12, -7.4868e-12, -7.8208e-12, None),
        (1.4651e-9, 3.463e-9, 4.3068e-9, None),
        (-2.6721e-9, -7.0923e-9, -7.3688e-9, None),
        (8452.1594, 199.8161, 3543.5363, None),
        (3.6891e6, 2.063e6, 3.048e6, None),
        (-1.9428e6, -2.671e6, -2.8631e6, None),
        (4.9998e-11, 6.2415e-11, 2.6771e-11, None),
        (1.1046e-10, 1.291e-10, 7.6e-11, None),
        (-1.0258e-11, -4.8665e-13, -2.2602e-11, None),
    ]),
    notes=(
        "The elastic displacement is given for the whole drive only.",
        "The seed does not say which load acts on which stage.",
    ),
)

#: All transcribed tables by key.
SEED_TABLES: dict[str, SeedTable] = {
    t.key: t for t in (TABLE1, TABLE2, TABLE3, TABLE4, SECTION_5_1, SECTION_5_2)
}
