"""Loads (MODEL.md section 3): the kind codes of closed-form force rows, sampled series and filter
envelopes, and their formulae (evaluated in the step loops by ``kernels/loads.py``)."""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from ..jit.flags import INLINE

#: Kinds of closed-form rows, their width and the column of their floor (``GROUND`` for a
#: ground acceleration: a harmonic row there is the ``base-harmonic`` load).
HARMONIC, HALF_SINE, PULSE_TRAIN, CHIRP, BLAST = 0, 1, 2, 3, 4
FORCE_ROW, FLOOR = 7, 6
#: ``series_target`` (and closed-form rows' floor) of a ground acceleration.
GROUND = -1
#: Envelope kinds of filter rows (``filters.STATIONARY`` etc.).
STATIONARY, JENNINGS, SARAGONI_HART = 0, 1, 2
#: Columns of a filter state's envelope row: the kind and three parameters (``envelope``), then
#: 1 on a filter's first state, whose envelope its other states share (0 on those): the filter
#: step evaluates an envelope once a filter (``filters.block_diagonal``).
ENVELOPE_COLUMNS, ENVELOPE_FIRST = 5, 4


@njit(**INLINE)
def closed_form_force(t: float, tm: float, forces, r: int, pc, on_grid: bool) -> float:
    """Closed-form force row ``r`` at ``t`` (piece chosen at ``tm``); with ``on_grid``, a
    harmonic row is read from its phasor's cosine ``pc[r]`` at ``t``."""
    kind, amplitude = forces[r, 0], forces[r, 1]
    if kind == HARMONIC:  # P cos(omega t + phi)
        if on_grid:
            return amplitude * pc[r]
        return amplitude * math.cos(forces[r, 2] * t + forces[r, 3])
    if kind == HALF_SINE:  # F0 sin(pi (t - t0) / Td) on [t0, t0 + Td]
        duration, t0 = forces[r, 2], forces[r, 3]
        if t0 <= tm <= t0 + duration:
            return amplitude * math.sin(np.pi * (t - t0) / duration)
        return 0.0
    if kind == PULSE_TRAIN:  # F0 while (t - t0) mod Tp < tw, t >= t0, at most `count` pulses
        width, period, t0, count = forces[r, 2], forces[r, 3], forces[r, 4], forces[r, 5]
        if tm < t0:
            return 0.0
        k = float(math.floor((tm - t0) / period))
        if count > 0 and k >= count:
            return 0.0
        return amplitude if tm - t0 - k * period < width else 0.0
    if kind == BLAST:  # Friedlander: Ps (1 - s) exp(-b s), s = (t - t0) / Td, for t >= t0
        duration, decay, t0 = forces[r, 2], forces[r, 3], forces[r, 4]
        if tm < t0:
            return 0.0
        s = (t - t0) / duration
        return amplitude * (1.0 - s) * math.exp(-decay * s)
    # CHIRP: A sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))
    f0, f1, sweep = forces[r, 2], forces[r, 3], forces[r, 4]
    return amplitude * math.sin(2.0 * np.pi * (f0 * t + (f1 - f0) * t * t / (2.0 * sweep)))


@njit(**INLINE)
def envelope(t: float, row) -> float:
    """Amplitude envelope ``e(t)`` of a filter row ``(kind, p1, p2, p3)``: 1 (stationary),
    Jennings ``(t1, t2, c)``: ``(t/t1)^2``, 1, ``exp(-c (t - t2))``; Saragoni-Hart
    ``(peak, shape)``: ``(t/peak)^shape exp(shape (1 - t/peak))`` (peak 1 at ``t = peak``)."""
    kind = row[0]
    if kind == JENNINGS:
        if t < row[1]:
            return (t / row[1]) ** 2
        if t <= row[2]:
            return 1.0
        return math.exp(-row[3] * (t - row[2]))
    if kind == SARAGONI_HART:
        r = t / row[1]
        return r ** row[2] * math.exp(row[2] * (1.0 - r)) if r > 0.0 else 0.0
    return 1.0
