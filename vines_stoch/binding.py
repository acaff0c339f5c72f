"""Uncertain parameters bound to the arrays of a scene, once a study and sweep point.

A realisation's scene is the sweep point's scene with its drawn values written into the slots
they set: equal bitwise to the scene of the point validated again with the values set and built
again (``build_scene(study.realise(point, values))``, tens to hundreds of microseconds of Python
a realisation).  A key (``absorbers.0.stiffness``) is bound one of four ways:

- a slot, the value as it is: a floor's or an absorber's mass in ``mass``, a storey's stiffness
  or dashpot (``storey_k``, ``storey_c``), a column of an absorber's row (``ROW_COLUMNS``), of a
  closed-form force row (``FORCE_COLUMNS``; a harmonic frequency also moves the Poincare
  samples, ``scene.poincare_samples``), a limit's value, the intensity measures' period and
  damping;
- a term of a sum over the loads in file order, as ``build_scene`` adds them: an impulse's
  velocity in ``v0``, a white-noise intensity in ``sigma`` (while the intensity keeps the sign it
  has at the sweep point: noise or none decides the scheme; a draw that changes it takes the
  last way);
- a rebuild of what its item sets, from a copy of the item with its values set: a Hertz
  absorber's row (``scene.absorber_row``: walls, rest offset, contact constants) and start in
  ``x0``, Rayleigh dashpots (``Primary.damping_matrices``), a record's scaled samples;
- the realised path, the whole scenario validated and built again: any key of the time grid
  (``simulation.*``), of filtered noise, ground motion or wind (their filters), of envelopes or
  initial conditions, a record's time step, a key of an absorber type without an entry in
  ``ROW_COLUMNS``, the ensemble's settings.  One such key sends every realisation that way.

Every drawn value is checked as validation checked it, with the same one-line message naming the
file, key, value and rule: against the range of its field's type (``FieldRange``) and, where its
item's fields are checked against each other (a Hertz obstacle within the gap, a pulse no wider
than its period, Rayleigh damping of a primary fixed to the ground), by those checks.  The
scenario's own cross-section checks read none of the values bound here.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Any

from pydantic import BaseModel

from .physics.absorbers import COLUMNS
from .scenario import (
    BaseHarmonicLoad,
    BlastLoad,
    ForceRecordLoad,
    HarmonicLoad,
    ImpulseLoad,
    InitialLoad,
    Primary,
    RecordLoad,
    Scenario,
    ScenarioError,
    Study,
    WhiteNoiseLoad,
)
from .scenario.bodies import ABSORBERS
from .scenario.errors import format_error
from .scenario.study import FieldRange, checked_models, cross_check, field_range
from .scene import Scene, absorber_row, build_scene, closed_form_rows, poincare_samples

#: Absorber fields held as they are in one column of the absorber's row (``scene.absorber_row``).
ROW_COLUMNS = {kind: {name: COLUMNS[column] for name, column in model.columns.items()}
               for kind, model in ABSORBERS.items()}
#: Absorber types whose other fields rebuild the absorber's row and start (walls, contact).
ROWS_REBUILT = tuple(kind for kind, model in ABSORBERS.items() if model.derived)
#: Fields of closed-form force rows held as they are, in columns 1, 2, ... (``build_scene``).
FORCE_COLUMNS = {
    "harmonic": ("amplitude", "frequency", "phase"),
    "half-sine": ("amplitude", "duration", "start"),
    "pulse-train": ("amplitude", "width", "period", "start"),
    "chirp": ("amplitude", "f0", "f1", "duration"),
    "blast": ("amplitude", "duration", "decay", "start"),
    "base-harmonic": ("amplitude", "frequency", "phase"),
}
#: Fields of a record that scale its samples (not its time step: that changes the times).
RECORD_SCALES = ("scale", "sa")

#: The arrays of a primary's fields: one storey (``mass``...) or a building (``masses``...).
PRIMARY_ARRAYS = {"mass": "mass", "masses": "mass", "stiffness": "storey_k", "stiffnesses": "storey_k",
                  "damping": "storey_c", "dampings": "storey_c"}


def _identity(value: float) -> float:
    return value


def _or_zero(value: float) -> float:
    """A one-storey primary's stiffness or damping as ``Primary`` gives it."""
    return value or 0.0


def _replaced(node: Any, parts: list[str], value: float) -> Any:
    """A copy of ``node`` (a model or list, not validated again) with the field at ``parts``
    set to ``value``."""
    if not parts:
        return value
    head, rest = parts[0], parts[1:]
    if isinstance(node, list):
        copy = list(node)
        copy[int(head)] = _replaced(node[int(head)], rest, value)
        return copy
    return node.model_copy(update={head: _replaced(getattr(node, head), rest, value)})


@dataclass
class _Sum:
    """A slot that ``build_scene`` sums over the loads in file order from 0: ``terms`` are
    constants or keys (``squared``: of the terms' squares, the slot the square root)."""

    terms: list[float | str]
    squared: bool = False

    def value(self, values: dict[str, float]) -> float:
        total = 0.0
        for term in self.terms:
            x = values[term] if isinstance(term, str) else term
            total += x**2 if self.squared else x
        return math.sqrt(total) if self.squared else total


@dataclass
class _Item:
    """An item of the scenario (the primary, an absorber, a load) whose drawn values are set in a
    copy of it, for the checks of the models at ``where`` and the ``rebuilds`` (by what they
    rebuild; each takes the copy and the scene's fields)."""

    key: str
    model: BaseModel
    parts: dict[str, list[str]] = field(default_factory=dict)
    where: list[str] = field(default_factory=list)
    rebuilds: dict[str, Callable[[Any, dict[str, Any]], None]] = field(default_factory=dict)
    writes: set[str] = field(default_factory=set)  # the scene's fields the rebuilds write

    def add(self, parts: list[str]) -> None:
        """A drawn key at ``parts`` below the item."""
        self.parts[".".join([self.key, *parts])] = parts
        self.where = list(dict.fromkeys(self.where + checked_models(self.model, ".".join(parts))))

    def rebuild(self, make: Callable[[Any, dict[str, Any]], None], *writes: str) -> None:
        """Rebuild the scene's fields ``writes`` with ``make`` (once, whichever keys ask)."""
        self.rebuilds.setdefault(writes[0], make)
        self.writes.update(writes)

    def apply(self, values: dict[str, float], fields: dict[str, Any], source: str) -> None:
        item = self.model
        for key, parts in self.parts.items():
            item = _replaced(item, parts, values[key])
        cross_check(item, self.where, self.key, source)
        for rebuild in self.rebuilds.values():
            rebuild(item, fields)


class Binding:
    """The uncertain parameters of sweep point ``point`` of ``study`` bound to its scene (see the
    module): ``scene(values)`` is the scene of a realisation; ``fallback`` names the keys that
    send it the realised path."""

    def __init__(self, study: Study, point: int):
        self.study, self.point, self.source = study, point, study.source
        scenario = study.points[point]
        self.base = build_scene(scenario)
        self.ranges: dict[str, FieldRange] = {}
        self.fallback: list[str] = []
        self.signs: dict[str, bool] = {}  # key -> whether its value is > 0 at the sweep point
        self.slots: list[tuple[str, str, Any, Callable[[float], float]]] = []  # key, field, index, transform
        self.sums: dict[tuple[str, int], _Sum] = {}
        self.items: dict[str, _Item] = {}
        self.poincare: Callable[[Any], tuple[float, float, int]] | None = None
        for key in study.base.uncertain:
            rule = field_range(scenario, key)
            if rule is not None and self._bind(scenario, key):
                self.ranges[key] = rule
            else:
                self.fallback.append(key)
        # (an item without checks or rebuilds has slots alone)
        self.items = {k: item for k, item in self.items.items() if item.where or item.rebuilds}
        self.copied = sorted({name for _, name, index, _ in self.slots if index is not None}
                             | {name for name, _ in self.sums}
                             | {name for item in self.items.values() for name in item.writes})

    def scene(self, values: dict[str, float]) -> Scene:
        """The scene of the sweep point with the uncertain parameters ``values``; ScenarioError
        (one line a mistake) for values their fields do not allow."""
        if self.fallback:
            return build_scene(self.study.realise(self.point, values))
        refused = {key: why for key, rule in self.ranges.items()
                   if (why := rule.refusal(values[key])) is not None}
        if refused:
            raise ScenarioError("\n".join(format_error(self.source, key, values[key], why)
                                          for key, why in refused.items()), tuple(refused))
        if any((values[key] > 0) != positive for key, positive in self.signs.items()):
            return build_scene(self.study.realise(self.point, values))
        fields = {name: getattr(self.base, name).copy() for name in self.copied}
        for key, name, index, transform in self.slots:
            if index is None:
                fields[name] = transform(values[key])
            else:
                fields[name][index] = transform(values[key])
        for (name, index), total in self.sums.items():
            fields[name][index] = total.value(values)
        for item in self.items.values():
            item.apply(values, fields, self.source)
        if self.poincare is not None:
            period, sample_from, count = self.poincare(fields["forces"])
            fields.update(period=float(period), sample_from=float(sample_from), n_samples=count)
        return dataclasses.replace(self.base, **fields)

    def _item(self, key: str, model: BaseModel, parts: list[str]) -> _Item:
        """The item at ``key`` (made on first use) with a drawn key at ``parts`` below it."""
        item = self.items.setdefault(key, _Item(key, model))
        item.add(parts)
        return item

    def _slot(self, key: str, name: str, index: Any, transform: Callable[[float], float] = _identity) -> None:
        self.slots.append((key, name, index, transform))

    def _bind(self, scenario: Scenario, key: str) -> bool:
        """Bind ``key``; False where it takes the realised path."""
        head, *parts = key.split(".")
        if head == "primary":
            return self._bind_primary(scenario.primary, key, parts)
        if head in ("absorbers", "loads") and parts and parts[0].isdigit():
            bind = self._bind_absorber if head == "absorbers" else self._bind_load
            return bind(scenario, key, int(parts[0]), parts[1:])
        if head == "limits" and parts[1:] == ["value"]:
            metric = scenario.limits[parts[0]].metric
            if metric.startswith("drift_ratio_max_"):  # (the kernels watch the storey's drift)
                return False
            self._slot(key, "limits", (list(scenario.limits).index(parts[0]), 2))
            return True
        if head == "intensity_measures" and parts in (["period"], ["damping"]):
            self._slot(key, f"im_{parts[0]}", None)
            return True
        return False

    def _bind_primary(self, primary: Primary, key: str, parts: list[str]) -> bool:
        single = primary.masses is None
        if parts[0] in PRIMARY_ARRAYS and len(parts) == (1 if single else 2):
            self._slot(key, PRIMARY_ARRAYS[parts[0]], 0 if single else int(parts[1]),
                       _or_zero if single and parts[0] != "mass" else _identity)
        elif parts != ["rayleigh", "ratio"]:
            return False
        item = self._item("primary", primary, parts)
        if primary.rayleigh is not None and parts[0] in ("masses", "stiffnesses", "rayleigh"):
            item.rebuild(_rayleigh, "storey_c", "floor_c")
        return True

    def _bind_absorber(self, scenario: Scenario, key: str, a: int, parts: list[str]) -> bool:
        absorber = scenario.absorbers[a]
        columns = ROW_COLUMNS.get(absorber.type)
        body = scenario.primary.n_floors + a
        if columns is None or (parts != ["mass"] and parts[0] not in columns
                               and absorber.type not in ROWS_REBUILT):
            return False
        if parts == ["mass"]:
            self._slot(key, "mass", body)
        elif parts[0] in columns:
            self._slot(key, "rows", (a, columns[parts[0]]))
        item = self._item(f"absorbers.{a}", absorber, parts)
        if parts != ["mass"] and parts[0] not in columns:
            displacements = [c for _, c in _state_terms(scenario, "displacement", body)]
            item.rebuild(partial(_absorber, a, body, displacements), "rows", "x0")
        return True

    def _bind_load(self, scenario: Scenario, key: str, index: int, parts: list[str]) -> bool:
        load = scenario.loads[index]
        scaled = isinstance(load, BlastLoad) and load.scales is not None  # (rows of s * amplitude)
        if parts[0] in FORCE_COLUMNS.get(load.type, ()) and len(parts) == 1 and not scaled:
            column = 1 + FORCE_COLUMNS[load.type].index(parts[0])
            self._slot(key, "forces", (_force_row(scenario, index), column))
            if isinstance(load, (HarmonicLoad, BaseHarmonicLoad)) and parts[0] == "frequency":
                sim = scenario.simulation
                self.poincare = partial(poincare_samples, scenario.scheme, metrics_from=sim.metrics_from,
                                        n_steps=self.base.n_steps, dt=sim.dt,
                                        periods=scenario.output.poincare_periods)
        elif isinstance(load, ImpulseLoad) and parts == ["velocity"]:
            floor = _floor(scenario, load)
            self._term(key, index, "v0", floor, _state_terms(scenario, "velocity", floor))
        elif isinstance(load, WhiteNoiseLoad) and parts == ["intensity"]:
            self.signs[key] = load.intensity > 0
            floor = _floor(scenario, load)
            self._term(key, index, "sigma", floor, _noise_terms(scenario, floor), squared=True)
        elif isinstance(load, (RecordLoad, ForceRecordLoad)) and parts[0] in RECORD_SCALES:
            item = self._item(f"loads.{index}", load, parts)
            item.rebuild(partial(_record, _series_index(scenario, index), self.base.series_ptr), "series_v")
            return True
        else:
            return False
        self._item(f"loads.{index}", load, parts)
        return True

    def _term(self, key: str, index: int, name: str, slot: int, terms: list[tuple[int | None, float]],
              squared: bool = False) -> None:
        """Bind ``key`` to the term of load ``index`` in the sum at ``name[slot]`` (``terms``:
        each load's index, None for an initial load, and its value at the sweep point)."""
        total = self.sums.setdefault((name, slot), _Sum([value for _, value in terms], squared))
        total.terms[[i for i, _ in terms].index(index)] = key


def _rayleigh(primary: Primary, fields: dict[str, Any]) -> None:
    """Rayleigh's storey and mass-proportional dashpots of ``primary``."""
    fields["storey_c"][:], fields["floor_c"][:] = primary.damping_matrices()


def _absorber(a: int, body: int, displacements: list[float], absorber: Any, fields: dict[str, Any]) -> None:
    """Absorber ``a``'s row and, for a Hertz absorber, its start plus the initial loads'
    ``displacements`` of its body."""
    fields["rows"][a] = absorber_row(absorber)
    start = absorber.start
    for d in displacements:
        start += d
    fields["x0"][body] = start


def _record(series: int, pointers: Any, load: RecordLoad | ForceRecordLoad, fields: dict[str, Any]) -> None:
    """The scaled samples of record ``series`` (``pointers``: the scene's ``series_ptr``)."""
    fields["series_v"][pointers[series]:pointers[series + 1]] = load.samples()[1]


def _force_row(scenario: Scenario, index: int) -> int:
    """The first row of ``scene.forces`` of closed-form load ``index``: ``build_scene`` writes the
    loads' ``closed_form_rows`` in file order."""
    nf = scenario.primary.n_floors
    return sum(len(closed_form_rows(load, _floor(scenario, load), nf)) for load in scenario.loads[:index])


def _series_index(scenario: Scenario, index: int) -> int:
    """The series of record load ``index`` (records in file order)."""
    return sum(isinstance(load, (RecordLoad, ForceRecordLoad)) for load in scenario.loads[:index])


def _state_terms(scenario: Scenario, which: str, body: int) -> list[tuple[int | None, float]]:
    """The terms ``build_scene`` adds in ``v0[body]`` (``which = "velocity"``: impulses and initial
    loads) or in ``x0[body]`` after an absorber's start (``"displacement"``: initial loads)."""
    terms: list[tuple[int | None, float]] = []
    for i, load in enumerate(scenario.loads):
        if isinstance(load, InitialLoad):
            given = getattr(load, which)
            terms.append((None, float(given[body]) if given else 0.0))
        elif which == "velocity" and isinstance(load, ImpulseLoad) and _floor(scenario, load) == body:
            terms.append((i, load.velocity))
    return terms


def _noise_terms(scenario: Scenario, floor: int) -> list[tuple[int | None, float]]:
    """The white-noise intensities on ``floor`` whose squares ``build_scene`` sums."""
    return [(i, load.intensity) for i, load in enumerate(scenario.loads)
            if isinstance(load, WhiteNoiseLoad) and _floor(scenario, load) == floor]


def _floor(scenario: Scenario, load: Any) -> int:
    """The floor (body index) a load acts on: its ``floor``, else the roof."""
    floor = getattr(load, "floor", None)  # (base loads and wind have none)
    return scenario.primary.n_floors - 1 if floor is None else floor - 1


def binding(study: Study, point: int) -> Binding:
    """The binding of sweep point ``point`` of ``study``, made once (kept in ``study.bindings``)."""
    made = study.bindings.get(point)
    if made is None:
        made = study.bindings[point] = Binding(study, point)
    return made
