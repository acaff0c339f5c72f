"""The accuracy guard, beside the stability check: a ``dt`` that is stable but coarse for what
the scene contains, and realisations that would all be the same.  Each finding is one warning
line (``Study.warnings``); nothing is refused.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from ..notices import CoarseStepWarning, IdenticalRealizationsWarning, Notice
from .bodies import ImpactAbsorber
from .errors import format_error
from .loads import (
    BaseHarmonicLoad,
    BlastLoad,
    ChirpLoad,
    FilteredNoiseLoad,
    GroundMotionLoad,
    HalfSineLoad,
    HarmonicLoad,
    WindLoad,
)
from .model import Scenario

#: A scene's time scales: ``(omega, what)`` pairs.
Scales = Callable[[Scenario], list[tuple[float, str]]]

#: Steps a period below which ``dt`` is coarse: for the highest mode, a forcing or a filter's
#: fastest pole (RK4 at 20 steps a period loses 3e-4 of an undamped oscillator's energy a
#: period and 5e-4 rad of its phase; at 2.5 steps, 97 % of its energy a period).
STEPS_PER_PERIOD = 20

#: Steps a period of the dominant motion (the primary's fundamental mode, a forcing) below
#: which ``dt`` is coarse for impact absorbers: an impact slower than the relative velocity the
#: loads add in one step is plastic (sticking), and that speed is about ``omega dt`` of the
#: motion's speed scale, 6 % at 100 steps a period.
IMPACT_STEPS_PER_PERIOD = 100


def _pole(frequency: float, damping: float) -> float:
    """Magnitude of the fastest pole of ``y'' + 2 damping frequency y' + frequency^2 y`` (rad/s)."""
    return frequency * (damping + math.sqrt(damping**2 - 1.0)) if damping > 1.0 else frequency


def load_frequencies(scenario: Scenario) -> list[tuple[float, str]]:
    """The fastest angular frequency (rad/s) of each load that has one, with what it is: a
    harmonic's frequency, a chirp's highest, a half-sine's (period twice its duration), the
    fastest pole of a filter of noise, the upper end of a wind filter's band."""
    found = []
    for i, load in enumerate(scenario.loads):
        if isinstance(load, (HarmonicLoad, BaseHarmonicLoad)):
            omega, what = load.frequency, "harmonic forcing"
        elif isinstance(load, ChirpLoad):
            omega, what = 2.0 * math.pi * max(load.f0, load.f1), "chirp's highest frequency"
        elif isinstance(load, HalfSineLoad):
            omega, what = math.pi / load.duration, "half-sine (a period twice its duration)"
        elif isinstance(load, BlastLoad):
            omega, what = math.pi / load.duration, "blast (a period twice its positive phase)"
        elif isinstance(load, FilteredNoiseLoad):
            omega, what = _pole(load.frequency, load.damping), "filter's fastest pole"
        elif isinstance(load, GroundMotionLoad):
            poles = [_pole(load.ground_frequency, load.ground_damping)]
            if load.model == "clough-penzien":
                poles.append(_pole(load.filter_frequency, load.filter_damping))
            omega, what = max(poles), "filter's fastest pole"
        elif isinstance(load, WindLoad):
            omega, what = 2.0 * math.pi * load.fit_band()[1], "filter band's upper end"
        else:
            continue
        if omega > 0.0:
            found.append((omega, f"loads.{i} ({what})"))
    return found


def _coarsest(points: list[Scenario], scales: Scales) -> tuple[float, str, int] | None:
    """``(omega dt, what, point)`` of the time scale with the fewest steps a period over the
    sweep points, or None."""
    worst = None
    for p, point in enumerate(points):
        for omega, what in scales(point):
            ratio = omega * point.simulation.dt
            if worst is None or ratio > worst[0]:
                worst = (ratio, f"{what}, {omega:.4g} rad/s", p)
    return worst


def _coarse(source: str, points: list[Scenario], grid: list[dict[str, Any]], scales: Scales, steps: int,
            topic: str, why: str) -> list[str]:
    """The warning when the time scale with the fewest steps a period (``_coarsest``) has fewer
    than ``steps``: ``topic`` says for what, ``why`` (formatted with ``ratio``, ``omega dt``)
    what goes wrong."""
    worst = _coarsest(points, scales)
    if worst is None or worst[0] <= 2.0 * math.pi / steps:
        return []
    ratio, what, p = worst
    dt, have = points[p].simulation.dt, 2.0 * math.pi / worst[0]
    where = f"{source} (sweep point {grid[p]})" if grid[p] else source
    return [format_error(where, "simulation.dt", dt,
                         f"coarse{topic}: {have:.3g} steps a period of {what}; {why.format(ratio=ratio)}: "
                         f"use dt <= {dt * have / steps:.3g} ({steps} steps a period) or less")]


def _modes(scenario: Scenario) -> list[tuple[float, str]]:
    """The highest mode and the loads' frequencies."""
    return [(scenario.highest_frequency(), "the highest mode")] + load_frequencies(scenario)


def _dominant(scenario: Scenario) -> list[tuple[float, str]]:
    """With impact absorbers: the primary's fundamental mode and the loads' frequencies."""
    if not any(isinstance(a, ImpactAbsorber) for a in scenario.absorbers):
        return []
    return [(float(scenario.primary.frequencies()[0]), "the primary's fundamental mode")] + \
        load_frequencies(scenario)


def warnings(source: str, points: list[Scenario], grid: list[dict[str, Any]],
             realizations: int) -> list[Notice]:
    """The accuracy guard's warnings on the validated sweep ``points`` (their values in ``grid``)
    of the file ``source`` that asks for ``realizations`` each, one line each (with its category:
    ``notices``)."""
    found = _coarse(source, points, grid, _modes, STEPS_PER_PERIOD, "",
                    "results (energy balance, peaks, EDM) may be wrong without other sign")
    found += _coarse(source, points, grid, _dominant, IMPACT_STEPS_PER_PERIOD, " for impact absorbers",
                     "an impact slower than the relative velocity the loads add in one step (about "
                     "omega dt = {ratio:.2g} of the speed scale) is plastic and starts sticking, so chatter "
                     "ends sooner and 'impacts' counts fewer")
    found = [Notice(line, CoarseStepWarning) for line in found]
    if realizations > 1 and not any(p.is_random for p in points):
        found.append(Notice(format_error(
            source, "ensemble.realizations", realizations,
            "the scene has neither noise nor uncertain parameters, so every realisation would be the "
            "same: one runs a sweep point"), IdenticalRealizationsWarning))
    return found
