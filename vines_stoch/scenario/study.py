"""A scenario file read, validated and expanded: its sweep points, uncertain and optimised
parameters checked at both ends of their ranges, and its record files read once."""

from __future__ import annotations

import copy
import itertools
import math
import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from annotated_types import Ge, Gt, Le, Lt
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from .. import schemes
from ..environment import memory_problem
from ..notices import LongRunWarning, Notice
from ..records import RecordError, read_record
from ..textfile import TextFileError, read_text
from . import accuracy
from .distributions import REACH, LognormalDistribution
from .errors import (
    MISSING,
    FieldError,
    Mistakes,
    ScenarioError,
    _constraints,
    _interval,
    format_error,
    quote,
    validate,
)
from .fields import LARGEST, MAX_DEPTH
from .loads import _RecordLoad
from .model import Scenario, floor_mistakes
from .settings import REGIME_SAMPLES
from .sweeps import _grid, _product, _zipped, get_path, set_path

#: Path-steps beyond which a run's cost is said before it starts (``LongRunWarning``).
LONG_RUN = 1e11
#: The largest scenario file read (bytes).
SCENARIO_BYTES = 4 * 2**20


def _validate(data: dict[str, Any], source: str) -> Scenario:
    """``data`` as a Scenario, or ScenarioError with one line per mistake."""
    return validate(Scenario, data, source)


def _require_numeric(data: dict[str, Any], key: str, where: str, spec: Any, source: str,
                     text: bool = False, refused: tuple[str, ...] = ()) -> None:
    """``key`` must address an existing numeric field of the file (``text``: a text field),
    unless it lies at or inside one of the ``refused`` keys (whose mistake is reported)."""
    if any(key == k or key.startswith(k + ".") for k in refused):
        return
    try:
        current = get_path(data, key)
    except (KeyError, IndexError, ValueError, TypeError):
        current = None
    if text and not isinstance(current, str):
        raise ScenarioError(format_error(source, where, spec,
                                         "texts sweep an existing text field of the file "
                                         "(e.g. loads.0.file for a suite of records)"))
    if not text and (isinstance(current, bool) or not isinstance(current, (int, float))):
        raise ScenarioError(format_error(source, where, spec,
                                         "must name an existing numeric field of the file "
                                         "(e.g. loads.0.velocity)"))


def _check_values(data: dict[str, Any], key: str, ends: tuple[float, float], where: str, spec: Any,
                  source: str, message: str) -> None:
    """Validate the file with ``key`` set to each of ``ends``; on failure raise ``message``
    (formatted with ``end`` and the field's ``rule``) at ``where`` (whose value is ``spec``)."""
    for end in ends:
        try:
            _validate(_variant(data, {key: end}), source)
        except ScenarioError as exc:
            rule = str(exc).split("\n")[0].rsplit(": ", 1)[-1]
            raise ScenarioError(format_error(source, where, spec,
                                             message.format(end=end, rule=rule))) from None


def _invalid(data: dict[str, Any], values: dict[str, float], source: str) -> ScenarioError | None:
    """Why the file with the fields named by ``values`` set is not a valid scenario (its first
    mistake; None: it is valid)."""
    try:
        _validate(_variant(data, values), source)
    except ScenarioError as exc:
        return exc
    return None


def _variant(data: dict[str, Any], values: dict[str, Any]) -> dict[str, Any]:
    """A copy of the file's tables with the fields named by ``values`` set: one design, without
    the uncertain, optimize and sensitivity tables (the values a study varies, and the study over
    them)."""
    variant = copy.deepcopy(data)
    for key, value in values.items():
        set_path(variant, key, value)
    for table in ("uncertain", "optimize", "sensitivity"):
        variant.pop(table, None)
    return variant


def _mistake(exc: ScenarioError, source: str) -> str:
    """The first mistake of ``exc`` without the file's name: ``key = value: rule``."""
    line = str(exc).split("\n")[0]
    return line[len(source) + 2:] if line.startswith(source + ": ") else line


#: Corners of the other optimised parameters' ranges a bound is tried with, at most (ten others).
MAX_CORNERS = 2**10


def _at_sweep(exc: ScenarioError, source: str, where: str, values: dict[str, Any],
              sweep: dict[str, Any]) -> list[tuple[str, str]]:
    """The lines of a sweep point's mistake, each with the swept key it names ("" where none):
    a swept value out of its field's range is said at ``sweep.KEY``, where the file gives it."""
    lines = []
    for line in str(exc).split("\n"):
        key = next((k for k in values if line.startswith(f"{where}: {k} = ")), "")
        if key:
            rule = line[len(f"{where}: {key} = {quote(values[key])}: "):]
            line = format_error(source, f"sweep.{key}", sweep[key],
                                f"its value {quote(values[key])}: {rule}")
        lines.append((key, line))
    return lines


def _stability(scenario: Scenario) -> str | None:
    """Why ``dt`` is past the linear stability limit of the scheme that would run (None: it is not)."""
    omega, dt = scenario.highest_frequency(), scenario.simulation.dt
    limit = schemes.SCHEMES[scenario.scheme].stability
    if omega * dt < limit:
        return None
    return (f"is past the stability limit of the {scenario.scheme} scheme: the highest linear natural "
            f"frequency of the scene is {omega:.6g} rad/s, which needs dt < {limit:.4g} / omega = "
            f"{limit / omega:.4g} (use about a tenth of that for accuracy)")


#: The time step: where it is uncertain or optimised, every value it may take must be stable
#: (a physical parameter drawn past the limit makes a diverged realisation instead).
STEP = "simulation.dt"


def _check_stability(scenario: Scenario, source: str) -> None:
    """Refuse a ``dt`` past the linear stability limit of the scheme that would run."""
    why = _stability(scenario)
    if why is not None:
        raise ScenarioError(format_error(source, "simulation.dt", scenario.simulation.dt, why))


@dataclass(frozen=True)
class FieldRange:
    """The values a numeric field of a scenario allows by its type (``Mass``, ``NonNegative``, the
    items of ``primary.masses``...): its bounds (None: none) and whether it must be finite."""

    constraints: tuple[Any, ...]
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    finite: bool = False

    @classmethod
    def of(cls, info: FieldInfo) -> FieldRange:
        """The range of a field (of its items, for a list of numbers)."""
        constraints = tuple(_constraints(info))
        bounds: dict[str, Any] = {}
        for m in constraints:
            if isinstance(m, (Ge, Gt)):
                bounds.update(low=m.ge if isinstance(m, Ge) else m.gt, low_open=isinstance(m, Gt))
            elif isinstance(m, (Le, Lt)):
                bounds.update(high=m.le if isinstance(m, Le) else m.lt, high_open=isinstance(m, Lt))
            elif getattr(m, "allow_inf_nan", True) is False:
                bounds.update(finite=True)
        return cls(constraints, **bounds)

    def refusal(self, value: float) -> str | None:
        """Why the field cannot hold ``value``, worded as validation words it (None: it can)."""
        if self.finite and not math.isfinite(value):
            return "must be a finite number"
        low_ok = self.low is None or (value > self.low if self.low_open else value >= self.low)
        high_ok = self.high is None or (value < self.high if self.high_open else value <= self.high)
        if low_ok and high_ok:
            return None
        return _interval(list(self.constraints), value) or "is out of the field's range"


def _step(node: Any, part: str) -> Any:
    """The node one part of a dotted key below ``node`` (a model, list or table), or MISSING."""
    if isinstance(node, BaseModel):
        return getattr(node, part) if part in type(node).model_fields else MISSING
    if isinstance(node, list):
        return node[int(part)] if part.isdigit() and int(part) < len(node) else MISSING
    if isinstance(node, dict):
        return node.get(part, MISSING)
    return MISSING


def _walk(root: BaseModel, key: str) -> tuple[list[str], FieldInfo | None]:
    """The keys (relative to ``root``, ``""`` for ``root``) of the models dotted ``key`` passes
    through, and the field the key names (None: no field of a model)."""
    node: Any = root
    models: list[str] = []
    info = None
    parts = key.split(".")
    for i, part in enumerate(parts):
        if isinstance(node, BaseModel):
            models.append(".".join(parts[:i]))
            info = type(node).model_fields.get(part)
        node = _step(node, part)
        if node is MISSING:
            return models, None
    return models, info


def _model_at(root: BaseModel, where: str) -> BaseModel:
    """The model at dotted ``where`` below ``root`` (``""``: ``root``)."""
    node: Any = root
    for part in where.split(".") if where else ():
        node = _step(node, part)
    return node


def field_range(root: BaseModel, key: str) -> FieldRange | None:
    """The range of the numeric field dotted ``key`` names below ``root`` (None: no field)."""
    info = _walk(root, key)[1]
    return None if info is None else FieldRange.of(info)


def checked_models(root: BaseModel, key: str) -> list[str]:
    """Keys (relative to ``root``, ``""`` for ``root``) of the models dotted ``key`` passes
    through whose fields are checked against each other (model validators: ``cross_check``)."""
    return [where for where in _walk(root, key)[0]
            if type(_model_at(root, where)).__pydantic_decorators__.model_validators]


def cross_check(root: BaseModel, wheres: list[str], prefix: str, source: str) -> None:
    """Run the checks of fields against each other (the model validators) of the models at
    ``wheres`` below ``root`` (``checked_models``; ``prefix``: the dotted key of ``root`` in the
    file) as validation runs them; a ScenarioError worded as validation words it."""
    for where in wheres:
        model = _model_at(root, where)
        for decorator in type(model).__pydantic_decorators__.model_validators.values():
            if decorator.info.mode != "after":
                continue
            try:
                decorator.func(model)
            except FieldError as exc:
                key = ".".join(k for k in (prefix, where, exc.key) if k)
                raise ScenarioError(format_error(source, key, MISSING if exc.value is None else exc.value,
                                                 exc.rule), (key,)) from None


class Study:
    """A validated scenario file: the base scenario and its sweep points; ``warnings``: one line
    for each thing the run would do that the file may not expect (a coarse ``dt``, realisations
    that would all be the same), which ``run`` and ``validate`` print before anything runs."""

    def __init__(self, source: str, text: str, data: dict[str, Any], directory: Path = Path("."),
                 records: dict[tuple[Any, ...], tuple[np.ndarray, np.ndarray]] | None = None):
        self.source = source
        self.text = text
        self.data = data
        self.directory = directory
        self._records = {} if records is None else records  # record files read so far, shared by variants
        self.bindings: dict[int, Any] = {}  # vines_stoch.binding.Binding of each sweep point, once made
        mistakes = Mistakes()  # every mistake of the file, reported at once
        base, invalid = None, ()
        try:
            base = self.base = self._read_records(_validate(data, source), source)
        except ScenarioError as exc:
            mistakes.lines += str(exc).split("\n")
            mistakes.lines += [format_error(source, *m) for m in floor_mistakes(data) if m[0] not in exc.keys]
            invalid = exc.keys
        refused = tuple(k for k in invalid if k)  # (keys at or inside these are not named again)
        sweep = dict(data["sweep"]) if isinstance(data.get("sweep"), dict) else {}
        zipped: list[str] = []
        with mistakes.kept():
            zipped = _zipped(sweep.pop("zip", []), sweep, source)
        self.sweep_keys = list(sweep)
        grids: dict[str, list] = {}
        for key in self.sweep_keys:
            with mistakes.kept():
                grid = _grid(key, sweep[key], source)
                text = isinstance(grid[0], str)
                _require_numeric(data, key, f"sweep.{key}", sweep[key], source, text, refused)
                if base is not None and not text and self._integer(key):
                    grid = _whole(grid, f"sweep.{key}", sweep[key], source)
                grids[key] = grid
        uncertain = data["uncertain"] if isinstance(data.get("uncertain"), dict) else {}
        self.uncertain_keys = list(uncertain)
        for key in self.uncertain_keys:
            with mistakes.kept():
                self._check_uncertain(data, key, base, refused, source)
        optimize = data.get("optimize")
        parameters = optimize.get("parameters") if isinstance(optimize, dict) else None
        for key in parameters if isinstance(parameters, dict) else ():
            with mistakes.kept():
                self._check_parameter(data, key, parameters[key], base, refused, source)
        mistakes.raise_any()
        self.grid = _product(grids, zipped, source)
        self.points: list[Scenario] = []
        self._point_data: list[dict[str, Any]] = []
        named: set[str] = set()  # (swept keys whose mistake is said)
        first: int | None = None  # (the first point with a mistake at a key not swept: its lines are said)
        for point, values in enumerate(self.grid):
            variant = copy.deepcopy(data)
            for key, value in values.items():
                set_path(variant, key, value)
            self._point_data.append(variant)
            where = f"{source} (sweep point {values})" if values else source
            try:
                self.points.append(self._read_records(_validate(variant, where), source))
                _check_stability(self.points[-1], where)
            except ScenarioError as exc:
                for key, line in _at_sweep(exc, source, where, values, sweep):
                    if key and key not in named:
                        named.add(key)
                        mistakes.lines.append(line)
                    elif not key and first in (None, point):
                        first = point
                        mistakes.lines.append(line)
        if not mistakes and STEP in self.uncertain_keys:
            dist = self.base.uncertain[STEP]
            with mistakes.kept():
                self._check_steps(dist.reach(), f"uncertain.{STEP}", uncertain[STEP],
                                  dist.distribution + " draws reach {end:g}{point}, where {rule}")
        tuned = self.base.optimize if not mistakes else None
        if tuned is not None and STEP in tuned.parameters:
            bound = tuned.parameters[STEP]
            with mistakes.kept():
                self._check_steps((bound.low, bound.high), f"optimize.parameters.{STEP}", parameters[STEP],
                                  "the bound {end:g}{point} is not allowed: {rule}")
        if not mistakes and tuned is not None:
            with mistakes.kept():
                self._check_start(tuned, source)
        mistakes.raise_any()
        self._check_work(source)
        self.warnings = accuracy.warnings(source, self.points, self.grid, self.base.ensemble.realizations)
        if self.base.is_random and self.cost > LONG_RUN:
            self.warnings.append(Notice(format_error(
                source, "ensemble.realizations", self.base.ensemble.realizations,
                f"the run takes {self.cost:.3g} path-steps (sweep points x realisations x duration / dt): "
                f"hours of CPU at the 1e8 path-steps a second of a light scene on one core (make bench "
                "measures this machine's)"), LongRunWarning))

    def _integer(self, key: str) -> bool:
        """True when the (numeric) field at dotted ``key`` holds integers."""
        node: Any = self.base
        for part in key.split("."):
            node = node[int(part)] if isinstance(node, list) else (node[part] if isinstance(node, dict)
                                                                  else getattr(node, part))
        return isinstance(node, int)

    def _check_work(self, source: str) -> None:
        """Refuse a run past ``ensemble.max_path_steps`` (sweep points x realisations x steps) and
        a sensitivity study whose bootstrap cannot fit the machine's memory; say the cost of a
        long one (``LONG_RUN``: a ``LongRunWarning`` among the study's warnings)."""
        ens = self.base.ensemble
        spec = self.base.sensitivity
        if spec is not None:  # (SALib's bootstrap keeps about six arrays of samples x bootstrap floats)
            why = memory_problem("the sensitivity bootstrap (samples x bootstrap)",
                                 48.0 * spec.samples * spec.bootstrap)
            if why:
                raise ScenarioError(format_error(source, "sensitivity.bootstrap", spec.bootstrap,
                                                 f"{why}: lower sensitivity.samples or bootstrap"))
        self._check_sections(source)
        steps = sum(p.simulation.duration / p.simulation.dt for p in self.points) * ens.realizations
        self.cost = steps
        if steps > ens.max_path_steps:
            raise ScenarioError(format_error(
                source, "ensemble.realizations", ens.realizations,
                f"the run would take {steps:.3g} path-steps ({len(self.points)} sweep point(s) x "
                f"{ens.realizations} realisation(s) x duration / dt), past ensemble.max_path_steps = "
                f"{ens.max_path_steps:.3g}: raise that if the run is meant"))

    def _check_sections(self, source: str) -> None:
        """Refuse ``[output] poincare`` where the samples it keeps (every realisation's state once a
        forcing period over the window, ``scene.poincare_samples``) cannot fit the machine's memory."""
        out = self.base.output
        if not out.poincare:
            return
        count = self.base.ensemble.realizations if self.base.is_random else 1
        need = 0.0
        for point in self.points:
            omega = point.forcing_frequency
            if omega is None:
                continue
            sim, columns = point.simulation, 2 * (point.primary.n_floors + len(point.absorbers)) + 2
            periods = (sim.duration - sim.metrics_from) * omega / (2.0 * math.pi) + 1.0
            if out.poincare_periods:
                periods = min(periods, max(out.poincare_periods, REGIME_SAMPLES))
            need += 8.0 * columns * periods * count
        why = memory_problem("the Poincare samples kept (sweep points x realisations x forcing periods)",
                             need)
        if why:
            raise ScenarioError(format_error(source, "output.poincare", True,
                                             f"{why}: set [output] poincare_periods to keep fewer"))

    def _check_uncertain(self, data: dict[str, Any], key: str, base: Scenario | None,
                         refused: tuple[str, ...], source: str) -> None:
        """An uncertain parameter: an existing real field, not swept, valid over the support of its
        law (the last two once the file's tables are valid)."""
        where, spec = f"uncertain.{key}", data["uncertain"][key]
        _require_numeric(data, key, where, spec, source, refused=refused)
        if key in self.sweep_keys:
            raise ScenarioError(format_error(source, where, spec,
                                             "is also swept: a parameter is either swept or uncertain"))
        if base is None:
            return
        if self._integer(key):
            raise ScenarioError(format_error(source, where, spec, "names an integer field, and distributions "
                                             "draw real numbers: sweep it instead"))
        dist = base.uncertain[key]
        lo, hi = dist.support()
        lo = dist.reach()[0] if isinstance(dist, LognormalDistribution) else lo  # (its support starts at 0)
        ends = (lo if math.isfinite(lo) else -LARGEST, hi if math.isfinite(hi) else LARGEST)
        _check_values(data, key, ends, where, spec, source,
                      f"{dist.distribution} draws reach {{end:g}}, but the value {{rule}}; choose a "
                      "distribution whose support fits (lognormal for positive values, uniform or "
                      "truncated-normal within bounds)")
        for end in dist.reach():
            if not abs(end) <= LARGEST:
                raise ScenarioError(format_error(source, where, spec,
                                                 f"{dist.distribution} draws reach {end:.3g} "
                                                 f"({REACH:g} standard deviations), "
                                                 f"past the largest magnitude {LARGEST:g}"))

    def _check_parameter(self, data: dict[str, Any], key: str, spec: Any, base: Scenario | None,
                         refused: tuple[str, ...], source: str) -> None:
        """An optimised parameter: an existing real field, neither swept nor uncertain, valid at both
        bounds (the last once the file's tables are valid)."""
        where = f"optimize.parameters.{key}"
        _require_numeric(data, key, where, spec, source, refused=refused)
        if key in self.sweep_keys or key in self.uncertain_keys:
            raise ScenarioError(format_error(source, where, spec, "is swept or uncertain: "
                                             "an optimised parameter must be neither"))
        if base is None:
            return
        if self._integer(key):
            raise ScenarioError(format_error(source, where, spec, "names an integer field, and the optimiser "
                                             "moves parameters continuously: sweep it instead"))
        parameters = base.optimize.parameters
        others = {k: b for k, b in parameters.items() if k != key and self._settable(data, k)}
        for end in (parameters[key].low, parameters[key].high):
            why = self._bound_refusal(data, key, end, others, source)
            if why is not None:
                raise ScenarioError(format_error(source, where, spec,
                                                 f"the bound {end:g} is not allowed: {why}"))

    def _settable(self, data: dict[str, Any], key: str) -> bool:
        """True when dotted ``key`` names an existing numeric field that is neither swept nor uncertain."""
        if key in self.sweep_keys or key in self.uncertain_keys:
            return False
        try:
            value = get_path(data, key)
        except (KeyError, IndexError, ValueError, TypeError):
            return False
        return isinstance(value, (int, float)) and not isinstance(value, bool)

    @staticmethod
    def _bound_refusal(data: dict[str, Any], key: str, end: float, others: dict[str, Any],
                       source: str) -> str | None:
        """Why no candidate design with ``key`` at ``end`` is valid (None: one is).  The design is
        tried with the ``others`` (optimised parameters: their Bounds) at their starts, then at the
        corners of their ranges: a rule that checks fields against each other (the offset < gap
        of a 'from-primary' obstacle) may refuse the bound at some of them, and the search then
        skips those candidates as infeasible; a bound no candidate can take is a mistake."""
        starts = {k: b.initial for k, b in others.items()}
        corners = itertools.product(*((b.low, b.high) for b in others.values()))
        first = _invalid(data, {**starts, key: end}, source)
        if first is None:
            return None
        for corner in itertools.islice(corners, MAX_CORNERS):
            if _invalid(data, {**dict(zip(others, corner)), key: end}, source) is None:
                return None
        line = _mistake(first, source)
        why = f"the value {line.rsplit(': ', 1)[-1]}" if line.partition(" = ")[0] == key else line
        tried = (" (with the other optimised parameters at their starts; no corner of their ranges "
                 "allows it either)") if others else ""
        return why + tried

    def _check_start(self, tuned: Any, source: str) -> None:
        """The start design (every optimised parameter of ``tuned``, the Optimize table, at its
        start) must be a valid scenario at every sweep point: the search starts there, and
        candidates that are not valid are infeasible."""
        starts = {k: b.initial for k, b in tuned.parameters.items()}
        for values, data in zip(self.grid, self._point_data):
            try:
                design = _validate(_variant(data, starts), source)
                _check_stability(self._read_records(design, source), source)
            except ScenarioError as exc:
                at = f" at sweep point {values}" if values else ""
                shown = ", ".join(f"{k} = {v:g}" for k, v in starts.items())
                raise ScenarioError(format_error(
                    source, "optimize.parameters", MISSING,
                    f"the start design ({shown}) is not valid{at}: {_mistake(exc, source)}; set each "
                    "parameter's start (within [low, high]) where the design is valid")) from None

    def _check_steps(self, ends: tuple[float, float], where: str, spec: Any, message: str) -> None:
        """``dt`` at either of ``ends`` must be stable at every sweep point (``message``, formatted
        with ``end``, ``point`` and the stability ``rule``, says why not)."""
        for values, point in zip(self.grid, self.points):
            for end in ends:
                simulation = point.simulation.model_copy(update={"dt": end})
                variant = point.model_copy(update={"simulation": simulation})
                why = _stability(variant)
                if why is not None:
                    at = f" (at sweep point {values})" if values else ""
                    rule = f"{STEP} = {end:g} {why}"
                    raise ScenarioError(format_error(self.source, where, spec,
                                                     message.format(end=end, point=at, rule=rule)))

    def realise(self, point: int, values: dict[str, float]) -> Scenario:
        """Sweep point ``point`` with its uncertain parameters set to ``values``, the whole file
        validated again (``vines_stoch.binding`` sets most keys in the point's scene instead)."""
        variant = copy.deepcopy(self._point_data[point])
        for key, value in values.items():
            set_path(variant, key, value)
        return self._read_records(_validate(variant, self.source), self.source)

    def with_values(self, values: dict[str, float]) -> Study:
        """The study with the fields named by ``values`` set (e.g. an optimiser's candidate)."""
        data = copy.deepcopy(self.data)
        for key, value in values.items():
            set_path(data, key, value)
        return Study(self.source, self.text, data, self.directory, self._records)

    def _read_records(self, scenario: Scenario, source: str) -> Scenario:
        """Read the files of record loads (paths relative to the scenario file), once each."""
        for i, load in enumerate(scenario.loads):
            if isinstance(load, _RecordLoad):
                path = self.directory / load.file
                key = (os.path.abspath(path), load.format, load.dt)  # (no resolve: it fails on link loops)
                if key not in self._records:
                    try:
                        self._records[key] = read_record(path, load.format, load.dt)
                    except RecordError as exc:
                        raise ScenarioError(format_error(source, f"loads.{i}.file", load.file, str(exc)),
                                            (f"loads.{i}.file",)) from None
                load._times, load._values = self._records[key]
                span, dt = load._times[-1] - load._times[0], scenario.simulation.dt
                if not span >= dt:
                    raise ScenarioError(format_error(
                        source, f"loads.{i}.file", load.file,
                        f"the record spans {span:.3g} s ({len(load._times)} samples), less than one step "
                        f"of the run (simulation.dt = {dt:g}): check its time step (DT) or time column"),
                        (f"loads.{i}.file",))
        return scenario

    @property
    def name(self) -> str:
        return self.base.name

    def __repr__(self) -> str:
        base = self.base
        absorbers = ", ".join(a.type for a in base.absorbers) or "none"
        loads = ", ".join(load.type for load in base.loads) or "none"
        sweep = f" over {', '.join(self.sweep_keys)}" if self.sweep_keys else ""
        sim = base.simulation
        return (f"Study {base.name!r} ({self.source}): {len(self.points)} sweep point(s){sweep}; "
                f"{base.primary.n_floors} floor(s), absorbers: {absorbers}; loads: {loads}; "
                f"{base.ensemble.realizations if base.is_random else 1} realisation(s) a point, "
                f"{base.scheme}, T = {sim.duration:g}, dt = {sim.dt:g}"
                + (f"; {len(self.warnings)} warning(s): {self.warnings[0]}" if self.warnings else ""))

    def _repr_html_(self) -> str:
        import html

        return f"<p>{html.escape(repr(self))}</p>"


def _whole(values: list[float], where: str, spec: Any, source: str) -> list[int]:
    """Sweep values of an integer field: whole numbers, as integers."""
    if any(v != int(v) for v in values):
        raise ScenarioError(format_error(source, where, spec,
                                         "names an integer field: the values must be whole numbers"))
    return [int(v) for v in values]


def load_scenario(path: str | Path) -> Study:
    """Read and validate a scenario file; raise ScenarioError with a one-line reason per mistake."""
    path = Path(path)
    try:
        text = read_text(path, SCENARIO_BYTES)
    except TextFileError as exc:
        raise ScenarioError(str(exc)) from None
    return parse_scenario(text, str(path), path.parent)


def parse_scenario(text: str, source: str = "<scenario>", directory: str | Path = ".") -> Study:
    """Validate scenario TOML text (``source`` names it in messages; record files are found
    relative to ``directory``)."""
    _check_keys(text, source)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: TOML syntax error: {exc}") from None
    except RecursionError:
        raise ScenarioError(f"{source}: tables, arrays or keys nest too deep to read "
                            f"(a scenario nests at most {MAX_DEPTH} levels)") from None
    _check_depth(data, source)
    return Study(source, text, data, Path(directory))


#: Quoted strings of a TOML line (their dots do not split keys).
_QUOTED = re.compile(r'"(?:[^"\\]|\\.)*"|\'[^\']*\'')


#: What is left of a key once its quoted parts are removed.
_KEY = re.compile(r"[A-Za-z0-9_.\s-]*")


def _check_keys(text: str, source: str) -> None:
    """Refuse dotted keys of more than ``MAX_DEPTH`` parts before parsing (the TOML reader
    takes time quadratic in their length)."""
    for number, line in enumerate(text.splitlines(), start=1):
        head = line.strip()
        if head.startswith("["):
            head = head.strip("[]")
        elif "=" in head:
            head = head.split("=", 1)[0]
        key = _QUOTED.sub("", head)
        if _KEY.fullmatch(key) and key.count(".") >= MAX_DEPTH:
            raise ScenarioError(f"{source}: line {number}: a dotted key of more than {MAX_DEPTH} parts; "
                                "a scenario nests fewer")


def _check_depth(data: dict[str, Any], source: str) -> None:
    """Refuse tables and arrays nested deeper than ``MAX_DEPTH`` (walked without recursion)."""
    stack: list[tuple[Any, tuple[str, ...]]] = [(data, ())]
    while stack:
        node, path = stack.pop()
        if len(path) > MAX_DEPTH:
            key = ".".join(path[:4]) + "..."
            raise ScenarioError(format_error(source, key, MISSING, f"nests more than {MAX_DEPTH} levels of "
                                             "tables and arrays; a scenario needs fewer"))
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        stack.extend((value, path + (str(key),)) for key, value in items)
