"""A validated scenario turned into the arrays a kernel reads (MODEL.md sections 1-3)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .outputs import ACC_MAX_K, DRIFT_MAX_K, LIMIT_E1, X_MAX_K
from .physics import filters, wind
from .physics.absorbers import (
    COLUMNS,
    HERTZ,
    IMPACT,
    LAWS,
    ROW,
    SHAPED,
)
from .physics.loads import (
    BLAST,
    CHIRP,
    FLOOR,
    FORCE_ROW,
    GROUND,
    HALF_SINE,
    HARMONIC,
    JENNINGS,
    PULSE_TRAIN,
    SARAGONI_HART,
    STATIONARY,
)
from .scenario import (
    BaseHarmonicLoad,
    BlastLoad,
    ChirpLoad,
    FilteredNoiseLoad,
    ForceRecordLoad,
    GroundMotionLoad,
    HalfSineLoad,
    HarmonicLoad,
    HertzAbsorber,
    ImpulseLoad,
    InitialLoad,
    JenningsEnvelope,
    PulseTrainLoad,
    RecordLoad,
    Scenario,
    WhiteNoiseLoad,
    WindLoad,
)
from .scenario.settings import REGIME_SAMPLES
from .signals import declare_metrics


@dataclass(frozen=True)
class Scene:
    """Numeric description of one sweep point: bodies, absorber laws, loads, time grid.

    Bodies are the floors (lowest first, the roof last) and then the absorbers (MODEL.md 1a).
    """

    mass: np.ndarray          # (n_bodies,) floors first
    storey_k: np.ndarray      # (n_floors,) storey springs, storey k joins floor k-1 (ground) to k
    storey_c: np.ndarray      # (n_floors,) storey dashpots
    floor_c: np.ndarray       # (n_floors,) mass-proportional (Rayleigh) dashpots to the ground
    kind: np.ndarray          # (n_absorbers,) law of each absorber (physics.absorbers.LAWS)
    host: np.ndarray          # (n_absorbers,) host floor (body index) of each absorber
    rows: np.ndarray          # (n_absorbers, physics.ROW) parameter rows
    wall: np.ndarray          # (n_absorbers,) body holding each absorber's walls: its host floor, or the
                              # absorber whose cavity holds it (physics.structure.wall_of)
    forces: np.ndarray        # (n_forces, loads.FORCE_ROW) closed-form force rows (kernels/loads.py)
    series_t: np.ndarray      # records, concatenated: times
    series_v: np.ndarray      # values (force or ground acceleration, scaled)
    series_ptr: np.ndarray    # (n_series + 1,) offsets
    series_target: np.ndarray  # (n_series,) floor of a force record, loads.GROUND for a ground acceleration
    filters: dict             # filter arrays (filters.block_diagonal): phi, chol, envelope, c_force,
                              # c_ground, p0
    sigma: np.ndarray         # (n_floors,) white-noise intensity on each floor, F dt = sigma dW
    x0: np.ndarray
    v0: np.ndarray
    dt: float
    n_steps: int
    i0: int                   # first step of the metrics window
    scheme: str               # a name of schemes.SCHEMES
    period: float = 0.0       # forcing period of Poincare samples (0: no regime)
    sample_from: float = 0.0  # time of the first Poincare sample
    n_samples: int = 0        # Poincare samples a path keeps, one a forcing period from sample_from
    limits: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # (n_limits, 3) rows: limit_row
    limit_names: tuple[str, ...] = ()      # the limits' names, in the rows' order
    reductions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int64))  # declared metrics:
    # rows (code, index, reduction) of signals.declare_metrics, after the limits in the metric vector
    metric_names: tuple[str, ...] = ()     # the declared metrics' names, in the rows' order
    event_rows: int = 0       # rows of a realisation's event log ([output] events; 0: none kept)
    poincare: bool = False    # Poincare samples into poincare.parquet ([output] poincare)
    lyapunov: bool = False    # the largest Lyapunov exponent of every realisation ([output] lyapunov)
    heights: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (n_floors,) storey heights
    # (m; none: no drift ratios)
    im_period: float = 0.0    # period (s) and damping of the sa column ([intensity_measures]; 0: none)
    im_damping: float = 0.05

    @property
    def n_floors(self) -> int:
        return self.storey_k.shape[0]

    @property
    def has_noise(self) -> bool:
        """True when realisations differ (white noise or filtered noise)."""
        return self.has_white_noise or self.has_filters

    @property
    def has_white_noise(self) -> bool:
        return bool(self.sigma.any())

    @property
    def has_filters(self) -> bool:
        return self.filters["phi"].shape[0] > 0

    @property
    def noisy_floors(self) -> int:
        """Floors with white noise: the normals a step draws (per integral of the scheme)."""
        return int(np.count_nonzero(self.sigma))

    @property
    def excitation(self) -> tuple:
        """The kernels' tuple of closed-form loads and records (kernels/loads.py)."""
        return self.forces, self.series_t, self.series_v, self.series_ptr, self.series_target

    @cached_property
    def has_ground(self) -> bool:
        """The loads include a ground acceleration (records, filtered ground motion, base-harmonic
        rows): a compile-time flag of the step loops, looked up once a scene, not once a
        realisation."""
        return bool((self.series_target == GROUND).any() or self.filters["c_ground"].any()
                    or (self.forces[:, FLOOR] == GROUND).any())

    @property
    def has_impact(self) -> bool:
        return bool((self.kind == IMPACT).any())

    @property
    def has_hertz(self) -> bool:
        return bool((self.kind == HERTZ).any())

    @property
    def has_partners(self) -> bool:
        """True when an impact absorber meets the walls of another absorber's cavity rather
        than its host floor's (``impacts_with``: a compile-time flag of the step loops)."""
        return bool((self.wall != self.host).any())

    @cached_property
    def has_shaped(self) -> bool:
        """True when an absorber has a shaped spring (``physics.absorbers.SHAPED``: a geometric
        attachment, a gap spring)."""
        return bool((self.rows[:, SHAPED] != 0.0).any())

    @property
    def window(self) -> float:
        """Length of the metrics window."""
        return (self.n_steps - self.i0) * self.dt


def absorber_row(a) -> np.ndarray:
    """The parameter row of one absorber (columns ``physics.absorbers.COLUMNS``, named by the
    absorber's ``parameters``; zero where its law has none)."""
    row = np.zeros(ROW)
    for name, value in a.parameters().items():
        row[COLUMNS[name]] = value
    return row


def limit_row(metric: str, value: float, n_floors: int, heights=()) -> tuple[float, float, float]:
    """A limit's row for the kernels' first-passage check: the running peak it watches
    (``kernels.common.first_passages``: a per-floor block's code or ``LIMIT_E1``), the floor
    (body index) and the value (a drift ratio's: the storey's drift, ``value h_k``)."""
    if metric == "e1_max":
        return LIMIT_E1, 0, value
    if metric == "x1_max":
        return X_MAX_K, n_floors - 1, value
    name, floor = metric.rsplit("_", 1)
    if name == "drift_ratio_max":
        return DRIFT_MAX_K, int(floor) - 1, value * heights[int(floor) - 1]
    codes = {"x_max": X_MAX_K, "drift_max": DRIFT_MAX_K, "acc_max": ACC_MAX_K}
    return codes[name], int(floor) - 1, value


#: The loads made of closed-form rows (``closed_form_rows``; wind's mean force too).
CLOSED_FORM = (HarmonicLoad, HalfSineLoad, PulseTrainLoad, ChirpLoad, BlastLoad, BaseHarmonicLoad)


def closed_form_rows(load, k: int, n_floors: int, mean: np.ndarray | None = None) -> list[tuple]:
    """The closed-form rows (``physics.loads.FORCE_ROW`` columns: kind, amplitude, parameters,
    floor) that ``load`` on floor index ``k`` adds to ``Scene.forces``: one for each closed-form
    load, one a floor a blast's ``scales`` load, and for wind one a floor with a mean force (a
    harmonic row of frequency 0; ``mean``: the floors' mean forces, ``wind_load``); none for
    other loads."""
    if isinstance(load, HarmonicLoad):
        return [(HARMONIC, load.amplitude, load.frequency, load.phase, 0.0, 0.0, k)]
    if isinstance(load, BaseHarmonicLoad):
        return [(HARMONIC, load.amplitude, load.frequency, load.phase, 0.0, 0.0, GROUND)]
    if isinstance(load, HalfSineLoad):
        return [(HALF_SINE, load.amplitude, load.duration, load.start, 0.0, 0.0, k)]
    if isinstance(load, PulseTrainLoad):
        return [(PULSE_TRAIN, load.amplitude, load.width, load.period, load.start, load.count, k)]
    if isinstance(load, ChirpLoad):
        return [(CHIRP, load.amplitude, load.f0, load.f1, load.duration, 0.0, k)]
    if isinstance(load, BlastLoad):
        scales = [(k, 1.0)] if load.scales is None else enumerate(load.scales)
        return [(BLAST, s * load.amplitude, load.duration, load.decay, load.start, 0.0, j)
                for j, s in scales if s != 0.0]
    if isinstance(load, WindLoad):
        mean = wind_load(load, n_floors)[0] if mean is None else mean
        return [(HARMONIC, f, 0.0, 0.0, 0.0, 0.0, j) for j, f in enumerate(mean) if f != 0.0]
    return []


def poincare_samples(scheme: str, forces, metrics_from: float, n_steps: int, dt: float,
                     periods: int | None = None) -> tuple[float, float, int]:
    """``(period, sample_from, count)`` of a scene's Poincare samples, at the multiples of the
    forcing period in the metrics window before its end (the last ``periods`` of them where
    given, ``[output] poincare_periods``; at least ``REGIME_SAMPLES`` where the window holds
    them; at least one, left NaN, where it holds none): rk4 under one harmonic force row
    (``forces``) of frequency > 0; ``(0, 0, 0)`` otherwise."""
    frequencies = [f[2] for f in forces if f[0] == HARMONIC]
    if not (scheme == "rk4" and len(frequencies) == 1 and frequencies[0] > 0):
        return 0.0, 0.0, 0
    period, end = 2.0 * math.pi / frequencies[0], n_steps * dt
    first = metrics_from if periods is None else max(metrics_from,
                                                     end - max(periods, REGIME_SAMPLES) * period)
    sample_from = math.ceil(first / period - 1e-9) * period
    count = max(1, math.floor((end - sample_from) / period - 1e-9) + 1)  # (one slot, NaN, past the end)
    return period, sample_from, count


def build_scene(scenario: Scenario) -> Scene:
    """Arrays of one scenario (one sweep point)."""
    absorbers = scenario.absorbers
    primary = scenario.primary
    nf = primary.n_floors
    roof = nf - 1
    n = nf + len(absorbers)

    def floor_of(item) -> int:
        return roof if getattr(item, "floor", None) is None else item.floor - 1

    mass = np.array(primary.floor_masses + [a.mass for a in absorbers], dtype=float)
    storey_c, floor_c = primary.damping_matrices()
    x0 = np.zeros(n)
    v0 = np.zeros(n)
    for i, a in enumerate(absorbers):
        if isinstance(a, HertzAbsorber):
            x0[nf + i] = a.start
    forces = []
    series = []
    variance = np.zeros(nf)
    dt = float(scenario.simulation.dt)
    for load in scenario.loads:
        k = floor_of(load)
        if isinstance(load, ImpulseLoad):
            v0[k] += load.velocity
        elif isinstance(load, InitialLoad):
            x0 += np.asarray(load.displacement or np.zeros(n), dtype=float)
            v0 += np.asarray(load.velocity or np.zeros(n), dtype=float)
        elif isinstance(load, CLOSED_FORM):
            forces += closed_form_rows(load, k, nf)
        elif isinstance(load, (RecordLoad, ForceRecordLoad)):
            series.append((*load.samples(), GROUND if isinstance(load, RecordLoad) else k))
        elif isinstance(load, WhiteNoiseLoad):
            variance[k] += load.intensity**2
        elif isinstance(load, WindLoad):
            forces += closed_form_rows(load, k, nf)
    sim = scenario.simulation
    n_steps = max(1, math.ceil(sim.duration / sim.dt - 1e-9))
    scheme = scenario.scheme
    period, sample_from, n_samples = poincare_samples(scheme, forces, sim.metrics_from, n_steps, sim.dt,
                                                      scenario.output.poincare_periods)
    return Scene(
        mass=mass, storey_k=np.array(primary.storey_stiffnesses, dtype=float),
        storey_c=np.array(storey_c, dtype=float), floor_c=np.array(floor_c, dtype=float),
        kind=np.array([LAWS[a.type] for a in absorbers], dtype=np.int64),
        host=np.array([floor_of(a) for a in absorbers], dtype=np.int64),
        wall=np.array([floor_of(a) if getattr(a, "impacts_with", None) is None else nf + a.impacts_with - 1
                       for a in absorbers], dtype=np.int64),
        rows=np.array([absorber_row(a) for a in absorbers], dtype=float).reshape(-1, ROW),
        forces=np.array(forces, dtype=float).reshape(-1, FORCE_ROW),
        series_t=np.concatenate([t for t, _, _ in series] or [np.zeros(0)]),
        series_v=np.concatenate([v for _, v, _ in series] or [np.zeros(0)]),
        series_ptr=np.cumsum([0] + [len(t) for t, _, _ in series]).astype(np.int64),
        series_target=np.array([g for _, _, g in series], dtype=np.int64),
        filters=filters.block_diagonal(scene_filters(scenario), dt, nf),
        sigma=np.sqrt(variance), x0=x0, v0=v0, dt=float(sim.dt), n_steps=n_steps,
        i0=min(n_steps - 1, int(round(sim.metrics_from / sim.dt))), scheme=scheme,
        period=period, sample_from=sample_from, n_samples=n_samples,
        limits=np.array([limit_row(limit.metric, limit.value, nf, primary.heights or ())
                         for limit in scenario.limits.values()],
                        dtype=float).reshape(-1, 3),
        limit_names=tuple(scenario.limits),
        reductions=declare_metrics(scenario.output.metrics, nf, len(absorbers)),
        metric_names=tuple(scenario.output.metrics),
        event_rows=scenario.output.events,
        heights=np.array(primary.heights or [], dtype=float),
        poincare=scenario.output.poincare, lyapunov=scenario.output.lyapunov,
        **({"im_period": scenario.intensity_measures.period,
            "im_damping": scenario.intensity_measures.damping}
           if scenario.intensity_measures else {}),
    )


def scene_filters(scenario: Scenario) -> list[filters.Filter]:
    """The linear filters of a scenario's filtered loads, in file order: filtered noise, ground
    motion (those of zero intensity left out) and wind turbulence (MODEL.md section 3)."""
    roof = scenario.primary.n_floors - 1
    out = []
    for load in scenario.loads:
        if isinstance(load, (FilteredNoiseLoad, GroundMotionLoad)) and load.intensity > 0:
            out.append(_filter(load, roof if getattr(load, "floor", None) is None else load.floor - 1))
        elif isinstance(load, WindLoad):
            out.append(wind_load(load, scenario.primary.n_floors)[1])
    return out


def wind_load(load: WindLoad, n_floors: int) -> tuple[np.ndarray, filters.Filter]:
    """The mean force on each floor, ``0.5 rho Cd A_k U(z_k)^2``, and the turbulence filter
    whose read-out on floor ``k`` is ``rho Cd A_k U(z_k) u(t)`` (``vines_stoch.wind``)."""
    speeds = load.speeds(load.floor_heights(n_floors))
    weight = load.density * load.drag * load.floor_areas(n_floors) * speeds
    variance, time_scale = load.turbulence()
    a, b, c, _ = wind.turbulence_filter(load.spectrum, variance, time_scale, load.fit_band(), load.order)
    turbulence = filters.Filter(a=a, b=b, c=c, ground=False, envelope=_envelope_row(load.envelope),
                                stationary=load.start == "stationary", profile=weight)
    return 0.5 * weight * speeds, turbulence


def _envelope_row(env) -> tuple:
    """A filter's envelope row (``kernels/loads.py``): stationary, Jennings or Saragoni-Hart."""
    if env is None:
        return (STATIONARY, 0.0, 0.0, 0.0)
    if isinstance(env, JenningsEnvelope):
        return (JENNINGS, env.rise, env.hold, env.decay)
    return (SARAGONI_HART, env.peak, env.shape, 0.0)


def _filter(load: FilteredNoiseLoad | GroundMotionLoad, floor: int) -> filters.Filter:
    """The linear filter of a filtered-noise or ground-motion load."""
    if isinstance(load, FilteredNoiseLoad):
        a, b, c = filters.filtered_noise(load.intensity, load.frequency, load.damping)
    elif load.model == "kanai-tajimi":
        a, b, c = filters.kanai_tajimi(load.intensity, load.ground_frequency, load.ground_damping)
    else:
        a, b, c = filters.clough_penzien(load.intensity, load.ground_frequency, load.ground_damping,
                                         load.filter_frequency, load.filter_damping)
    row = _envelope_row(load.envelope)
    return filters.Filter(a=a, b=b, c=c, ground=isinstance(load, GroundMotionLoad), envelope=row,
                          stationary=load.start == "stationary", floor=floor)
