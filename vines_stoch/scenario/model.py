"""The root model of a scenario file (SCENARIOS.md) and its cross-section checks."""

from __future__ import annotations

import re
from typing import Annotated, Any

import numpy as np
from pydantic import Field, model_validator

from .. import schemes
from ..signals import declare_metrics, floor_name, sensitivity_metrics, signal_names
from .bodies import (
    ABSORBERS,
    Absorber,
    HertzAbsorber,
    ImpactAbsorber,
    Primary,
    eigenfrequencies,
    shear_stiffness,
)
from .distributions import Distribution
from .errors import FieldError
from .fields import MAX_ABSORBERS, MAX_LIMITS, MAX_LOADS, MAX_STEPS, _Model
from .loads import (
    BaseHarmonicLoad,
    BlastLoad,
    HarmonicLoad,
    InitialLoad,
    Load,
    WhiteNoiseLoad,
    WindLoad,
    draws_filter_noise,
)
from .settings import (
    Ensemble,
    IntensityMeasures,
    Limit,
    Optimize,
    Output,
    Rare,
    Sensitivity,
    Simulation,
    limit_metrics,
)

#: A limit's name (it becomes part of column names).
LIMIT_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,39}")


def floor_rule(n_floors: int) -> str:
    """What a floor number may be on a primary of ``n_floors`` floors."""
    return f"must be in [1, {n_floors}] (the primary has {n_floors} floor{'s' * (n_floors > 1)})"


def floor_mistakes(data: dict[str, Any]) -> list[tuple[str, Any, str]]:
    """The absorbers' and loads' whole-number floors outside the primary's, read from a file's
    raw tables (key, value, rule): named beside the file's other mistakes, which stop the
    model's own check (``Scenario``) from running."""
    primary = data.get("primary")
    masses = primary.get("masses") if isinstance(primary, dict) else None
    n = len(masses) if isinstance(masses, list) and masses else 1
    found = []
    for table in ("absorbers", "loads"):
        rows = data.get(table)
        for i, row in enumerate(rows if isinstance(rows, list) else []):
            floor = row.get("floor") if isinstance(row, dict) else None
            if isinstance(floor, int) and not isinstance(floor, bool) and not 1 <= floor <= n:
                found.append((f"{table}.{i}.floor", floor, floor_rule(n)))
    return found


class Scenario(_Model):
    """A complete scenario file (SCENARIOS.md)."""

    name: Annotated[str, Field(min_length=1)]
    description: str = ""
    primary: Primary
    absorbers: Annotated[list[Absorber], Field(max_length=MAX_ABSORBERS)] = []
    loads: Annotated[list[Load], Field(max_length=MAX_LOADS)] = []
    simulation: Simulation
    ensemble: Ensemble = Ensemble()
    sweep: dict[str, Any] = {}
    uncertain: dict[str, Distribution] = {}
    optimize: Optimize | None = None
    limits: Annotated[dict[str, Limit], Field(max_length=MAX_LIMITS)] = {}
    intensity_measures: IntensityMeasures | None = None
    rare: Rare | None = None
    sensitivity: Sensitivity | None = None
    output: Output = Output()

    @model_validator(mode="after")
    def _consistency(self) -> Scenario:
        if any(ord(c) < 32 or ord(c) == 127 for c in self.name):
            raise FieldError("name", self.name, "must hold no control characters (NUL, tab, newline, ...): "
                             "it names the default output folder and the report's")
        sim = self.simulation
        if sim.dt > sim.duration:
            raise FieldError("simulation.dt", sim.dt, f"must be <= simulation.duration ({sim.duration:g})")
        if sim.duration / sim.dt > MAX_STEPS:
            raise FieldError("simulation.dt", sim.dt,
                             f"gives {sim.duration / sim.dt:.3g} steps a path (duration / dt); "
                             f"at most {MAX_STEPS:.0e}")
        if sim.metrics_from >= sim.duration:
            raise FieldError(
                "simulation.metrics_from", sim.metrics_from, f"must be in [0, {sim.duration:g})"
            )
        n = self.primary.n_floors
        nbodies = n + len(self.absorbers)
        for i, item in [(f"absorbers.{i}", a) for i, a in enumerate(self.absorbers)] + \
                       [(f"loads.{i}", load) for i, load in enumerate(self.loads)]:
            floor = getattr(item, "floor", None)
            if floor is not None and not 1 <= floor <= n:
                raise FieldError(f"{i}.floor", floor, floor_rule(n))
        self._check_partners()
        for i, load in enumerate(self.loads):
            if isinstance(load, WindLoad) and (bad := load.floors_error(n)) is not None:
                raise FieldError(f"loads.{i}.{bad[0]}", bad[1], bad[2])
            if isinstance(load, BlastLoad) and load.scales is not None and len(load.scales) != n:
                raise FieldError(f"loads.{i}.scales", load.scales,
                                 f"must list {n} values (one per floor, from the lowest)")
            if isinstance(load, InitialLoad):
                for field in ("displacement", "velocity"):
                    values = getattr(load, field)
                    if values is not None and len(values) != nbodies:
                        raise FieldError(
                            f"loads.{i}.{field}", values,
                            f"must list {nbodies} values (the {n} floor{'s' * (n > 1)} from the lowest, "
                            "then each absorber)",
                        )
        if sim.history is not None:
            self._check_signals("simulation.history.signals", sim.history.signals)
        for metric in self.output.metrics:
            try:
                declare_metrics([metric], n, len(self.absorbers))
            except ValueError as exc:
                raise FieldError("output.metrics", self.output.metrics,
                                 f"{str(exc).removeprefix('metrics: ')}: give <signal>_<reduction>, the "
                                 f"signal x1, e1, x_k, v_k or drift_k with k in [1, {n}], or xa_j, va_j, "
                                 f"stroke_j or contact_j with j in [1, {len(self.absorbers)}], the reduction "
                                 "peak, max, min, mean or rms") from None
        metrics = limit_metrics(n, self.primary.heights is not None)
        for name, limit in self.limits.items():
            if not LIMIT_NAME.fullmatch(name):
                raise FieldError("limits", name, "a limit's name must start with a letter and hold letters, "
                                 "digits and '_' only (at most 40 characters): it names the columns "
                                 "first_passage_NAME, p_NAME")
            if floor_name(limit.metric, n) not in metrics:
                raise FieldError(f"limits.{name}.metric", limit.metric,
                                 "must be a peak metric: x1_max, e1_max, or x_max_k, drift_max_k, acc_max_k "
                                 f"with k in [1, {n}] or roof (drift_ratio_max_k with primary.heights)")
            limit.metric = floor_name(limit.metric, n)
        self._check_rare(n)
        paths = self.output.paths
        if paths is not None:
            self._check_signals("output.paths.signals", paths.signals)
            count = self.ensemble.realizations if self.is_random else 1
            if max(paths.realizations) >= count:
                raise FieldError("output.paths.realizations", paths.realizations,
                                 f"each must be in [0, {count - 1}]: the realisations of a sweep point "
                                 + ("(ensemble.realizations)" if self.is_random else
                                    "(a scene without noise or uncertain parameters runs one)"))
        spectra = self.output.spectra
        if spectra is not None:
            self._check_signals("output.spectra.signals", spectra.signals)
            window = sim.duration - sim.metrics_from
            if spectra.segment is not None and not 8 * sim.dt <= spectra.segment <= window:
                raise FieldError("output.spectra.segment", spectra.segment,
                                 f"must be in [{8 * sim.dt:g}, {window:g}] s (8 steps to the metrics "
                                 "window, simulation.duration - simulation.metrics_from)")
        for key in ("poincare", "lyapunov"):
            if getattr(self.output, key) and self.forcing_frequency is None:
                raise FieldError(f"output.{key}", True,
                                 "needs a periodically forced scene: one harmonic or base-harmonic load of "
                                 "frequency > 0, and no noise (the rk4 scheme, which samples the state once "
                                 "a forcing period)")
        contents = self.contents
        if sim.scheme != "auto":
            why = schemes.refusal(schemes.SCHEMES[sim.scheme], *contents)
            if why is not None:
                raise FieldError("simulation.scheme", sim.scheme, why)
        return self

    def _check_rare(self, n: int) -> None:
        """``[rare]``: a limit of ``[limits]``, a scene with noise; ``[sensitivity]``: uncertain
        parameters and a metric or limit to read."""
        rare = self.rare
        if rare is not None:
            if rare.limit not in self.limits:
                raise FieldError("rare.limit", rare.limit, "must be a key of [limits] ("
                                 + (", ".join(self.limits) or "the scenario has none") + ")")
            if not self.has_noise:
                raise FieldError("rare", rare.limit, "needs a scene with noise (a white-noise, filtered or "
                                 "ground-motion load): splitting branches paths onto fresh noise")
            if rare.method == "subset" and rare.n % 10:
                raise FieldError("rare.particles", rare.particles,
                                 "must be a multiple of 10 with subset simulation (10 states a chain)")
        sens = self.sensitivity
        if sens is not None:
            if not self.uncertain:
                raise FieldError("sensitivity", sens.metric, "needs [uncertain] parameters to apportion")
            allowed = sensitivity_metrics(n, self.limits, self.output.metrics)
            if sens.metric not in allowed:
                raise FieldError("sensitivity.metric", sens.metric,
                                 "must be a metric column (edm, x1_max, e1_max, ...) or p_NAME for a limit "
                                 f"NAME ({', '.join(sorted(allowed)[:12])}, ...)")

    def _check_partners(self) -> None:
        """A ``FieldError`` where an impact absorber's ``impacts_with`` names no other absorber, or
        one that is itself an impact absorber (whose walls a stuck absorber would have to follow
        while stuck itself)."""
        na = len(self.absorbers)
        for i, a in enumerate(self.absorbers):
            j = getattr(a, "impacts_with", None)
            if j is None:
                continue
            key = f"absorbers.{i}.impacts_with"
            if j > na or j == i + 1:
                raise FieldError(key, j, f"must name another absorber: j in [1, {na}] (file order), not "
                                 f"{i + 1}, this one")
            if isinstance(self.absorbers[j - 1], ImpactAbsorber):
                others = ", ".join(t for t in ABSORBERS if t != "impact")
                raise FieldError(key, j, f"absorber {j} is an impact absorber: the cavity must be in an "
                                 f"absorber of another type ({others})")

    def _check_signals(self, key: str, signals: list[str]) -> None:
        """A ``FieldError`` for ``key`` where a name of ``signals`` is not a signal of the scene."""
        n, na = self.primary.n_floors, len(self.absorbers)
        allowed = signal_names(n, na)
        for signal in signals:
            if signal not in allowed:
                raise FieldError(key, signals, f"{signal!r} is not a signal: give x1, e1, x_k, v_k or "
                                 f"drift_k with k in [1, {n}], or xa_j, va_j, stroke_j or contact_j with j "
                                 f"in [1, {na}] (absorbers in file order)")

    @property
    def forcing_frequency(self) -> float | None:
        """The frequency (rad/s) of the scene's one periodic load where the step loop samples
        the state once a forcing period (Poincare samples: rk4, one harmonic or base-harmonic
        load of frequency > 0; ``scene.poincare_samples``), else None."""
        periodic = [load for load in self.loads if isinstance(load, (HarmonicLoad, BaseHarmonicLoad))]
        if self.scheme != "rk4" or len(periodic) != 1 or periodic[0].frequency <= 0:
            return None
        return periodic[0].frequency

    @property
    def contents(self) -> tuple[bool, bool, bool, bool]:
        """What the schemes must accept: noise, filtered loads, impact absorbers, Hertz absorbers."""
        return (self.has_noise, any(draws_filter_noise(load) for load in self.loads),
                any(isinstance(a, ImpactAbsorber) for a in self.absorbers),
                any(isinstance(a, HertzAbsorber) for a in self.absorbers))

    @property
    def is_random(self) -> bool:
        """True when realisations differ: random loads or uncertain parameters."""
        return self.has_noise or bool(self.uncertain)

    @property
    def scheme(self) -> str:
        """The scheme that runs (``schemes.choose`` for ``"auto"``)."""
        if self.simulation.scheme != "auto":
            return self.simulation.scheme
        return schemes.choose(*self.contents)

    def natural_frequencies(self) -> np.ndarray:
        """Natural frequencies (rad/s, ascending) of the linear structure: the floors and every
        absorber on its attachment linearised about its stable rest position (``spring``: cubic
        terms, impacts and contacts left out; an absorber without a linear spring is a free mass,
        frequency 0)."""
        n = self.primary.n_floors
        mass = np.array(self.primary.floor_masses + [a.mass for a in self.absorbers])
        k = np.zeros((mass.shape[0], mass.shape[0]))
        k[:n, :n] = shear_stiffness(self.primary.storey_stiffnesses)
        for j, a in enumerate(self.absorbers, start=n):
            spring = a.spring
            h = (a.floor or n) - 1
            k[[h, j], [h, j]] += spring
            k[[h, j], [j, h]] -= spring
        return eigenfrequencies(mass, k)

    def highest_frequency(self) -> float:
        """The highest of ``natural_frequencies`` (the stability limit of ``dt``)."""
        return float(self.natural_frequencies().max())

    @property
    def has_noise(self) -> bool:
        """True when any random load acts (white, filtered noise, stochastic ground motion, wind)."""
        return any((isinstance(load, WhiteNoiseLoad) and load.intensity > 0) or draws_filter_noise(load)
                   for load in self.loads)
