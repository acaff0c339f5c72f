"""Scenario files: parsing, validation and sweep expansion (SCENARIOS.md).

A scenario is validated completely before anything is computed.  Every mistake is reported
as one line naming the file, the dotted key, the value and what is allowed, e.g.
``scenarios/x.toml: absorbers.1.restitution = 1.4: must be in [0, 1]``.
"""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
from annotated_types import Ge, Gt, Le, Lt
from pydantic import (BaseModel, ConfigDict, Field, PrivateAttr, ValidationError, field_validator,
                      model_validator)

from . import schemes
from .filters import SOILS
from .physics import hertz_constant
from .records import G, RecordError, read_record


class ScenarioError(ValueError):
    """A scenario file that cannot be run; the message names file, key, value and rule."""


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=False, frozen=False)


Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Real = Annotated[float, Field(allow_inf_nan=False)]


class Rayleigh(_Model):
    """Rayleigh damping ``C = alpha M + beta K`` with damping ``ratio`` at two ``modes`` of the
    primary (1-based): ``alpha = 2 z w_i w_j / (w_i + w_j)``, ``beta = 2 z / (w_i + w_j)``
    (Chopra, Dynamics of Structures, section 11.4)."""

    ratio: Annotated[float, Field(ge=0, lt=1)]
    modes: Annotated[list[Annotated[int, Field(ge=1)]], Field(min_length=2, max_length=2)]


#: A floor number, 1 (lowest) to the roof; its range is checked against the primary's floors.
Floor = int


class Primary(_Model):
    """The linear primary (MODEL.md sections 1, 1a): one storey (``mass``, ``stiffness``,
    ``damping``) or a shear building (``masses``, ``stiffnesses`` and ``dampings`` or
    ``rayleigh``, floors from the lowest to the roof; storey ``k`` joins floor ``k - 1``, the
    ground for ``k = 1``, to floor ``k``)."""

    mass: Positive | None = None
    stiffness: NonNegative | None = None
    damping: NonNegative | None = None
    masses: Annotated[list[Positive], Field(min_length=1)] | None = None
    stiffnesses: list[NonNegative] | None = None
    dampings: list[NonNegative] | None = None
    rayleigh: Rayleigh | None = None

    @model_validator(mode="after")
    def _layout(self) -> "Primary":
        scalars = {"mass": self.mass, "stiffness": self.stiffness, "damping": self.damping}
        lists = {"masses": self.masses, "stiffnesses": self.stiffnesses, "dampings": self.dampings}
        if self.masses is None:
            if self.mass is None:
                raise _KeyError("mass", None, "missing: give mass (one storey) or masses = [...] (floors from the "
                                "lowest to the roof)")
            for name, value in lists.items():
                if value is not None:
                    raise _KeyError(name, value, "needs masses = [...]: a one-storey primary takes mass, stiffness "
                                    "and damping")
            if self.rayleigh is not None:
                raise _KeyError("rayleigh", None, "needs a multi-storey primary (masses = [...]); give damping")
            return self
        for name, value in scalars.items():
            if value is not None:
                raise _KeyError(name, value, f"give either {name} (one storey) or the lists masses, stiffnesses, "
                                "dampings, not both")
        n = len(self.masses)
        for name in ("stiffnesses", "dampings"):
            value = lists[name]
            if value is not None and len(value) != n:
                raise _KeyError(name, value, f"must list {n} values (one per storey, as primary.masses)")
        if self.stiffnesses is None:
            raise _KeyError("stiffnesses", None, f"missing: give {n} storey stiffnesses")
        if self.dampings is not None and self.rayleigh is not None:
            raise _KeyError("rayleigh", None, "give either dampings (storey dashpots) or rayleigh, not both")
        if self.rayleigh is not None:
            modes = self.rayleigh.modes
            if modes[0] == modes[1] or max(modes) > n:
                raise _KeyError("rayleigh.modes", modes, f"must be two different modes in [1, {n}]")
            if self.frequencies()[0] <= 0.0:
                raise _KeyError("rayleigh", None, "needs a primary fixed to the ground (every storey stiffness > 0)")
        return self

    @property
    def n_floors(self) -> int:
        return 1 if self.masses is None else len(self.masses)

    @property
    def floor_masses(self) -> list[float]:
        return [float(self.mass)] if self.masses is None else [float(m) for m in self.masses]

    @property
    def storey_stiffnesses(self) -> list[float]:
        if self.masses is None:
            return [float(self.stiffness or 0.0)]
        return [float(k) for k in self.stiffnesses]

    def frequencies(self) -> np.ndarray:
        """Natural frequencies (rad/s, ascending) of the primary alone (no absorbers)."""
        mass, stiffness = np.array(self.floor_masses), _shear_stiffness(self.storey_stiffnesses)
        return _frequencies(mass, stiffness)

    def damping_matrices(self) -> tuple[list[float], list[float]]:
        """``(storey dashpots, mass-proportional dashpots to the ground)``, one per floor:
        the given dashpots, or Rayleigh's ``beta k_k`` and ``alpha m_k``."""
        n = self.n_floors
        if self.masses is None:
            return [float(self.damping or 0.0)], [0.0]
        if self.rayleigh is None:
            return [float(c) for c in (self.dampings or [0.0] * n)], [0.0] * n
        w = self.frequencies()
        wi, wj = (w[m - 1] for m in self.rayleigh.modes)
        z = self.rayleigh.ratio
        alpha, beta = 2.0 * z * wi * wj / (wi + wj), 2.0 * z / (wi + wj)
        return [beta * k for k in self.storey_stiffnesses], [alpha * m for m in self.floor_masses]


def _shear_stiffness(storeys: list[float]) -> np.ndarray:
    """Stiffness matrix of a shear building (MODEL.md 1a) from its storey stiffnesses."""
    n = len(storeys)
    k = np.zeros((n, n))
    for i, ks in enumerate(storeys):
        k[i, i] += ks
        if i > 0:
            k[i - 1, i - 1] += ks
            k[i - 1, i] -= ks
            k[i, i - 1] -= ks
    return k


def _frequencies(mass: np.ndarray, stiffness: np.ndarray) -> np.ndarray:
    """Square roots of the eigenvalues of ``M^-1 K`` (diagonal ``M``), ascending."""
    scale = 1.0 / np.sqrt(mass)
    eig = np.linalg.eigvalsh(stiffness * np.outer(scale, scale))
    return np.sqrt(np.clip(eig, 0.0, None))


class LinearAbsorber(_Model):
    """Tuned mass damper: ``f = -k u - c w`` (MODEL.md section 2)."""

    type: Literal["linear"]
    floor: Floor | None = None
    mass: Positive
    stiffness: NonNegative = 0.0
    damping: NonNegative = 0.0


class CubicAbsorber(_Model):
    """Cubic NES: ``f = -k u^3 - k_lin u - c w`` (MODEL.md section 2, Wei et al. eq. 1)."""

    type: Literal["cubic"]
    floor: Floor | None = None
    mass: Positive
    stiffness: NonNegative = 0.0
    damping: NonNegative = 0.0
    linear_stiffness: NonNegative = 0.0


class ImpactAbsorber(_Model):
    """Vibro-impact NES in a symmetric cavity with Newton restitution (MODEL.md section 2)."""

    type: Literal["impact"]
    floor: Floor | None = None
    mass: Positive
    clearance: Positive
    restitution: Annotated[float, Field(ge=0, le=1)]
    stiffness: NonNegative = 0.0
    damping: NonNegative = 0.0


class Contact(_Model):
    """Hertz contact constant ``K`` of one side, given directly (``k``) or from the surfaces:
    Young's moduli and Poisson ratios ``[barrier, absorber]`` and the sphere ``radius``
    (MODEL.md section 2)."""

    k: Positive | None = None
    young: Annotated[list[Positive], Field(min_length=2, max_length=2)] | None = None
    poisson: Annotated[list[Annotated[float, Field(ge=0, lt=0.5)]], Field(min_length=2, max_length=2)] | None = None
    radius: Positive | None = None
    q: Positive = 0.318

    @model_validator(mode="after")
    def _one_way(self) -> "Contact":
        surfaces = (self.young, self.poisson, self.radius)
        if self.k is not None and any(s is not None for s in surfaces):
            raise _KeyError("k", self.k, "give either k or young/poisson/radius, not both")
        if self.k is None and any(s is None for s in surfaces):
            missing = [n for n, s in zip(("young", "poisson", "radius"), surfaces) if s is None]
            raise _KeyError(missing[0], None, "missing: give k, or all of young = [barrier, absorber], "
                            "poisson = [barrier, absorber] and radius")
        return self

    @property
    def constant(self) -> float:
        """``K`` of ``F = K z^1.5``."""
        if self.k is not None:
            return float(self.k)
        return hertz_constant(self.young, self.poisson, self.radius, self.q)


class HertzAbsorber(_Model):
    """Vibro-impact NES with finite-duration Hertz contact (MODEL.md section 2, Lizunov et al.).

    ``offset`` is D (single-sided) or V (double-sided), ``gap`` is C.  ``rest`` overrides the
    spring's rest offset (default D, or V + C for double-sided).
    """

    type: Literal["hertz"]
    geometry: Literal["single-sided", "double-sided"]
    floor: Floor | None = None
    mass: Positive
    stiffness: NonNegative = 0.0
    damping: NonNegative = 0.0
    offset: NonNegative
    gap: Positive
    contact_left: Contact
    contact_right: Contact
    obstacle: Literal["from-rest", "from-primary"] = "from-rest"
    rest: Real | None = None

    @model_validator(mode="after")
    def _geometry(self) -> "HertzAbsorber":
        if self.obstacle == "from-primary":
            if self.geometry != "single-sided":
                raise _KeyError("obstacle", self.obstacle, "'from-primary' (seed 002) is defined for single-sided geometry only")
            if self.offset >= self.gap:
                raise _KeyError("offset", self.offset, f"must be < gap ({self.gap:g}) with obstacle = 'from-primary' "
                                "(the absorber would start inside the obstacle)")
        return self

    @property
    def walls(self) -> tuple[float, float]:
        """Relative positions ``(lo, hi)`` of the left and right contact surfaces:
        ``z_L = lo - u``, ``z_R = u - hi``."""
        if self.geometry == "double-sided":
            return self.offset, self.offset + 2.0 * self.gap
        if self.obstacle == "from-primary":
            return 0.0, self.gap
        return 0.0, self.offset + self.gap

    @property
    def start(self) -> float:
        """Initial relative position: D (single-sided) or V + C (double-sided)."""
        return self.offset + (self.gap if self.geometry == "double-sided" else 0.0)

    @property
    def spring_rest(self) -> float:
        """Rest offset of the linear spring."""
        return self.start if self.rest is None else self.rest


Absorber = Annotated[
    Union[LinearAbsorber, CubicAbsorber, ImpactAbsorber, HertzAbsorber], Field(discriminator="type")
]


class ImpulseLoad(_Model):
    """Initial velocity ``v(0) = velocity`` of a floor (default the roof; Wei's impulse
    strength X)."""

    type: Literal["impulse"]
    velocity: Real
    floor: Floor | None = None


class InitialLoad(_Model):
    """Initial displacements and velocities of all bodies (the floors from the lowest, then
    the absorbers)."""

    type: Literal["initial"]
    displacement: list[Real] | None = None
    velocity: list[Real] | None = None


class HarmonicLoad(_Model):
    """``F = amplitude * cos(frequency * t + phase)``, frequency in rad/s."""

    type: Literal["harmonic"]
    amplitude: Real
    frequency: NonNegative
    phase: Real = 0.0
    floor: Floor | None = None


class WhiteNoiseLoad(_Model):
    """Additive white-noise force, ``F dt = intensity dW`` (Ito)."""

    type: Literal["white-noise"]
    intensity: NonNegative
    floor: Floor | None = None


class JenningsEnvelope(_Model):
    """Jennings et al. (1968): ``(t/rise)^2`` up to ``rise``, 1 up to ``hold``, then
    ``exp(-decay (t - hold))``."""

    type: Literal["jennings"]
    rise: NonNegative
    hold: NonNegative
    decay: NonNegative

    @model_validator(mode="after")
    def _order(self) -> "JenningsEnvelope":
        if self.hold < self.rise:
            raise _KeyError("hold", self.hold, f"must be >= rise ({self.rise:g})")
        return self


class SaragoniHartEnvelope(_Model):
    """Saragoni and Hart (1974), normalised to peak 1 at ``t = peak``:
    ``(t/peak)^shape exp(shape (1 - t/peak))``."""

    type: Literal["saragoni-hart"]
    peak: Positive
    shape: Positive


Envelope = Annotated[Union[JenningsEnvelope, SaragoniHartEnvelope], Field(discriminator="type")]


class _FilteredLoad(_Model):
    """Shared fields of loads made by filtering white noise (``filters.py``)."""

    intensity: NonNegative
    envelope: Envelope | None = None
    start: Literal["rest", "stationary"] = "rest"

    @model_validator(mode="after")
    def _stationary(self) -> "_FilteredLoad":
        if self.start == "stationary" and self.envelope is not None:
            raise _KeyError("start", self.start, "a stationary start needs a load without envelope")
        return self


class FilteredNoiseLoad(_FilteredLoad):
    """Wei et al. eq. 23: ``f'' + 2 damping frequency f' + frequency^2 f = intensity xi``,
    force ``F = f``."""

    type: Literal["filtered-noise"]
    frequency: Positive
    damping: Positive
    floor: Floor | None = None


class GroundMotionLoad(_FilteredLoad):
    """Stochastic ground acceleration: Kanai-Tajimi or Clough-Penzien filtered white noise
    ``w dt = intensity dW`` (two-sided PSD ``S0 = intensity^2 / (2 pi)``) with an optional
    envelope; filter parameters from a ``soil`` preset or given."""

    type: Literal["ground-motion"]
    model: Literal["kanai-tajimi", "clough-penzien"] = "clough-penzien"
    soil: Literal["firm", "medium", "soft"] | None = None
    ground_frequency: Positive | None = None
    ground_damping: Positive | None = None
    filter_frequency: Positive | None = None
    filter_damping: Positive | None = None

    @model_validator(mode="after")
    def _parameters(self) -> "GroundMotionLoad":
        preset = SOILS.get(self.soil, (None,) * 4)
        names = ["ground_frequency", "ground_damping"]
        if self.model == "clough-penzien":
            names += ["filter_frequency", "filter_damping"]
        for name, value in zip(["ground_frequency", "ground_damping", "filter_frequency", "filter_damping"], preset):
            if getattr(self, name) is None:
                setattr(self, name, value)
        for name in names:
            if getattr(self, name) is None:
                raise _KeyError(name, None, "missing: give it or a soil preset (firm, medium, soft)")
        return self


class HalfSineLoad(_Model):
    """``F = amplitude sin(pi (t - start) / duration)`` for ``start <= t <= start + duration``."""

    type: Literal["half-sine"]
    amplitude: Real
    duration: Positive
    start: NonNegative = 0.0
    floor: Floor | None = None


class PulseTrainLoad(_Model):
    """``F = amplitude`` while ``(t - start) mod period < width`` (``t >= start``), for ``count``
    pulses (0: no end)."""

    type: Literal["pulse-train"]
    amplitude: Real
    width: Positive
    period: Positive
    start: NonNegative = 0.0
    count: Annotated[int, Field(ge=0)] = 0
    floor: Floor | None = None

    @model_validator(mode="after")
    def _width(self) -> "PulseTrainLoad":
        if self.width > self.period:
            raise _KeyError("width", self.width, f"must be <= period ({self.period:g})")
        return self


class ChirpLoad(_Model):
    """``F = amplitude sin(2 pi (f0 t + (f1 - f0) t^2 / (2 duration)))``, ``f0``, ``f1`` in Hz."""

    type: Literal["chirp"]
    amplitude: Real
    f0: NonNegative
    f1: NonNegative
    duration: Positive
    floor: Floor | None = None


class _RecordLoad(_Model):
    """A sampled record: linear interpolation, zero outside its time span."""

    file: Annotated[str, Field(min_length=1)]
    dt: Positive | None = None
    scale: Real = 1.0
    format: Literal["auto", "at2", "two-column", "one-column"] = "auto"
    _times: np.ndarray | None = PrivateAttr(default=None)
    _values: np.ndarray | None = PrivateAttr(default=None)

    def samples(self) -> tuple[np.ndarray, np.ndarray]:
        """Times and values in scenario units (scale and units applied)."""
        if self._times is None:
            raise RuntimeError(f"record {self.file!r} was not read (use load_scenario)")
        factor = G if getattr(self, "units", "m/s2") == "g" else 1.0
        return self._times, self._values * (self.scale * factor)


class RecordLoad(_RecordLoad):
    """Ground acceleration record (base excitation: every mass gets ``-m a_g``)."""

    type: Literal["record"]
    units: Literal["g", "m/s2"]


class ForceRecordLoad(_RecordLoad):
    """Force record acting on a floor (default the roof; scenario force units)."""

    type: Literal["force-record"]
    floor: Floor | None = None


Load = Annotated[
    Union[ImpulseLoad, InitialLoad, HarmonicLoad, WhiteNoiseLoad, FilteredNoiseLoad, GroundMotionLoad,
          HalfSineLoad, PulseTrainLoad, ChirpLoad, RecordLoad, ForceRecordLoad],
    Field(discriminator="type"),
]


class History(_Model):
    """Ensemble statistics of time histories on a decimated grid (history.parquet): by default
    the roof's displacement ``x1`` and the structure's energy ``e1``; ``signals`` may also name
    a floor's displacement ``x_k`` or inter-storey drift ``drift_k`` (``k = 1..n``)."""

    points: Annotated[int, Field(ge=2, le=100_000)] = 1000
    quantiles: list[Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False)]] = [0.05, 0.5, 0.95]
    signals: Annotated[list[str], Field(min_length=1)] = ["x1", "e1"]

    @model_validator(mode="after")
    def _distinct(self) -> "History":
        if len(set(self.signals)) != len(self.signals):
            raise _KeyError("signals", self.signals, "must not repeat a signal")
        if len(set(self.quantiles)) != len(self.quantiles):
            raise _KeyError("quantiles", self.quantiles, "must not repeat a value")
        if len({quantile_name(q) for q in self.quantiles}) != len(self.quantiles):
            raise _KeyError("quantiles", self.quantiles, "must differ in their first 4 decimals")
        return self


def history_signals(n_floors: int) -> list[str]:
    """Signals a history can record on a primary with ``n_floors`` floors: the roof's
    displacement ``x1``, the structure's energy ``e1``, each floor's displacement ``x_k`` and
    inter-storey drift ``drift_k``."""
    floors = range(1, n_floors + 1)
    return ["x1", "e1", *(f"x_{k}" for k in floors), *(f"drift_{k}" for k in floors)]


def quantile_name(q: float) -> str:
    """Column suffix of a quantile: ``q05`` for 0.05, ``q50`` for 0.5, ``q025`` for 0.025."""
    digits = f"{q:.4f}"[2:].rstrip("0")
    return "q" + digits.ljust(2, "0")


class Simulation(_Model):
    """Time grid and scheme; ``metrics_from`` opens the metrics window ``[t0, T]``; ``history``
    asks for ensemble statistics of time histories (``true``: the default grid and quantiles)."""

    duration: Positive
    dt: Positive
    scheme: Literal["auto", "euler-maruyama", "rk4", "sra"] = "auto"
    history: History | None = None
    metrics_from: NonNegative = 0.0

    @field_validator("history", mode="before")
    @classmethod
    def _history_switch(cls, value: Any) -> Any:
        """``true``: the default grid and quantiles; ``false``: none."""
        if isinstance(value, bool):
            return History() if value else None
        return value


class Ensemble(_Model):
    """Monte Carlo ensemble size, master seed, chunk size (0 = automatic), the EDM standard
    error at which a sweep point stops early, and whether sweep points share their random
    numbers (realisation ``r`` sees the same noise and parameter draws at every point)."""

    realizations: Annotated[int, Field(ge=1)] = 1
    seed: Annotated[int, Field(ge=0)] = 0
    chunk: Annotated[int, Field(ge=0)] = 0
    target_sem: Positive | None = None
    common_random_numbers: bool = True


class NormalDistribution(_Model):
    """``mean + std Z``."""

    distribution: Literal["normal"]
    mean: Real
    std: Positive

    def support(self) -> tuple[float, float]:
        return -math.inf, math.inf

    def draw(self, gen: np.random.Generator) -> float:
        return self.mean + self.std * gen.standard_normal()


class LognormalDistribution(_Model):
    """``median exp(s Z)`` with ``s^2 = ln(1 + cov^2)`` (``cov``: coefficient of variation)."""

    distribution: Literal["lognormal"]
    median: Positive
    cov: Positive

    def support(self) -> tuple[float, float]:
        return 0.0, math.inf

    def draw(self, gen: np.random.Generator) -> float:
        return self.median * math.exp(math.sqrt(math.log1p(self.cov ** 2)) * gen.standard_normal())


class _Bounded(_Model):
    low: Real
    high: Real

    @model_validator(mode="after")
    def _order(self) -> "_Bounded":
        if not self.low < self.high:
            raise _KeyError("high", self.high, f"must be > low ({self.low:g})")
        return self

    def support(self) -> tuple[float, float]:
        return self.low, self.high


class UniformDistribution(_Bounded):
    """Uniform on ``[low, high]``."""

    distribution: Literal["uniform"]

    def draw(self, gen: np.random.Generator) -> float:
        return self.low + (self.high - self.low) * gen.random()


class TruncatedNormalDistribution(_Bounded):
    """``mean + std Z`` conditioned on ``[low, high]`` (drawn by inverting its CDF)."""

    distribution: Literal["truncated-normal"]
    mean: Real
    std: Positive

    def draw(self, gen: np.random.Generator) -> float:
        from scipy.stats import truncnorm

        a, b = (self.low - self.mean) / self.std, (self.high - self.mean) / self.std
        return float(truncnorm.ppf(gen.random(), a, b, loc=self.mean, scale=self.std))


Distribution = Annotated[
    Union[NormalDistribution, LognormalDistribution, UniformDistribution, TruncatedNormalDistribution],
    Field(discriminator="distribution"),
]


class Bound(_Model):
    """Range searched for one optimised parameter, its starting value (default: the middle,
    geometric on a log scale) and whether the search works on its logarithm."""

    low: Real
    high: Real
    start: Real | None = None
    scale: Literal["linear", "log"] = "linear"

    @model_validator(mode="after")
    def _range(self) -> "Bound":
        if not self.low < self.high:
            raise _KeyError("high", self.high, f"must be > low ({self.low:g})")
        if self.scale == "log" and self.low <= 0:
            raise _KeyError("low", self.low, "must be > 0 with scale = 'log'")
        if self.start is not None and not self.low <= self.start <= self.high:
            raise _KeyError("start", self.start, f"must be in [{self.low:g}, {self.high:g}]")
        return self

    @property
    def initial(self) -> float:
        if self.start is not None:
            return self.start
        return math.sqrt(self.low * self.high) if self.scale == "log" else 0.5 * (self.low + self.high)


#: Metrics an optimisation can target, and their default goal.
OBJECTIVES = {"edm": "maximize", "e1_max": "minimize", "energy_integral": "minimize",
              "x1_max": "minimize", "x1_rms": "minimize"}


class Optimize(_Model):
    """Robust design (``vines-stoch optimize``): tune ``parameters`` within their bounds so that
    the mean of ``objective`` over the realisations and sweep points is best."""

    objective: Literal[tuple(OBJECTIVES)] = "edm"  # type: ignore[valid-type]
    goal: Literal["maximize", "minimize"] | None = None
    method: Literal["nelder-mead", "powell"] = "nelder-mead"
    max_evaluations: Annotated[int, Field(ge=1, le=100_000)] = 200
    tolerance: Annotated[float, Field(gt=0, le=0.5)] = 1e-3
    parameters: Annotated[dict[str, Bound], Field(min_length=1)]

    @property
    def sign(self) -> float:
        """+1 to minimise the objective, -1 to maximise it."""
        return -1.0 if (self.goal or OBJECTIVES[self.objective]) == "maximize" else 1.0


class Output(_Model):
    """Where results go (default ``results/<name>``)."""

    directory: str | None = None


class Scenario(_Model):
    """A complete scenario file (SCENARIOS.md)."""

    name: Annotated[str, Field(min_length=1)]
    description: str = ""
    primary: Primary
    absorbers: list[Absorber] = []
    loads: list[Load] = []
    simulation: Simulation
    ensemble: Ensemble = Ensemble()
    sweep: dict[str, Any] = {}
    uncertain: dict[str, Distribution] = {}
    optimize: Optimize | None = None
    output: Output = Output()

    @model_validator(mode="after")
    def _consistency(self) -> "Scenario":
        sim = self.simulation
        if sim.dt > sim.duration:
            raise _KeyError("simulation.dt", sim.dt, f"must be <= simulation.duration ({sim.duration:g})")
        if sim.metrics_from >= sim.duration:
            raise _KeyError(
                "simulation.metrics_from", sim.metrics_from, f"must be in [0, {sim.duration:g})"
            )
        n = self.primary.n_floors
        nbodies = n + len(self.absorbers)
        for i, item in [(f"absorbers.{i}", a) for i, a in enumerate(self.absorbers)] + \
                       [(f"loads.{i}", l) for i, l in enumerate(self.loads)]:
            floor = getattr(item, "floor", None)
            if floor is not None and not 1 <= floor <= n:
                raise _KeyError(f"{i}.floor", floor, f"must be in [1, {n}] (the primary has {n} floor{'s' * (n > 1)})")
        for i, load in enumerate(self.loads):
            if isinstance(load, InitialLoad):
                for field in ("displacement", "velocity"):
                    values = getattr(load, field)
                    if values is not None and len(values) != nbodies:
                        raise _KeyError(
                            f"loads.{i}.{field}", values,
                            f"must list {nbodies} values (the {n} floor{'s' * (n > 1)} from the lowest, then each "
                            "absorber)",
                        )
        if sim.history is not None:
            allowed = history_signals(n)
            for signal in sim.history.signals:
                if signal not in allowed:
                    raise _KeyError("simulation.history.signals", sim.history.signals,
                                    f"{signal!r} is not a signal: give x1, e1, x_k or drift_k with k in [1, {n}]")
        contents = self.contents
        if sim.scheme != "auto":
            why = schemes.refusal(schemes.SCHEMES[sim.scheme], *contents)
            if why is not None:
                raise _KeyError("simulation.scheme", sim.scheme, why)
        elif schemes.refusal(schemes.SCHEMES[self.scheme], *contents) is not None:
            i = next(i for i, a in enumerate(self.absorbers) if isinstance(a, HertzAbsorber))
            raise _KeyError(f"absorbers.{i}.type", "hertz",
                            "Hertz contact is solved by the rk4 scheme only: remove noise loads "
                            "and use scheme = 'auto' or 'rk4'")
        return self

    @property
    def contents(self) -> tuple[bool, bool, bool, bool]:
        """What the schemes must accept: noise, filtered loads, impact absorbers, Hertz absorbers."""
        return (self.has_noise, any(isinstance(l, _FilteredLoad) and l.intensity > 0 for l in self.loads),
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
        absorber on the linear part of its attachment to its host floor (cubic terms, impacts and
        contacts left out; an absorber without a linear spring is a free mass, frequency 0)."""
        n = self.primary.n_floors
        mass = np.array(self.primary.floor_masses + [a.mass for a in self.absorbers])
        k = np.zeros((mass.shape[0], mass.shape[0]))
        k[:n, :n] = _shear_stiffness(self.primary.storey_stiffnesses)
        for j, a in enumerate(self.absorbers, start=n):
            spring = a.linear_stiffness if isinstance(a, CubicAbsorber) else a.stiffness
            h = (a.floor or n) - 1
            k[[h, j], [h, j]] += spring
            k[[h, j], [j, h]] -= spring
        return _frequencies(mass, k)

    def highest_frequency(self) -> float:
        """The highest of ``natural_frequencies`` (the stability limit of ``dt``)."""
        return float(self.natural_frequencies().max())

    @property
    def has_noise(self) -> bool:
        """True when any random load acts (white, filtered noise, stochastic ground motion)."""
        return any(isinstance(l, (WhiteNoiseLoad, _FilteredLoad)) and l.intensity > 0 for l in self.loads)


class _KeyError(ValueError):
    """Raised inside validators to report a dotted key with its value and rule."""

    def __init__(self, key: str, value: Any, rule: str):
        super().__init__(rule)
        self.key, self.value, self.rule = key, value, rule


# ----------------------------------------------------------------------------- errors


def _interval(metadata: list[Any]) -> str | None:
    lo = hi = None
    lo_open = hi_open = True
    for m in metadata:
        if isinstance(m, Ge):
            lo, lo_open = m.ge, False
        elif isinstance(m, Gt):
            lo, lo_open = m.gt, True
        elif isinstance(m, Le):
            hi, hi_open = m.le, False
        elif isinstance(m, Lt):
            hi, hi_open = m.lt, True
    if lo is None and hi is None:
        return None
    if hi is None:
        return f"must be {'>' if lo_open else '>='} {lo:g}"
    if lo is None:
        return f"must be {'<' if hi_open else '<='} {hi:g}"
    return f"must be in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def _constraints(info: Any) -> list[Any]:
    """Bound constraints of a field, also inside ``Optional[Annotated[...]]`` and lists of
    them (``Optional[list[Annotated[...]]]``: the bound of the items)."""
    found = list(info.metadata)

    def walk(annotation: Any) -> None:
        for arg in getattr(annotation, "__args__", ()):
            for meta in getattr(arg, "__metadata__", ()):
                found.extend(getattr(meta, "metadata", [meta]))
            walk(arg)

    walk(info.annotation)
    return found


def _field_info(loc: tuple[Any, ...]):
    """Walk a pydantic error location through the models to the FieldInfo it names."""
    model: Any = Scenario
    info = None
    for part in loc:
        if isinstance(part, int) or model is None:
            continue
        if isinstance(model, type) and issubclass(model, BaseModel):
            if part not in model.model_fields:
                return None
            info = model.model_fields[part]
            model = _inner_model(info.annotation)
        elif isinstance(model, dict):  # tagged union: part is the tag (or a key of a table of them)
            model = model.get(part, model)
    return info


def _members(annotation: Any) -> list[type[BaseModel]]:
    """Model classes inside an annotation (through lists, unions and Annotated)."""
    found: list[type[BaseModel]] = []
    for arg in getattr(annotation, "__args__", ()):
        if isinstance(arg, type) and issubclass(arg, BaseModel):
            found.append(arg)
        else:
            found += _members(arg)
    return found


def _inner_model(annotation: Any) -> Any:
    """The model (or tag -> model map for a tagged union) inside an annotation, if any."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    members = _members(annotation)
    if len(members) == 1:
        return members[0]
    if members:
        return {m.model_fields[_tag(m)].annotation.__args__[0]: m for m in members}
    return None


#: Fields that tag the members of a tagged union (absorbers and loads, distributions).
TAGS = ("type", "distribution")


def _tag(model: type[BaseModel]) -> str:
    return next(t for t in TAGS if t in model.model_fields)


def _dotted(loc: tuple[Any, ...], data: Any) -> tuple[str, Any, tuple[Any, ...]]:
    """Dotted key, the user's value at it, and the location without union tags."""
    parts: list[str] = []
    clean: list[Any] = []
    node = data
    for part in loc:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and part < len(node):
            node = node[part]
        elif isinstance(part, str) and isinstance(node, dict) and part in (node.get(t) for t in TAGS):
            continue  # the tag of a tagged union, not a key of the file
        else:
            node = _MISSING
        parts.append(str(part))
        clean.append(part)
    return ".".join(parts), node, tuple(clean)


_MISSING = object()


def _describe(err: dict[str, Any], data: Any) -> tuple[str, Any, str]:
    key, value, loc = _dotted(tuple(err["loc"]), data)
    kind = err["type"]
    info = _field_info(tuple(err["loc"]))
    if kind == "missing":
        what = "section" if info is not None and _inner_model(info.annotation) is not None else "key"
        return key, _MISSING, f"missing required {what}"
    if kind == "extra_forbidden":
        allowed = _allowed_keys(loc[:-1], data)
        return key, value, f"unknown key; allowed keys: {', '.join(allowed)}" if allowed else "unknown key"
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        tag = err.get("ctx", {}).get("discriminator", "'type'").strip("'")
        key = f"{key}.{tag}" if key else tag
        value = value.get(tag, _MISSING) if isinstance(value, dict) else value
        tags = err.get("ctx", {}).get("expected_tags", "")
        members = _inner_model(info.annotation) if info is not None else None
        if not tags and isinstance(members, dict):
            tags = ", ".join(repr(t) for t in members)
        return key, value, f"must be one of {tags}"
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal") and info:
        return key, value, _interval(_constraints(info)) or err["msg"]
    if kind in ("float_parsing", "float_type", "int_parsing", "int_type", "int_from_float"):
        return key, value, "must be " + ("an integer" if kind.startswith("int") else "a number")
    if kind == "finite_number":
        return key, value, "must be a finite number"
    if kind == "literal_error":
        return key, value, "must be " + err["msg"].removeprefix("Input should be ")
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return key, value, "must be a table"
    if kind == "list_type":
        return key, value, "must be a list"
    if kind == "value_error" and isinstance(err.get("ctx", {}).get("error"), _KeyError):
        e = err["ctx"]["error"]
        value = e.value if e.value is not None else _MISSING
        return (f"{key}.{e.key}" if key else e.key), value, e.rule
    return key, value, err["msg"]


def _allowed_keys(loc: tuple[Any, ...], data: Any) -> list[str]:
    model: Any = Scenario
    node = data
    for part in loc:
        node = node[part] if isinstance(node, (dict, list)) and part in (node if isinstance(node, dict) else range(len(node))) else None
        if isinstance(part, int) or isinstance(model, dict):
            continue  # a list index, or a key of a table of tagged models
        info = model.model_fields.get(part) if isinstance(model, type) else None
        model = _inner_model(info.annotation) if info else None
    if isinstance(model, dict):
        tag = next((node[t] for t in TAGS if isinstance(node, dict) and t in node), None)
        model = model.get(tag)
    return list(model.model_fields) if isinstance(model, type) else []


def _format(source: str, key: str, value: Any, rule: str) -> str:
    where = f"{source}: {key}" if key else source
    if value is _MISSING:
        return f"{where}: {rule}"
    return f"{where} = {value!r}: {rule}"


def _validate(data: dict[str, Any], source: str) -> Scenario:
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors(include_url=False)
        lines = [_format(source, *_describe(e, data)) for e in errors]
        raise ScenarioError("\n".join(dict.fromkeys(lines))) from None


# ----------------------------------------------------------------------------- sweeps


def _grid(key: str, spec: Any, source: str) -> list[float]:
    """Values of one ``[sweep]`` entry: a list, ``{linspace = [a, b, n]}`` or ``{logspace = [a, b, n]}``."""
    where = f"sweep.{key}"
    if isinstance(spec, list):
        values = spec
    elif isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in ("linspace", "logspace"):
        kind, args = next(iter(spec.items()))
        if not (isinstance(args, list) and len(args) == 3 and all(isinstance(a, (int, float)) for a in args)
                and isinstance(args[2], int) and args[2] >= 1):
            raise ScenarioError(_format(source, f"{where}.{kind}", args, "must be [first, last, count] with count an integer >= 1"))
        first, last, count = args
        if kind == "logspace":
            if first <= 0 or last <= 0:
                raise ScenarioError(_format(source, f"{where}.logspace", args, "first and last must be > 0 (values, not exponents)"))
            values = list(np.geomspace(first, last, count))
        else:
            values = list(np.linspace(first, last, count))
    else:
        raise ScenarioError(_format(source, where, spec, "must be a list of values, {linspace = [first, last, count]} or {logspace = [first, last, count]}"))
    if not values:
        raise ScenarioError(_format(source, where, spec, "must hold at least one value"))
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ScenarioError(_format(source, where, spec, "values must be finite numbers"))
    return [float(v) for v in values]


def set_path(data: dict[str, Any], key: str, value: Any) -> None:
    """Set the field addressed by a dotted path (``loads.0.velocity``) in raw scenario data."""
    parts = key.split(".")
    node: Any = data
    for part in parts[:-1]:
        node = node[int(part)] if isinstance(node, list) else node[part]
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value


def get_path(data: dict[str, Any], key: str) -> Any:
    """The value addressed by a dotted path, or raise KeyError/IndexError/ValueError."""
    node: Any = data
    for part in key.split("."):
        node = node[int(part)] if isinstance(node, list) else node[part]
    return node


def _require_numeric(data: dict[str, Any], key: str, where: str, spec: Any, source: str) -> None:
    """``key`` must address an existing numeric field of the file."""
    try:
        current = get_path(data, key)
    except (KeyError, IndexError, ValueError, TypeError):
        current = None
    if isinstance(current, bool) or not isinstance(current, (int, float)):
        raise ScenarioError(_format(source, where, spec,
                                    "must name an existing numeric field of the file (e.g. loads.0.velocity)"))


def _check_values(data: dict[str, Any], key: str, ends: tuple[float, float], where: str, spec: Any,
                  source: str, message: str) -> None:
    """Validate the file with ``key`` set to each of ``ends``; on failure raise ``message``
    (formatted with ``end`` and the field's ``rule``) at ``where`` (whose value is ``spec``)."""
    for end in ends:
        variant = copy.deepcopy(data)
        set_path(variant, key, end)
        variant.pop("uncertain", None)
        variant.pop("optimize", None)
        try:
            _validate(variant, source)
        except ScenarioError as exc:
            rule = str(exc).split("\n")[0].rsplit(": ", 1)[-1]
            raise ScenarioError(_format(source, where, spec, message.format(end=end, rule=rule))) from None


def _check_stability(scenario: Scenario, source: str) -> None:
    """Refuse a ``dt`` past the linear stability limit of the scheme that would run."""
    omega, dt = scenario.highest_frequency(), scenario.simulation.dt
    limit = schemes.SCHEMES[scenario.scheme].stability
    if omega * dt >= limit:
        raise ScenarioError(_format(
            source, "simulation.dt", dt,
            f"is past the stability limit of the {scenario.scheme} scheme: the highest linear natural frequency "
            f"of the scene is {omega:.6g} rad/s, which needs dt < {limit:.4g} / omega = {limit / omega:.4g} "
            f"(use about a tenth of that for accuracy)"))


class Study:
    """A validated scenario file: the base scenario and its sweep points."""

    def __init__(self, source: str, text: str, data: dict[str, Any], directory: Path = Path("."),
                 records: dict[tuple[Any, ...], tuple[np.ndarray, np.ndarray]] | None = None):
        self.source = source
        self.text = text
        self.data = data
        self.directory = directory
        self._records = {} if records is None else records  # record files read so far, shared by variants
        self.base = self._read_records(_validate(data, source), source)
        sweep = dict(self.base.sweep)
        zipped = _zipped(sweep.pop("zip", []), sweep, source)
        self.sweep_keys = list(sweep)
        grids = {k: _grid(k, sweep[k], source) for k in self.sweep_keys}
        for key in self.sweep_keys:
            _require_numeric(data, key, f"sweep.{key}", sweep[key], source)
        self.uncertain_keys = list(self.base.uncertain)
        for key, dist in self.base.uncertain.items():
            _require_numeric(data, key, f"uncertain.{key}", data["uncertain"][key], source)
            if key in self.sweep_keys:
                raise ScenarioError(_format(source, f"uncertain.{key}", data["uncertain"][key],
                                            "is also swept: a parameter is either swept or uncertain"))
            self._check_support(data, key, dist, source)
        if self.base.optimize is not None:
            self._check_optimize(data, source)
        self.grid = _product(grids, zipped, source)
        self.points: list[Scenario] = []
        self._point_data: list[dict[str, Any]] = []
        for values in self.grid:
            variant = copy.deepcopy(data)
            for key, value in values.items():
                set_path(variant, key, value)
            self._point_data.append(variant)
            where = f"{source} (sweep point {values})" if values else source
            self.points.append(self._read_records(_validate(variant, where), source))
            _check_stability(self.points[-1], where)

    def _check_support(self, data: dict[str, Any], key: str, dist: Any, source: str) -> None:
        """Every value ``dist`` can draw must be valid for ``key``: check both ends of its support."""
        lo, hi = dist.support()
        lo = lo if math.isfinite(lo) else -1e300
        lo = lo if lo != 0.0 or not isinstance(dist, LognormalDistribution) else 2.2e-308
        _check_values(data, key, (lo, hi if math.isfinite(hi) else 1e300), f"uncertain.{key}",
                      data["uncertain"][key], source,
                      f"{dist.distribution} draws reach {{end:g}}, but the value {{rule}}; choose a distribution whose "
                      "support fits (lognormal for positive values, uniform or truncated-normal within bounds)")

    def _check_optimize(self, data: dict[str, Any], source: str) -> None:
        """Optimised parameters: numeric fields, neither swept nor uncertain, valid at both bounds."""
        for key, bound in self.base.optimize.parameters.items():
            where = f"optimize.parameters.{key}"
            spec = data["optimize"]["parameters"][key]
            _require_numeric(data, key, where, spec, source)
            if key in self.sweep_keys or key in self.uncertain_keys:
                raise ScenarioError(_format(source, where, spec, "is swept or uncertain: an optimised parameter "
                                                                 "must be neither"))
            _check_values(data, key, (bound.low, bound.high), where, spec, source,
                          "the bound {end:g} is not allowed: the value {rule}")

    def realise(self, point: int, values: dict[str, float]) -> Scenario:
        """Sweep point ``point`` with its uncertain parameters set to ``values``."""
        variant = copy.deepcopy(self._point_data[point])
        for key, value in values.items():
            set_path(variant, key, value)
        return self._read_records(_validate(variant, self.source), self.source)

    def with_values(self, values: dict[str, float]) -> "Study":
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
                key = (path.resolve(), load.format, load.dt)
                if key not in self._records:
                    try:
                        self._records[key] = read_record(path, load.format, load.dt)
                    except RecordError as exc:
                        raise ScenarioError(_format(source, f"loads.{i}.file", load.file, str(exc))) from None
                load._times, load._values = self._records[key]
        return scenario

    @property
    def name(self) -> str:
        return self.base.name


def _zipped(spec: Any, sweep: dict[str, Any], source: str) -> list[str]:
    """Keys of ``sweep.zip``: swept together, value by value, as one axis of the grid."""
    if not (isinstance(spec, list) and all(isinstance(k, str) for k in spec)):
        raise ScenarioError(_format(source, "sweep.zip", spec, "must be a list of swept keys"))
    for key in spec:
        if key not in sweep:
            raise ScenarioError(_format(source, "sweep.zip", spec, f"names {key!r}, which is not swept in [sweep]"))
    return list(dict.fromkeys(spec))


def _product(grids: dict[str, list[float]], zipped: list[str], source: str) -> list[dict[str, float]]:
    """Sweep points: the cartesian product of the axes, zipped keys forming one axis."""
    if zipped:
        lengths = {len(grids[k]) for k in zipped}
        if len(lengths) > 1:
            sizes = ", ".join(f"{k}: {len(grids[k])}" for k in zipped)
            raise ScenarioError(_format(source, "sweep.zip", zipped, f"zipped keys need equally many values ({sizes})"))
    axes: list[list[dict[str, float]]] = []
    if zipped:
        axes.append([{k: grids[k][i] for k in zipped} for i in range(len(grids[zipped[0]]))])
    axes += [[{k: v} for v in grid] for k, grid in grids.items() if k not in zipped]
    points: list[dict[str, float]] = [{}]
    for axis in axes:
        points = [{**p, **a} for p in points for a in axis]
    return [{k: p[k] for k in grids} for p in points]


def load_scenario(path: str | Path) -> Study:
    """Read and validate a scenario file; raise ScenarioError with a one-line reason per mistake."""
    path = Path(path)
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(f"{source}: cannot read file ({exc.strerror})") from None
    return parse_scenario(text, source, path.parent)


def parse_scenario(text: str, source: str = "<scenario>", directory: str | Path = ".") -> Study:
    """Validate scenario TOML text (``source`` names it in messages; record files are found
    relative to ``directory``)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: TOML syntax error: {exc}") from None
    return Study(source, text, data, Path(directory))
