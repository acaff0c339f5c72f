"""Dynamics of a realisation: its largest Lyapunov exponent, the envelope frequency of its
motion, and the regime classes of a periodically forced response built on them.

``largest_lyapunov``: two nearby trajectories with renormalisation (Benettin, Galgani,
Giorgilli and Strelcyn, Meccanica 15 (1980) 9, DOI 10.1007/BF02128236).  A reference path and a
companion displaced from it by ``d0`` in the state run side by side through the metrics window,
in stretches of one forcing period (``kernels.start_path``, ``Path.branch``, ``kernels.advance``:
the step loop the ensemble runs, impacts, sticking and contact included); after each stretch
the companion's distance ``d`` from the reference is measured, ``ln(d / d0)`` is added up, and
the companion is put back at ``d0`` along the same direction.  The exponent is the sum over the
time run.  The state is every body's displacement and velocity over the forcing frequency (the
Poincare sections' scaling, ``metrics.regimes``), so that both have the same unit; the limit does
not depend on the norm, and with this one a damped linear oscillator's estimate stays within
``ln((1 + zeta) / (1 - zeta)) / window`` of ``-zeta omega`` (``tests/unit/statistics/
test_dynamics.py``).  Non-smooth flows: both trajectories go through the same step loop, so an
impact that one meets a little before the other shows as the jump in their distance that the
saltation matrix of the variational method would give (Muller, Chaos Solitons Fractals 5 (1995)
1671, DOI 10.1016/0960-0779(94)00170-U), as long as ``d0`` is small.

``refine_regimes``: the Poincare samples name a periodic response ``nT,k,m`` (``metrics.regimes``);
one whose samples do not repeat over the last ``REGIME_SAMPLES`` forcing periods is
``transient`` when they repeat over at least their last half (with its ``settling_time``, the
first sample of the repeating tail) or when two nearby trajectories converge over the window
faster than a regular response lets them (still settling past the window), ``chaotic`` when its
largest Lyapunov exponent grows a distance over the window faster than a regular response can
(``GROWTH_POWER``), ``modulated``
when its envelope oscillates (``envelope_frequency``, read from the samples), ``chatter`` when
it is irregular but neither, with impacts (the near-periodic impacting motion seed 002 calls
chatter, Lizunov, Pogorelova and Postnikova 2023, Table 2 and Fig. 6), and ``modulated``
without impacts.

``envelope_frequency``: the modulus of the analytic signal (``scipy.signal.hilbert``) is the
envelope of an amplitude-modulated response, with a ripple at twice the fast frequency that an
average over one fast period takes out (in a run the envelope is read once a forcing period,
from the Poincare samples over the whole window, and has none); less its mean, it crosses zero
upward once a slow cycle, counted where it goes on to rise past ``HYSTERESIS`` standard
deviations after falling as far (the relaxation cycles of a strongly modulated response
wobble near their mean); the least-squares spacing of those crossings gives the envelope's
angular frequency.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.signal import hilbert

from .kernels import Path, advance, start_path
from .metrics import regimes
from .scenario.settings import REGIME_SAMPLES
from .scene import Scene
from .streams import Streams

#: Initial distance of the companion trajectory, relative to the state's size at the window's
#: start: far above rounding (1e-16), far below the motion's scale.
D0 = 1e-8
#: Part of a signal left out at each end of ``envelope_frequency`` (the Hilbert transform's
#: edge effects: scipy's transform takes the record as periodic).
EDGE = 0.1
#: Least modulation depth ``envelope_frequency`` reads as modulation: the envelope's range over
#: its mean (the edge effects leave a ripple of about ``1 / (pi omega s)`` at a distance ``s``).
DEPTH = 0.05
#: The marks (in standard deviations of the envelope about its mean) an envelope must pass,
#: below then above, between two upward crossings of its mean that ``crossing_frequency``
#: counts as a cycle apart.
HYSTERESIS = 0.5
#: A response is chaotic when its companion's distance grows over the metrics window ``W`` by
#: more than the window's length in forcing periods ``N`` to this power: ``lyapunov W > 2 ln N``.
#: On a periodic orbit the distance shrinks; along a quasi-periodic (modulated) response's torus
#: it grows at most linearly in time, ``ln N`` over the window; a positive exponent makes it grow
#: exponentially, past any power of ``N`` given a long enough window.  Where it shrinks by more
#: than ``N`` (``lyapunov W < -ln N``) the response is converging on a periodic orbit: transient.
GROWTH_POWER = 2.0
#: The columns beside ``regime`` in a periodically forced scene's table (``refine_regimes``).
REGIME_COLUMNS = ("lyapunov", "envelope_frequency", "settling_time")


def _scale(scene: Scene) -> float:
    """The velocities' divisor: the forcing frequency (rad/s), 1 without a periodic load."""
    return 2.0 * math.pi / scene.period if scene.period > 0 else 1.0


def _state(path: Path, scale: float) -> np.ndarray:
    """The path's state vector: displacements, then velocities over ``scale``."""
    return np.concatenate([path.x, path.v / scale])


def _place(path: Path, state: np.ndarray, scale: float) -> None:
    """Put ``path`` at ``state`` (as ``_state`` writes it), in place."""
    n = path.x.shape[0]
    path.x[:] = state[:n]
    path.v[:] = state[n:] * scale


def largest_lyapunov(scene: Scene, streams: Streams | np.random.Generator | None = None, *,
                     interval: int | None = None, d0: float = D0, first: int | None = None) -> float:
    """Largest Lyapunov exponent (1/s) of the realisation of ``scene`` on ``streams`` (as
    ``kernels.simulate`` takes them; None for a deterministic scene) from step ``first``
    (default: the metrics window's start) to the end, by Benettin's two trajectories (module
    text): renormalised every ``interval`` steps (default: one forcing period, or a
    two-hundredth of the window without a periodic load).  Negative
    for motion that settles on a periodic orbit or a point, about 0 for quasi-periodic
    (modulated) motion, positive for chaos.  NaN if the companion's distance stops being finite
    or the window holds no step."""
    first, last = (scene.i0 if first is None else first), scene.n_steps
    if last <= first:
        return math.nan
    if interval is None:
        interval = round(scene.period / scene.dt) if scene.period > 0 else (last - first) // 200
    interval = max(1, int(interval))
    scale = _scale(scene)
    reference = advance(start_path(scene, streams), first)
    companion = reference.branch()  # on copies of its streams: the same noise from here on
    state = _state(reference, scale)
    size = float(np.linalg.norm(state))
    d0 = d0 * (size if size > 0 else 1.0)
    direction = np.ones_like(state) / math.sqrt(state.shape[0])
    _place(companion, state + d0 * direction, scale)
    growth, step = 0.0, first
    while step < last:
        stop = min(step + interval, last)
        advance(reference, stop)
        advance(companion, stop)
        here = _state(reference, scale)
        gap = _state(companion, scale) - here
        d = float(np.linalg.norm(gap))
        if not math.isfinite(d) or d == 0.0:
            return math.nan
        growth += math.log(d / d0)
        _place(companion, here + gap * (d0 / d), scale)
        step = stop
    return growth / ((last - first) * scene.dt)


def envelope_frequency(signal: np.ndarray, dt: float, period: float | None = None) -> float:
    """Angular frequency (rad/s) of the envelope of ``signal`` (samples ``dt`` apart): the
    modulus of its analytic signal, averaged over one fast period (``period``, s; default the
    mean spacing of the signal's upward crossings of its mean) to take out the ripple at twice
    the fast frequency, over the record without ``EDGE`` at each end (``crossing_frequency``)."""
    x = np.asarray(signal, dtype=np.float64)
    x = x - x.mean()
    envelope = np.abs(hilbert(x))
    if period is None:
        ups = np.flatnonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))
        period = (ups[-1] - ups[0]) * dt / (ups.shape[0] - 1) if ups.shape[0] > 1 else dt
    width = max(1, int(round(period / dt)))
    smooth = np.convolve(envelope, np.full(width, 1.0 / width), mode="same")
    cut = max(int(EDGE * x.shape[0]), width)
    return crossing_frequency(smooth[cut:x.shape[0] - cut], dt)


def crossing_frequency(envelope: np.ndarray, dt: float) -> float:
    """Angular frequency (rad/s) of an envelope sampled ``dt`` apart: it crosses its mean upward
    once a slow cycle, counted where it then rises past ``HYSTERESIS`` standard deviations
    above its mean after falling as far below (a ripple's crossings are not cycles), the
    crossing linearly interpolated in its step; the crossing times, fitted by least squares
    against their count, give the period over whole cycles.  NaN where its range is at most
    ``DEPTH`` of its mean or fewer than two such crossings are seen (no modulation)."""
    envelope = np.asarray(envelope, dtype=np.float64)
    if envelope.shape[0] < 3:
        return math.nan
    mean = envelope.mean()
    if not np.ptp(envelope) > DEPTH * mean:
        return math.nan
    e = envelope - mean
    ups = np.flatnonzero((e[:-1] < 0.0) & (e[1:] >= 0.0))
    marks = np.flatnonzero(np.abs(e) > HYSTERESIS * e.std())
    high = e[marks] > 0.0
    rises = marks[1:][high[1:] & ~high[:-1]]  # (first sample past the upper mark after the lower)
    where = ups[np.searchsorted(ups, rises) - 1]  # (the last upward crossing before each rise)
    if where.shape[0] < 2:
        return math.nan
    t = (where + e[where] / (e[where] - e[where + 1])) * dt
    k = np.arange(t.shape[0], dtype=np.float64) - 0.5 * (t.shape[0] - 1)
    period = float(k @ (t - t.mean()) / (k @ k))  # (least squares: t = t0 + k period)
    return 2.0 * math.pi / period


def settling(samples: np.ndarray, omega: float) -> int | None:
    """Index of the first Poincare sample from which ``samples`` (one realisation's, NaN after
    the last) repeat (``metrics.regimes``), looked for in their first half; None where their last
    half does not repeat."""
    count = int((~np.isnan(samples[:, 0])).sum())
    for k in range(1, count // 2 + 1):
        if regimes(samples[np.newaxis, k:count], np.array([omega]))[0] not in (None, "aperiodic"):
            return k
    return None


def refine_regimes(frame: pd.DataFrame, scenes: Scene | list[Scene], samples: np.ndarray | None,
                   every: bool = False) -> None:
    """Name the ``aperiodic`` regimes of ``frame`` (a table of ``metrics.finish_table``, one row a
    realisation of ``scenes``: one scene, or one a row; ``samples``: their Poincare samples
    ``(rows, samples, columns)``) in the classes of the module text, in place, and add the
    ``REGIME_COLUMNS``: ``lyapunov`` (1/s, over the periods the samples span) where a row was
    classified by it (every ended row with ``every``, ``[output] lyapunov``),
    ``envelope_frequency`` (rad/s) of the ``modulated`` rows, ``settling_time`` (s) of the
    ``transient`` ones.  Nothing where the scene is not
    periodically forced."""
    first = scenes if isinstance(scenes, Scene) else scenes[0]
    if first.period <= 0 or samples is None or samples.shape[1] == 0:
        return
    n = frame.shape[0]
    columns = {name: np.full(n, np.nan) for name in REGIME_COLUMNS}
    regime = frame["regime"].to_numpy(dtype=object, na_value=None)
    ok = (frame["status"] == "ok").to_numpy()
    nf, nb = first.n_floors, first.mass.shape[0]
    # (by scene and first step: a scene without noise runs one path, whatever its row)
    exponents: dict[tuple[int, int], float] = {}
    for i in np.flatnonzero(ok):
        if regime[i] != "aperiodic" and not every:
            continue
        scene = scenes if isinstance(scenes, Scene) else scenes[i]
        omega = 2.0 * math.pi / scene.period
        row = samples[i]
        count = int((~np.isnan(row[:, 0])).sum())
        # over the periods of the last REGIME_SAMPLES (the regime's own stretch of the window)
        tail = max(0, count - REGIME_SAMPLES)
        start = scene.sample_from + tail * scene.period
        first = min(math.ceil(start / scene.dt - 1e-9), scene.n_steps - 1)
        if (id(scene), first) not in exponents:
            exponents[id(scene), first] = largest_lyapunov(scene, first=first)
        exponent = columns["lyapunov"][i] = exponents[id(scene), first]
        span = (scene.n_steps - first) * scene.dt
        periods = math.log(max(span / scene.period, 2.0))
        if regime[i] != "aperiodic":
            continue
        settled = settling(row[tail:count], omega)
        if settled is not None:
            regime[i] = "transient"
            columns["settling_time"][i] = start + settled * scene.period
        elif exponent * span > GROWTH_POWER * periods:
            regime[i] = "chaotic"
        elif exponent * span < -periods:
            regime[i] = "transient"  # (still converging on a periodic orbit past the window)
        else:
            # the roof's envelope once a period over all the samples: |x + i v / omega| (the
            # analytic signal of a response at the forcing frequency)
            roof = row[:count, nf - 1], row[:count, nb + nf - 1]
            found = crossing_frequency(np.hypot(roof[0], roof[1] / omega), scene.period)
            impacts = row[count - 1, 2 * nb:].sum() - row[tail, 2 * nb:].sum()  # (over the regime's stretch)
            regime[i] = "chatter" if math.isnan(found) and impacts > 0 else "modulated"
            columns["envelope_frequency"][i] = found
    frame["regime"] = pd.array(regime, dtype="string")
    for name, values in columns.items():
        frame[name] = values


__all__ = ["D0", "DEPTH", "EDGE", "GROWTH_POWER", "HYSTERESIS", "REGIME_COLUMNS", "crossing_frequency",
           "envelope_frequency", "largest_lyapunov", "refine_regimes", "settling"]
