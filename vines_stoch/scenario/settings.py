"""Settings: the time grid and scheme, histories, the ensemble, optimisation and output."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from .errors import FieldError
from .fields import MAX_REALIZATIONS, NonNegative, Positive, Real, _Model


class History(_Model):
    """Ensemble statistics of time histories on a decimated grid (history.parquet): by default
    the roof's displacement ``x1`` and the structure's energy ``e1``; ``signals`` may name any
    signal of ``signals.signal_names``: a floor's displacement ``x_k``, velocity ``v_k`` or
    inter-storey drift ``drift_k`` (``k = 1..n``), an absorber's displacement ``xa_j``, velocity
    ``va_j``, stroke ``stroke_j`` or contact force on its host ``contact_j`` (``j``: the
    absorbers in file order; a Hertz absorber's contact force, an impact absorber's impulses over
    the step that ended over ``dt``, 0 for the other laws), and with absorbers their share of the
    energy ``share`` (``E_abs / (E1 + E_abs)``)."""

    points: Annotated[int, Field(ge=2, le=100_000)] = 1000
    quantiles: list[Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False)]] = [0.05, 0.5, 0.95]
    signals: Annotated[list[str], Field(min_length=1)] = ["x1", "e1"]

    @model_validator(mode="after")
    def _distinct(self) -> History:
        if len(set(self.signals)) != len(self.signals):
            raise FieldError("signals", self.signals, "must not repeat a signal")
        if len(set(self.quantiles)) != len(self.quantiles):
            raise FieldError("quantiles", self.quantiles, "must not repeat a value")
        if len({quantile_name(q) for q in self.quantiles}) != len(self.quantiles):
            raise FieldError("quantiles", self.quantiles, "must differ in their first 4 decimals")
        return self


def quantile_name(q: float) -> str:
    """Column suffix of a quantile: ``q05`` for 0.05, ``q50`` for 0.5, ``q025`` for 0.025."""
    digits = f"{q:.4f}"[2:].rstrip("0")
    return "q" + digits.ljust(2, "0")


class Simulation(_Model):
    """Time grid and scheme; ``metrics_from`` opens the metrics window ``[t0, T]``; ``history``
    asks for ensemble statistics of time histories (``true``: the default grid and quantiles);
    ``residual_tolerance``: the largest ``|energy_residual|`` a realisation may end with
    unflagged (``metrics.residual_notes``)."""

    duration: Positive
    dt: Positive
    scheme: Literal["auto", "euler-maruyama", "rk4", "sra"] = "auto"
    history: History | None = None
    metrics_from: NonNegative = 0.0
    residual_tolerance: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = 1e-3

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
    numbers (realisation ``r`` sees the same noise and parameter draws at every point);
    ``max_path_steps`` caps a run's work (sweep points x realisations x steps a path) against
    runs that cannot be meant, and may be raised for a run that is."""

    realizations: Annotated[int, Field(ge=1, le=MAX_REALIZATIONS)] = 1
    seed: Annotated[int, Field(ge=0, le=2**63 - 1)] = 0
    chunk: Annotated[int, Field(ge=0, le=MAX_REALIZATIONS)] = 0
    target_sem: Positive | None = None
    common_random_numbers: bool = True
    max_path_steps: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 1e12


class Bound(_Model):
    """Range searched for one optimised parameter, its starting value (default: the middle,
    geometric on a log scale) and whether the search works on its logarithm."""

    low: Real
    high: Real
    start: Real | None = None
    scale: Literal["linear", "log"] = "linear"

    @model_validator(mode="after")
    def _range(self) -> Bound:
        if not self.low < self.high:
            raise FieldError("high", self.high, f"must be > low ({self.low:g})")
        if self.scale == "log" and self.low <= 0:
            raise FieldError("low", self.low, "must be > 0 with scale = 'log'")
        if self.start is not None and not self.low <= self.start <= self.high:
            raise FieldError("start", self.start, f"must be in [{self.low:g}, {self.high:g}]")
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


def limit_metrics(n_floors: int, heights: bool = False) -> list[str]:
    """Peak metrics a limit can name on a primary with ``n_floors`` floors: the roof's peak
    displacement ``x1_max``, the structure's peak energy ``e1_max`` and each floor's
    ``x_max_k``, ``drift_max_k``, ``acc_max_k`` (MODEL.md section 4), and with storey
    ``heights`` each storey's drift ratio ``drift_ratio_max_k``."""
    floors = range(1, n_floors + 1)
    kinds = ("x_max", "drift_max", "acc_max", *(("drift_ratio_max",) if heights else ()))
    return ["x1_max", "e1_max", *(f"{m}_{k}" for m in kinds for k in floors)]


class Limit(_Model):
    """A named threshold on a peak metric (``limit_metrics``): each realisation records the first
    time its running peak exceeds ``value`` (``first_passage_NAME``), each sweep point the
    fraction that did with its 95 % interval (``p_NAME``)."""

    metric: str
    value: Positive


class Rare(_Model):
    """A rare-event estimate of one limit's exceedance probability at every sweep point
    (rare.parquet; ``rare.py``): ``limit`` names a key of ``[limits]``; ``method`` is
    ``"splitting"`` (adaptive multilevel splitting on a running peak, ``rare.Score``: any
    scene with noise) or ``"subset"`` (subset simulation on the noise's standard normal inputs, white
    and filtered, and the uncertain parameters); independent replicas
    of ``particles`` paths each (default 200 for splitting, 1000 for subset) run until the
    estimate's coefficient of variation is at most ``target_cov`` or ``max_paths``
    path-equivalents (steps run over a path's steps) are spent; ``kill``: the least fraction of
    paths splitting kills a level."""

    limit: str
    method: Literal["splitting", "subset"] = "splitting"
    target_cov: Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False)] = 0.1
    max_paths: Annotated[float, Field(ge=1, le=1e9, allow_inf_nan=False)] = 100_000
    particles: Annotated[int, Field(ge=10, le=1_000_000)] | None = None
    kill: Annotated[float, Field(gt=0, le=0.5, allow_inf_nan=False)] = 0.1

    @property
    def n(self) -> int:
        """Paths of a splitting replica, samples of a subset level."""
        return self.particles or (200 if self.method == "splitting" else 1000)


class Sensitivity(_Model):
    """Sobol indices (first order and total, with bootstrap 95 % intervals) of ``metric`` with
    respect to the ``[uncertain]`` parameters at every sweep point (sensitivity.parquet;
    ``sensitivity.py``): a Sobol design of ``samples`` base points (Saltelli's scheme:
    ``samples (d + 2)`` parameter sets for ``d`` parameters), each run on the same
    ``realizations`` noise paths (common random numbers), its value the mean of ``metric`` over
    them, or for ``p_NAME`` the fraction exceeding limit NAME: the indices apportion the variance
    of that conditional mean, the noise's own variance left out."""

    metric: str = "edm"
    samples: Annotated[int, Field(ge=8, le=1 << 20)] = 1024
    realizations: Annotated[int, Field(ge=1, le=100_000)] = 8
    bootstrap: Annotated[int, Field(ge=10, le=100_000)] = 1000


class IntensityMeasures(_Model):
    """Intensity measures of the ground acceleration each realisation saw (records and
    generated ground motion, over the whole duration), as columns of realizations.parquet:
    ``sa``, the pseudo-spectral acceleration at ``period`` (s) and ``damping``
    (``vines_stoch.spectra``), and ``pga``, the peak ground acceleration."""

    period: Positive
    damping: Annotated[float, Field(ge=0, lt=1, allow_inf_nan=False)] = 0.05


class Spectra(_Model):
    """Ensemble-averaged one-sided power spectral densities of signals over the metrics window
    (spectra.parquet; ``psd.py``): Welch's method on every step of each realisation, Hann
    segments of ``segment`` seconds overlapping by half (default: 15 segments in the window)."""

    signals: Annotated[list[str], Field(min_length=1)] = ["x1"]
    segment: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = None

    @model_validator(mode="after")
    def _distinct(self) -> Spectra:
        if len(set(self.signals)) != len(self.signals):
            raise FieldError("signals", self.signals, "must not repeat a signal")
        return self


class Paths(_Model):
    """Time histories of chosen realisations into paths.parquet: the signals ``signals`` on a
    grid of at least ``points`` rows over the whole path (every ``stride`` steps, as the
    history's), for the realisations ``realizations`` (indices from 0) of every sweep point."""

    realizations: Annotated[list[Annotated[int, Field(ge=0)]], Field(min_length=1, max_length=1000)] = [0]
    signals: Annotated[list[str], Field(min_length=1)] = ["x1", "e1"]
    points: Annotated[int, Field(ge=2, le=1_000_000)] = 1000

    @model_validator(mode="after")
    def _distinct(self) -> Paths:
        for key in ("realizations", "signals"):
            values = getattr(self, key)
            if len(set(values)) != len(values):
                raise FieldError(key, values, "must not repeat a value")
        return self


#: Poincare samples (one per forcing period) at the end of the window the regime is read from:
#: a periodic response repeats over them (``metrics.regimes``); the samples kept span the whole
#: metrics window (``scene.poincare_samples``), for sections and slow modulations.
REGIME_SAMPLES = 32
#: Most forcing periods a path's Poincare samples span (``[output] poincare_periods``).
MAX_POINCARE_PERIODS = 1_000_000
#: Most rows of a realisation's event log (``[output] events``).
MAX_EVENT_ROWS = 1_000_000


class Output(_Model):
    """Where results go (default ``results/<name>``), and the metrics declared beside the
    built-in ones: ``metrics`` names each ``<signal>_<reduction>``, a signal of the history's
    (``x1``, ``e1``, ``x_k``, ``v_k``, ``drift_k``, ``xa_j``, ``va_j``, ``stroke_j``, ``contact_j``,
    ``share``) reduced over the metrics window by ``peak`` (largest absolute value), ``max``,
    ``min``, ``mean`` or ``rms``: ``stroke_1_peak`` is absorber 1's largest stroke; ``energy_share_mean`` and
    ``energy_share_max`` are the absorbers' energy share's mean and peak.  Each is a column of
    realizations.parquet with its statistics in summary.parquet.  ``events``: the impacts and
    Hertz contact onsets of each realisation in the metrics window, up to this many, into
    events.parquet (time, absorber, wall, relative velocity, energy lost; 0: none kept).
    ``paths``: time histories of chosen realisations into paths.parquet (``Paths``).
    ``poincare``: the state of every body once a forcing period (the Poincare samples the
    regimes are read from) into poincare.parquet; ``poincare_periods``: how many forcing periods
    at the window's end are sampled (default: every one of the metrics window; the regime is read
    from the last ``outputs.REGIME_SAMPLES``, the envelope frequency from all).  ``lyapunov``:
    the largest Lyapunov exponent of every realisation of a periodically forced scene (without
    it, only of those whose samples do not repeat, to name their regime).  ``spectra``: the
    ensemble-averaged power spectral densities of signals over the metrics window into
    spectra.parquet (``Spectra``)."""

    directory: str | None = None
    metrics: list[str] = []
    events: Annotated[int, Field(ge=0, le=MAX_EVENT_ROWS)] = 0
    poincare: bool = False
    poincare_periods: Annotated[int, Field(ge=1, le=MAX_POINCARE_PERIODS)] | None = None
    lyapunov: bool = False
    spectra: Spectra | None = None
    paths: Paths | None = None

    @model_validator(mode="after")
    def _distinct(self) -> Output:
        if len(set(self.metrics)) != len(self.metrics):
            raise FieldError("metrics", self.metrics, "must not repeat a metric")
        return self
