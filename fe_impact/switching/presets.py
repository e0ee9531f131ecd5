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
The cases are the package's schedule files (`fe_impact.switching.schedule`,
``schedules/<case>.toml``), read by the same reader as a user's ``--schedule``
file; this module groups them and names the seed tables they are compared with.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

from fe_impact.errors import CaseError
from fe_impact.switching.model import StageSchedule
from fe_impact.switching.schedule import SCHEDULE_DIR, DutyCycle, read_schedule

__all__ = ["PRESETS", "Case", "Preset", "get_preset", "preset_file", "schedule_preset",
           "seed_load_torque"]

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
    """A seed condition set, or a user's schedule (`schedule_preset`).

    Attributes
    ----------
    name : str
    description : str
    cases : tuple of Case
    seed_table : str or None
        Key of `fe_impact.switching.seed_tables.SEED_TABLES`; None for a user's
        schedule (nothing to compare with).
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
    seed_table: str | None
    figures: str
    layout: str
    stage: int | None = None

    @property
    def duration(self) -> float:
        """Simulated time of all cases [s]."""
        return sum(c.schedule.duration for c in self.cases)

    def scaled(self, duration: float) -> Preset:
        """Each case stretched or shrunk to ``duration`` [s] of simulated time.

        The blends of speed and load between segments keep their length (they are
        the drive's, not the run's): a segment shrunk below its blend is refused
        naming the shortest ``duration`` that keeps every blend.
        """
        from fe_impact.switching.model import DriveModel

        scaled = replace(self, cases=tuple(replace(c, schedule=c.schedule.scaled(duration))
                                           for c in self.cases))
        for case in scaled.cases:
            for i, seg in enumerate(case.schedule.segments[1:], start=1):
                blend = DriveModel.ramp_time if seg.blend is None else seg.blend
                if seg.duration < blend:
                    needed = max((DriveModel.ramp_time if s.blend is None else s.blend)
                                 / s.duration * duration
                                 for s in case.schedule.segments[1:])
                    raise CaseError(
                        f"--duration = {duration:g} s: {case.name}'s segments[{i}] would "
                        f"last {seg.duration:.3g} s, shorter than its {blend:g} s blend of "
                        f"speed and load (blend_s); give --duration {needed:.3g} or more")
        return scaled


def preset_file(case: str) -> Path:
    """The package's schedule file of the seed case ``case`` (``table1-100rpm``, ...)."""
    return SCHEDULE_DIR / f"{case}.toml"


@cache
def _read(case: str) -> DutyCycle:
    return read_schedule(preset_file(case))


#: The seed's condition sets: name, (case file, seed column label) per case, seed table,
#: seed figures, layout, stage of a ``conditions`` layout, description.
_GROUPS = (
    *((f"table{n}", tuple((f"table{n}-{rpm}rpm", f"{rpm} r/min") for rpm in (100, 300, 1000)),
       f"table{n}", "Figures 8-11" if n == 1 else "none in the seed (cf. Figures 8-11)",
       "conditions", n,
       f"stage {n}, no load, constant pinion speed 100/300/1000 r/min, 5 s each (seed "
       f"section 4.1, Table {n})") for n in (1, 2, 3)),
    ("table4", tuple((f"table4-{load}Nmm", f"{load} N mm") for load in (50, 200, 500, 1000)),
     "table4", "Figures 12-15", "conditions", 2,
     "stage 2, 300 r/min, load 50/200/500/1000 N mm on the output, 5 s each (seed section "
     "4.2, Table 4)"),
    ("variable-speed", (("variable-speed", "multistage"),), "section5.1", "Figures 17-20",
     "stages", None, None),
    ("variable-load", (("variable-load", "multistage"),), "section5.2", "Figures 21-24",
     "stages", None, None),
)


def _all_presets() -> dict[str, Preset]:
    presets = {}
    groups = []
    for name, cases, table, figures, layout, stage, description in _GROUPS:
        runs = tuple(Case(case, condition, _read(case).schedule) for case, condition in cases)
        group = Preset(name, description or _read(cases[0][0]).description, runs, table,
                       figures, layout, stage)
        groups.append(group)
        presets[name] = group
    for group in groups:
        if len(group.cases) == 1:
            continue
        for case in group.cases:
            presets[case.name] = Preset(
                case.name, f"{group.description}: {case.condition} only", (case,),
                group.seed_table, group.figures, group.layout, group.stage,
            )
    return presets


def schedule_preset(duty: DutyCycle) -> Preset:
    """A user's schedule as a study of one case (no seed table to compare with)."""
    return Preset(duty.name, duty.description or f"schedule {duty.source or duty.name}",
                  (Case(duty.name, "schedule", duty.schedule),), None, "none", "stages")


#: Every preset by name.
PRESETS: dict[str, Preset] = _all_presets()


def get_preset(name: str) -> Preset:
    """The preset called ``name``; CaseError naming the choices otherwise."""
    try:
        return PRESETS[name]
    except KeyError:
        raise CaseError(f"--preset = {name!r} is not a preset; pick one of "
                        f"{sorted(PRESETS)} (fe-impact switching --list)") from None


def seed_load_torque() -> float:
    """Largest load torque [N m] on the output among the seed presets (1 N m: the
    seed's 1000 N mm, presets ``table4`` and ``variable-load``): the geometry
    report's default load (:func:`fe_impact.api.geometry_report`)."""
    return max(seg.load for preset in PRESETS.values() for case in preset.cases
               for seg in case.schedule.segments)
