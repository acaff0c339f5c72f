"""The loads: initial conditions, deterministic forces, white and filtered noise, stochastic
ground motion, wind and records (MODEL.md section 3)."""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import Field, PrivateAttr, model_validator

from ..physics.wind import BANDS, DAVENPORT_LENGTH, OPEN_COUNTRY_DRAG, VON_KARMAN, mean_speed
from ..records import G
from .errors import FieldError
from .fields import Floor, NonNegative, Positive, Real, _Model

#: Soil presets of the Clough-Penzien (and Kanai-Tajimi) filter: ground frequency and damping,
#: high-pass frequency and damping (rad/s, fraction of critical).  Der Kiureghian, A. and
#: Neuenhofer, A. (1992), "Response spectrum method for multi-support seismic excitations",
#: Earthquake Engineering and Structural Dynamics 21(8), 713-740.
SOILS = {
    "firm": (15.0, 0.6, 1.5, 0.6),
    "medium": (10.0, 0.4, 1.0, 0.6),
    "soft": (5.0, 0.2, 0.5, 0.6),
}


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
    def _order(self) -> JenningsEnvelope:
        if self.hold < self.rise:
            raise FieldError("hold", self.hold, f"must be >= rise ({self.rise:g})")
        return self


class SaragoniHartEnvelope(_Model):
    """Saragoni and Hart (1974), normalised to peak 1 at ``t = peak``:
    ``(t/peak)^shape exp(shape (1 - t/peak))``."""

    type: Literal["saragoni-hart"]
    peak: Positive
    shape: Positive


Envelope = Annotated[JenningsEnvelope | SaragoniHartEnvelope, Field(discriminator="type")]


class _FilteredLoad(_Model):
    """Shared fields of loads made by filtering white noise (``physics/filters.py``)."""

    intensity: NonNegative
    envelope: Envelope | None = None
    start: Literal["rest", "stationary"] = "rest"

    @model_validator(mode="after")
    def _stationary(self) -> _FilteredLoad:
        if self.start == "stationary" and self.envelope is not None:
            raise FieldError("start", self.start, "a stationary start needs a load without envelope")
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
    def _parameters(self) -> GroundMotionLoad:
        preset = SOILS.get(self.soil, (None,) * 4)
        names = ["ground_frequency", "ground_damping"]
        if self.model == "clough-penzien":
            names += ["filter_frequency", "filter_damping"]
        for name, value in zip(["ground_frequency", "ground_damping", "filter_frequency", "filter_damping"],
                               preset):
            if getattr(self, name) is None:
                setattr(self, name, value)
        for name in names:
            if getattr(self, name) is None:
                raise FieldError(name, None, "missing: give it or a soil preset (firm, medium, soft)")
        return self


class WindLoad(_Model):
    """Along-wind load on every floor (seed 001 section 3.7; ``vines_stoch.wind``): mean force
    ``0.5 density drag A_k U(z_k)^2`` and turbulent force ``density drag A_k U(z_k) u(t)``, the
    turbulence ``u(t)`` fully correlated over the height with a Davenport or Kaimal spectrum,
    realised by a rational filter of white noise; the envelope scales the turbulence only."""

    type: Literal["wind"]
    speed: Positive
    reference_height: Positive = 10.0
    profile: Literal["power", "log"] = "power"
    exponent: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] = 0.16
    roughness: Positive = 0.05
    height: Positive | None = None
    heights: list[Positive] | None = None
    area: NonNegative | None = None
    areas: list[NonNegative] | None = None
    drag: Positive
    density: Positive = 1.25
    spectrum: Literal["davenport", "kaimal"] = "davenport"
    surface_drag: Positive | None = None
    friction_velocity: Positive | None = None
    band: Annotated[list[Positive], Field(min_length=2, max_length=2)] | None = None
    order: Literal[2, 3] = 3
    envelope: Envelope | None = None
    start: Literal["rest", "stationary"] = "rest"

    @model_validator(mode="after")
    def _choices(self) -> WindLoad:
        pairs = (("height", "heights", "storey heights (m)"), ("area", "areas", "tributary areas"))
        for one, many, what in pairs:
            if (getattr(self, one) is None) == (getattr(self, many) is None):
                raise FieldError(one, getattr(self, one), f"give either {one} (every floor) or {many} = "
                                 f"[...] (the {what}, floors from the lowest), one of the two")
        if self.roughness >= self.reference_height:
            raise FieldError("roughness", self.roughness,
                             f"must be < reference_height ({self.reference_height:g})")
        if self.spectrum == "davenport" and self.profile == "log" and self.roughness >= 10.0:
            raise FieldError("roughness", self.roughness,
                             "must be < 10 m (Davenport's spectrum takes the speed at 10 m)")
        if self.surface_drag is not None and self.spectrum != "davenport":
            raise FieldError("surface_drag", self.surface_drag,
                             "is Davenport's kappa: only with spectrum = 'davenport'")
        if self.friction_velocity is not None and self.spectrum != "kaimal":
            raise FieldError("friction_velocity", self.friction_velocity, "only with spectrum = 'kaimal'")
        if self.band is not None and not self.band[0] < self.band[1]:
            raise FieldError("band", self.band, "must be [low, high] in Hz with low < high")
        if self.start == "stationary" and self.envelope is not None:
            raise FieldError("start", self.start, "a stationary start needs a load without envelope")
        return self

    def floors_error(self, n: int) -> tuple[str, object, str] | None:
        """``(key, value, rule)`` when the lists do not fit a primary of ``n`` floors (or a
        floor lies below the log profile's roughness), else None."""
        for name in ("heights", "areas"):
            values = getattr(self, name)
            if values is not None and len(values) != n:
                return name, values, f"must list {n} values (one per floor, from the lowest)"
        lowest = self.floor_heights(n)[0]
        if self.profile == "log" and lowest <= self.roughness:
            return "roughness", self.roughness, f"must be below the lowest floor ({lowest:g} m)"
        return None

    def floor_heights(self, n: int) -> np.ndarray:
        """Heights ``z_k`` of the ``n`` floors above the ground (sums of the storey heights)."""
        return np.cumsum(self.heights if self.heights is not None else [self.height] * n, dtype=float)

    def floor_areas(self, n: int) -> np.ndarray:
        """Tributary areas ``A_k`` of the ``n`` floors."""
        return np.array(self.areas if self.areas is not None else [self.area] * n, dtype=float)

    def speeds(self, z: np.ndarray) -> np.ndarray:
        """Mean speed ``U(z)`` of the profile (``wind.mean_speed``)."""
        return mean_speed(z, self.speed, self.reference_height, self.profile, self.exponent, self.roughness)

    def turbulence(self) -> tuple[float, float]:
        """``(sigma_u^2, T)``: the target variance of ``u`` and the spectrum's time scale:
        Davenport ``6 kappa U10^2`` and ``1200 / U10``; Kaimal ``6 u*^2`` and ``z_ref / U_ref``
        (``u* = 0.4 U_ref / ln(z_ref / z0)`` unless given)."""
        if self.spectrum == "davenport":
            u10 = float(self.speeds(np.array([10.0]))[0])
            kappa = OPEN_COUNTRY_DRAG if self.surface_drag is None else self.surface_drag
            return 6.0 * kappa * u10**2, DAVENPORT_LENGTH / u10
        ustar = self.friction_velocity
        if ustar is None:
            ustar = VON_KARMAN * self.speed / np.log(self.reference_height / self.roughness)
        return 6.0 * float(ustar) ** 2, self.reference_height / self.speed

    def fit_band(self) -> tuple[float, float]:
        """The band (Hz) the rational spectrum is fitted over: ``band``, or the spectrum's
        default band of reduced frequency (``wind.BANDS``) over ``T``."""
        if self.band is not None:
            return float(self.band[0]), float(self.band[1])
        time_scale = self.turbulence()[1]
        lo, hi = BANDS[self.spectrum]
        return lo / time_scale, hi / time_scale


class HalfSineLoad(_Model):
    """``F = amplitude sin(pi (t - start) / duration)`` for ``start <= t <= start + duration``."""

    type: Literal["half-sine"]
    amplitude: Real
    duration: Positive
    start: NonNegative = 0.0
    floor: Floor | None = None


class BlastLoad(_Model):
    """Friedlander blast pulse, ``F = amplitude (1 - s) exp(-decay s)`` with
    ``s = (t - start) / duration`` for ``t >= start``, else 0 (MODEL.md section 3): the peak
    overpressure force ``Ps``, the positive phase ``Td`` and the decay coefficient ``b``; on one
    floor, or on every floor scaled by ``scales`` (one per floor, from the lowest)."""

    type: Literal["blast"]
    amplitude: Real
    duration: Positive
    decay: NonNegative
    start: NonNegative = 0.0
    floor: Floor | None = None
    scales: Annotated[list[Real], Field(min_length=1)] | None = None

    @model_validator(mode="after")
    def _one_way(self) -> BlastLoad:
        if self.scales is not None and self.floor is not None:
            raise FieldError("scales", self.scales, "give either floor or scales (one per floor), not both")
        return self


class BaseHarmonicLoad(_Model):
    """Harmonic ground acceleration ``a_g = amplitude cos(frequency t + phase)`` (m/s^2; frequency
    in rad/s) acting on every body through its mass (MODEL.md section 3)."""

    type: Literal["base-harmonic"]
    amplitude: Real
    frequency: NonNegative
    phase: Real = 0.0


class PulseTrainLoad(_Model):
    """``F = amplitude`` while ``(t - start) mod period < width`` (``t >= start``), for ``count``
    pulses (0: no end)."""

    type: Literal["pulse-train"]
    amplitude: Real
    width: Positive
    period: Positive
    start: NonNegative = 0.0
    count: Annotated[int, Field(ge=0, le=2**31 - 1)] = 0
    floor: Floor | None = None

    @model_validator(mode="after")
    def _width(self) -> PulseTrainLoad:
        if self.width > self.period:
            raise FieldError("width", self.width, f"must be <= period ({self.period:g})")
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

    @property
    def factor(self) -> float:
        """The record's scale."""
        return self.scale

    def samples(self) -> tuple[np.ndarray, np.ndarray]:
        """Times and values in scenario units (scale and units applied)."""
        if self._times is None:
            raise RuntimeError(f"record {self.file!r} was not read (use load_scenario)")
        units = G if getattr(self, "units", "m/s2") == "g" else 1.0
        return self._times, self._values * (self.factor * units)


class SpectralTarget(_Model):
    """Scale a record so that its pseudo-spectral acceleration ``Sa(period, damping)`` is
    ``value`` (in the record's units; ``vines_stoch.spectra``)."""

    period: Positive
    damping: Annotated[float, Field(ge=0, lt=1, allow_inf_nan=False)] = 0.05
    value: Positive


class RecordLoad(_RecordLoad):
    """Ground acceleration record (base excitation: every mass gets ``-m a_g``); ``sa`` scales
    it to a spectral acceleration instead of by ``scale``."""

    type: Literal["record"]
    units: Literal["g", "m/s2"]
    sa: SpectralTarget | None = None

    @model_validator(mode="after")
    def _one_scale(self) -> RecordLoad:
        if self.sa is not None and self.scale != 1.0:
            raise FieldError("scale", self.scale, "give scale or sa, not both (sa sets the scale)")
        return self

    @property
    def factor(self) -> float:
        """The record's scale: ``scale``, or ``sa.value / Sa`` of the record as read."""
        if self.sa is None:
            return self.scale
        from ..physics.spectra import pseudo_acceleration, uniform

        if self._times is None:
            raise RuntimeError(f"record {self.file!r} was not read (use load_scenario)")
        values, dt = uniform(self._times, self._values)
        sa = pseudo_acceleration(values, dt, self.sa.period, self.sa.damping)
        if sa <= 0.0:
            raise ValueError(f"record {self.file!r}: Sa({self.sa.period:g} s) is 0; it cannot be scaled to a "
                             "spectral acceleration")
        return self.sa.value / sa


class ForceRecordLoad(_RecordLoad):
    """Force record acting on a floor (default the roof; scenario force units)."""

    type: Literal["force-record"]
    floor: Floor | None = None


Load = Annotated[
    ImpulseLoad | InitialLoad | HarmonicLoad | WhiteNoiseLoad | FilteredNoiseLoad | GroundMotionLoad
    | WindLoad | HalfSineLoad | PulseTrainLoad | ChirpLoad | RecordLoad | ForceRecordLoad | BlastLoad
    | BaseHarmonicLoad,
    Field(discriminator="type"),
]


def draws_filter_noise(load: object) -> bool:
    """True for a load realised by a filter of white noise that draws random numbers: filtered
    noise and ground motion of intensity > 0, wind."""
    return (isinstance(load, _FilteredLoad) and load.intensity > 0) or isinstance(load, WindLoad)
