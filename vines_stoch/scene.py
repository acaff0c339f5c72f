"""A validated scenario turned into the arrays a kernel reads (MODEL.md sections 1-3)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import filters
from .kernels.common import POINCARE_SAMPLES
from .kernels.loads import (CHIRP, HALF_SINE, HARMONIC, JENNINGS, PULSE_TRAIN, SARAGONI_HART, STATIONARY,
                           has_breaks)
from .scenario import (ChirpLoad, CubicAbsorber, FilteredNoiseLoad, ForceRecordLoad, GroundMotionLoad,
                       HalfSineLoad, HarmonicLoad, HertzAbsorber, ImpactAbsorber, ImpulseLoad, InitialLoad,
                       JenningsEnvelope, PulseTrainLoad, RecordLoad, Scenario, WhiteNoiseLoad)


@dataclass(frozen=True)
class Scene:
    """Numeric description of one sweep point: bodies, absorber laws, loads, time grid."""

    mass: np.ndarray          # (n_bodies,) primary first
    k1: float
    c1: float
    k_lin: np.ndarray         # (n_absorbers,) linear attachment stiffness
    k_cubic: np.ndarray       # (n_absorbers,) cubic attachment stiffness
    c_abs: np.ndarray         # (n_absorbers,) attachment damping
    rest: np.ndarray          # (n_absorbers,) rest offset of the attachment spring
    impact_body: np.ndarray   # (n_impact,) absorber index of each impact absorber
    clearance: np.ndarray     # (n_impact,)
    restitution: np.ndarray   # (n_impact,)
    hertz_body: np.ndarray    # (n_hertz,) absorber index of each Hertz absorber
    hertz_k: np.ndarray       # (n_hertz, 2) contact constants K, left and right
    hertz_walls: np.ndarray   # (n_hertz, 2) contact surfaces: z_L = lo - u, z_R = u - hi
    forces: np.ndarray        # (n_forces, 6) closed-form force rows (kernels/loads.py)
    series_t: np.ndarray      # records, concatenated: times
    series_v: np.ndarray      # values (force or ground acceleration, scaled)
    series_ptr: np.ndarray    # (n_series + 1,) offsets
    series_ground: np.ndarray  # (n_series,) 1: ground acceleration, 0: force on the primary
    filters: dict             # filter arrays (filters.block_diagonal): phi, chol, envelope, c_force, c_ground, p0
    sigma: float              # white-noise intensity, F dt = sigma dW
    x0: np.ndarray
    v0: np.ndarray
    dt: float
    n_steps: int
    i0: int                   # first step of the metrics window
    scheme: str               # "rk4" | "euler-maruyama" | "sra"
    period: float = 0.0       # forcing period of Poincare samples (0: no regime)
    sample_from: float = 0.0  # time of the first Poincare sample

    @property
    def has_noise(self) -> bool:
        """True when realisations differ (white noise or filtered noise)."""
        return self.sigma > 0.0 or self.filters["phi"].shape[0] > 0

    @property
    def excitation(self) -> tuple:
        """The kernels' tuple of closed-form loads and records (kernels/loads.py)."""
        return self.forces, self.series_t, self.series_v, self.series_ptr, self.series_ground

    @cached_property
    def kernel_flags(self) -> tuple[bool, bool]:
        """Compile-time flags of the step loops, computed once a scene: loads with kinks or
        jumps inside the run (pulses, half-sines, records: sub-steps and pieces) and ground
        acceleration (records or filtered ground motion)."""
        ground = self.series_ground.any() or self.filters["c_ground"].any()
        return bool(has_breaks(self.excitation)), bool(ground)

    @property
    def has_impact(self) -> bool:
        return self.impact_body.shape[0] > 0

    @property
    def has_hertz(self) -> bool:
        return self.hertz_body.shape[0] > 0

    @property
    def window(self) -> float:
        """Length of the metrics window."""
        return (self.n_steps - self.i0) * self.dt


def build_scene(scenario: Scenario) -> Scene:
    """Arrays of one scenario (one sweep point)."""
    absorbers = scenario.absorbers
    n = 1 + len(absorbers)
    mass = np.array([scenario.primary.mass] + [a.mass for a in absorbers], dtype=float)
    k_lin = np.zeros(n - 1)
    k_cubic = np.zeros(n - 1)
    c_abs = np.zeros(n - 1)
    rest = np.zeros(n - 1)
    impact = []
    hertz = []
    for i, a in enumerate(absorbers):
        c_abs[i] = a.damping
        if isinstance(a, CubicAbsorber):
            k_cubic[i] = a.stiffness
            k_lin[i] = a.linear_stiffness
        else:
            k_lin[i] = a.stiffness
        if isinstance(a, ImpactAbsorber):
            impact.append((i, a.clearance, a.restitution))
        if isinstance(a, HertzAbsorber):
            rest[i] = a.spring_rest
            hertz.append((i, a.contact_left.constant, a.contact_right.constant, *a.walls, a.start))
    x0 = np.zeros(n)
    v0 = np.zeros(n)
    for i, _, _, _, _, start in hertz:
        x0[i + 1] = start
    forces = []
    series = []
    filter_list = []
    variance = 0.0
    dt = float(scenario.simulation.dt)
    for load in scenario.loads:
        if isinstance(load, ImpulseLoad):
            v0[0] += load.velocity
        elif isinstance(load, InitialLoad):
            x0 += np.asarray(load.displacement or np.zeros(n), dtype=float)
            v0 += np.asarray(load.velocity or np.zeros(n), dtype=float)
        elif isinstance(load, HarmonicLoad):
            forces.append((HARMONIC, load.amplitude, load.frequency, load.phase, 0.0, 0.0))
        elif isinstance(load, HalfSineLoad):
            forces.append((HALF_SINE, load.amplitude, load.duration, load.start, 0.0, 0.0))
        elif isinstance(load, PulseTrainLoad):
            forces.append((PULSE_TRAIN, load.amplitude, load.width, load.period, load.start, load.count))
        elif isinstance(load, ChirpLoad):
            forces.append((CHIRP, load.amplitude, load.f0, load.f1, load.duration, 0.0))
        elif isinstance(load, (RecordLoad, ForceRecordLoad)):
            series.append((*load.samples(), isinstance(load, RecordLoad)))
        elif isinstance(load, WhiteNoiseLoad):
            variance += load.intensity**2
        elif isinstance(load, (FilteredNoiseLoad, GroundMotionLoad)) and load.intensity > 0:
            filter_list.append(_filter(load))
    sim = scenario.simulation
    n_steps = max(1, math.ceil(sim.duration / sim.dt - 1e-9))
    scheme = scenario.scheme
    period = sample_from = 0.0
    frequencies = [f[2] for f in forces if f[0] == HARMONIC]
    if scheme == "rk4" and len(frequencies) == 1 and frequencies[0] > 0:
        # Poincare samples at multiples of the forcing period, in the last periods of the window
        period = 2.0 * math.pi / frequencies[0]
        first = max(sim.metrics_from, n_steps * sim.dt - POINCARE_SAMPLES * period)
        sample_from = math.ceil(first / period - 1e-9) * period
    return Scene(
        mass=mass, k1=float(scenario.primary.stiffness), c1=float(scenario.primary.damping),
        k_lin=k_lin, k_cubic=k_cubic, c_abs=c_abs, rest=rest,
        impact_body=np.array([i for i, _, _ in impact], dtype=np.int64),
        clearance=np.array([c for _, c, _ in impact], dtype=float),
        restitution=np.array([r for _, _, r in impact], dtype=float),
        hertz_body=np.array([h[0] for h in hertz], dtype=np.int64),
        hertz_k=np.array([h[1:3] for h in hertz], dtype=float).reshape(-1, 2),
        hertz_walls=np.array([h[3:5] for h in hertz], dtype=float).reshape(-1, 2),
        forces=np.array(forces, dtype=float).reshape(-1, 6),
        series_t=np.concatenate([t for t, _, _ in series] or [np.zeros(0)]),
        series_v=np.concatenate([v for _, v, _ in series] or [np.zeros(0)]),
        series_ptr=np.cumsum([0] + [len(t) for t, _, _ in series]).astype(np.int64),
        series_ground=np.array([int(g) for _, _, g in series], dtype=np.int64),
        filters=filters.block_diagonal(filter_list, dt),
        sigma=math.sqrt(variance), x0=x0, v0=v0, dt=float(sim.dt), n_steps=n_steps,
        i0=min(n_steps - 1, int(round(sim.metrics_from / sim.dt))), scheme=scheme,
        period=period, sample_from=sample_from,
    )


def _filter(load: FilteredNoiseLoad | GroundMotionLoad) -> filters.Filter:
    """The linear filter of a filtered-noise or ground-motion load."""
    if isinstance(load, FilteredNoiseLoad):
        a, b, c = filters.filtered_noise(load.intensity, load.frequency, load.damping)
    elif load.model == "kanai-tajimi":
        a, b, c = filters.kanai_tajimi(load.intensity, load.ground_frequency, load.ground_damping)
    else:
        a, b, c = filters.clough_penzien(load.intensity, load.ground_frequency, load.ground_damping,
                                         load.filter_frequency, load.filter_damping)
    env = load.envelope
    if env is None:
        row = (STATIONARY, 0.0, 0.0, 0.0)
    elif isinstance(env, JenningsEnvelope):
        row = (JENNINGS, env.rise, env.hold, env.decay)
    else:
        row = (SARAGONI_HART, env.peak, env.shape, 0.0)
    return filters.Filter(a=a, b=b, c=c, ground=isinstance(load, GroundMotionLoad), envelope=row,
                          stationary=load.start == "stationary")
