"""The seed's operating conditions as ready-made schedules (seed sections 4 and 5).

Each `Preset` is one or more cases (a case is one run of a `StageSchedule`)
and names the seed table its statistics are compared with:

- ``table1``, ``table2``, ``table3``: one stage, no load, constant pinion
  speed 100, 300 and 1000 r/min, 5 s each (seed section 4.1, Tables 1-3,
  Figures 8-11 for stage 1);
- ``table4``: stage 2 at 300 r/min with loads 50, 200, 500, 1000 N mm, 5 s
  each (section 4.2, Table 4, Figures 12-15);
- ``variable-speed``: stages 1, 2, 3 at 100, 300, 1000 r/min, no load, 5 s
  per segment, switching at each step (section 5.1, Figures 17-20);
- ``variable-load``: 300 r/min, loads 50, 200, 500, 1000 N mm in 5 s steps,
  switching 1 -> 2 -> 3 with the first three loads, the last load on stage 3
  (section 5.2, Figures 21-24; the seed does not say which load acts on
  which stage).

Every case is also a preset of its own (``table1-100rpm``, ``table4-500Nmm``, ...).
"""

from __future__ import annotations

from dataclasses import dataclass

from fe_impact.errors import CaseError
from fe_impact.switching.model import Segment, StageSchedule

__all__ = ["PRESETS", "Case", "Preset", "get_preset"]

#: The seed's segment length [s] (sections 4 and 5: "5 s", "5-second intervals").
SEGMENT = 5.0
_SPEEDS = (100.0, 300.0, 1000.0)
_LOADS = (0.05, 0.2, 0.5, 1.0)  # N m: the seed's 50, 200, 500, 1000 N mm


@dataclass(frozen=True)
class Case:
    """One run: a schedule and the seed condition (column) it stands for.

    Attributes
    ----------
    name : str
        Identifier used in file names.
    condition : str
        Column label of the seed table (``"100 r/min"``, ``"50 N mm"``), or
        ``"multistage"`` for the switching runs.
    schedule : StageSchedule
    """

    name: str
    condition: str
    schedule: StageSchedule


@dataclass(frozen=True)
class Preset:
    """A seed condition set.

    Attributes
    ----------
    name : str
    description : str
    cases : tuple of Case
    seed_table : str
        Key of `fe_impact.switching.seed_tables.SEED_TABLES`.
    figures : str
        The seed figures the plots correspond to.
    layout : {"conditions", "stages"}
        ``conditions``: one column per case, all on ``stage``; ``stages``: one
        multistage case, one column per stage.
    stage : int or None
        The stage of a ``conditions`` preset.
    """

    name: str
    description: str
    cases: tuple[Case, ...]
    seed_table: str
    figures: str
    layout: str
    stage: int | None = None

    @property
    def duration(self) -> float:
        """Simulated time of all cases [s]."""
        return sum(c.schedule.duration for c in self.cases)

    def scaled(self, duration: float) -> Preset:
        """Each case stretched or shrunk to ``duration`` [s] of simulated time."""
        cases = tuple(Case(c.name, c.condition, c.schedule.scaled(duration)) for c in self.cases)
        return Preset(self.name, self.description, cases, self.seed_table, self.figures,
                      self.layout, self.stage)


def _speed_table(number: int) -> Preset:
    cases = tuple(
        Case(f"table{number}-{rpm:.0f}rpm", f"{rpm:.0f} r/min",
             StageSchedule((Segment(SEGMENT, number, rpm),)))
        for rpm in _SPEEDS
    )
    figures = "Figures 8-11" if number == 1 else "none in the seed (cf. Figures 8-11)"
    return Preset(
        f"table{number}",
        f"stage {number}, no load, constant pinion speed 100/300/1000 r/min, 5 s each "
        f"(seed section 4.1, Table {number})",
        cases, f"table{number}", figures, "conditions", number,
    )


def _load_table() -> Preset:
    cases = tuple(
        Case(f"table4-{load * 1e3:.0f}Nmm", f"{load * 1e3:.0f} N mm",
             StageSchedule((Segment(SEGMENT, 2, 300.0, load),)))
        for load in _LOADS
    )
    return Preset(
        "table4",
        "stage 2, 300 r/min, load 50/200/500/1000 N mm on the output, 5 s each "
        "(seed section 4.2, Table 4)",
        cases, "table4", "Figures 12-15", "conditions", 2,
    )


def _variable_speed() -> Preset:
    schedule = StageSchedule(tuple(Segment(SEGMENT, stage, rpm)
                                   for stage, rpm in zip((1, 2, 3), _SPEEDS, strict=True)))
    return Preset(
        "variable-speed",
        "stages 1 -> 2 -> 3 at 100 -> 300 -> 1000 r/min, no load, 5 s per segment, ratio "
        "switching with each speed step (seed section 5.1)",
        (Case("variable-speed", "multistage", schedule),), "section5.1", "Figures 17-20",
        "stages",
    )


def _variable_load() -> Preset:
    schedule = StageSchedule(tuple(Segment(SEGMENT, stage, 300.0, load)
                                   for stage, load in zip((1, 2, 3, 3), _LOADS, strict=True)))
    return Preset(
        "variable-load",
        "300 r/min, load 50 -> 200 -> 500 -> 1000 N mm in 5 s steps, stages 1 -> 2 -> 3 -> 3 "
        "(seed section 5.2)",
        (Case("variable-load", "multistage", schedule),), "section5.2", "Figures 21-24",
        "stages",
    )


def _all_presets() -> dict[str, Preset]:
    groups = [_speed_table(1), _speed_table(2), _speed_table(3), _load_table(),
              _variable_speed(), _variable_load()]
    presets = {p.name: p for p in groups}
    for group in groups:
        if len(group.cases) == 1:
            continue
        for case in group.cases:
            presets[case.name] = Preset(
                case.name, f"{group.description}: {case.condition} only", (case,),
                group.seed_table, group.figures, group.layout, group.stage,
            )
    return presets


#: Every preset by name.
PRESETS: dict[str, Preset] = _all_presets()


def get_preset(name: str) -> Preset:
    """The preset called ``name``; CaseError naming the choices otherwise."""
    try:
        return PRESETS[name]
    except KeyError:
        raise CaseError(f"--preset = {name!r} is not a preset; pick one of "
                        f"{sorted(PRESETS)} (fe-impact switching --list)") from None
