"""Loads evaluated inside the step loops (MODEL.md section 3): no per-step Python.

A scene's time-dependent loads reach a kernel as the bundle
``ex = Loads(forces, series_t, series_v, series_ptr, series_target)`` (``kernels/bundles.py``):

- ``forces`` rows ``(kind, amplitude, p1, p2, p3, p4, floor)`` of closed-form forces on a
  floor (``HARMONIC``, ``HALF_SINE``, ``PULSE_TRAIN``, ``CHIRP``);
- sampled series (records), concatenated: series ``s`` holds ``series_t/v[ptr[s]:ptr[s+1]]``,
  linearly interpolated and zero outside its time span; ``series_target[s]`` is ``GROUND``
  (-1) for a ground acceleration (base excitation) or the floor a force acts on.

Loads reach the step loops as one force per floor (an array ``load``) and the ground
acceleration.

Piecewise loads are evaluated with a *piece time* ``tm``: the piece (pulse on or off, record
segment) is the one containing ``tm`` and its formula is evaluated at ``t``.  A step that
never straddles a break point (see ``next_break``) and passes its midpoint as ``tm`` sees a
smooth load, one-sided limits included.

Filtered loads (``physics/filters.py``) are advanced by ``advance_filters`` and read out linearly.

On a fixed time grid, harmonic rows are read from *phasors*, ``(cos, sin)`` of each row's
phase, turned by the angle of one step (a complex multiplication, ``turn``) instead of calling
``cos`` every step: a libm call in the step loop costs more than the rest of the load, and
the registers it clobbers cost as much again (the kick-drift-kick loop of a harmonically
forced scene ran 1.4-1.7x faster).  The step loops set the phasors exactly (``phasors``)
every ``common.CHECK_EVERY`` steps, so the rounding of the recurrence stays below about
``1e-13`` of the amplitude (``tests/test_loads.py``).
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import INLINE, KERNEL, copy_into, njit
from ..jit.intrinsics import fused
from ..physics.loads import (
    BLAST,
    ENVELOPE_FIRST,
    FLOOR,
    GROUND,
    HALF_SINE,
    HARMONIC,
    PULSE_TRAIN,
    closed_form_force,
    envelope,
)
from ..streams.rng import normal


@njit(**INLINE)
def segment(times, lo: int, hi: int, tm: float) -> int:
    """Index ``k`` in ``[lo, hi - 1)`` with ``times[k] <= tm < times[k + 1]`` (-1 outside the
    span): a guess from the mean spacing, then a walk (one step on uniform grids)."""
    if hi - lo < 2 or tm < times[lo] or tm > times[hi - 1]:
        return -1
    k = lo + int((tm - times[lo]) / (times[hi - 1] - times[lo]) * (hi - 1 - lo))
    k = min(max(k, lo), hi - 2)
    while k > lo and times[k] > tm:
        k -= 1
    while k < hi - 2 and times[k + 1] <= tm:
        k += 1
    return k


@njit(**INLINE)
def series_value(t: float, tm: float, times, values, lo: int, hi: int) -> float:
    """Linear interpolation of one series at ``t`` on the segment containing ``tm``."""
    k = segment(times, lo, hi, tm)
    if k < 0:
        return 0.0
    s = (t - times[k]) / (times[k + 1] - times[k])
    return values[k] + s * (values[k + 1] - values[k])


@njit(**INLINE)
def phasors(t: float, forces, pc, ps):
    """``(pc[r], ps[r])``: cosine and sine of the phase ``omega t + phi`` of each harmonic row
    at ``t`` (the phasor arrays have one entry per force row)."""
    for r in range(pc.shape[0]):
        if forces[r, 0] == HARMONIC:
            phase = forces[r, 2] * t + forces[r, 3]
            pc[r] = math.cos(phase)
            ps[r] = math.sin(phase)


@njit(**INLINE)
def rotations(forces, span: float, rc, rs):
    """``(rc[r], rs[r])``: cosine and sine of the angle each harmonic row turns through in
    ``span`` (``(1, 0)`` for the other rows)."""
    for r in range(rc.shape[0]):
        rc[r], rs[r] = 1.0, 0.0
        if forces[r, 0] == HARMONIC:
            rc[r] = math.cos(forces[r, 2] * span)
            rs[r] = math.sin(forces[r, 2] * span)


@njit(**INLINE)
def turn(pc, ps, rc, rs, oc, os):
    """Phasors ``(pc, ps)`` turned by ``(rc, rs)`` into ``(oc, os)`` (complex multiplication;
    the output may be the input).  Each part is one fused multiply-add, its first product fused
    (``intrinsics.fused``): left to the compiler, which product it fuses depends on the code
    around the call, and the scalar loop and the lane loop (``lanes.py``) would round apart."""
    for r in range(pc.shape[0]):
        c, s = pc[r], ps[r]
        oc[r] = fused(c, rc[r], -(s * rs[r]))
        os[r] = fused(s, rc[r], c * rs[r])


@njit(**INLINE)
def target(row: float, nf: int) -> int:
    """Floor index stored in a row (the constant 0 on a one-storey primary)."""
    return int(row) if nf > 1 else 0


@njit(**INLINE)
def applied(t: float, tm: float, forces, series_t, series_v, series_ptr, series_target, pc, on_grid: bool,
            load) -> float:
    """The closed-form loads and records at ``t``: the force on each floor into ``load`` (one
    entry per floor); returns the ground acceleration.  The arrays of ``ex`` come one by one
    (unpacking a tuple in a hot loop costs reference counting); with ``on_grid``, harmonic rows
    are read from the phasor cosines ``pc`` at ``t`` (a float array of any length otherwise)."""
    nf = load.shape[0]
    for k in range(nf):
        load[k] = 0.0
    ground = 0.0
    for r in range(forces.shape[0]):
        value = closed_form_force(t, tm, forces, r, pc, on_grid)
        if forces[r, FLOOR] == GROUND:  # (a base-harmonic row)
            ground += value
        else:
            load[target(forces[r, FLOOR], nf)] += value
    for s in range(series_target.shape[0]):
        value = series_value(t, tm, series_t, series_v, series_ptr[s], series_ptr[s + 1])
        if series_target[s] == GROUND:
            ground += value
        else:
            k = target(series_target[s], nf)
            load[k] += value
    return ground


@njit(**INLINE)
def has_breaks(ex) -> bool:
    """True when some load has kinks or jumps inside the run (pulses, half-sines, blasts, records)."""
    forces, series_target = ex.forces, ex.series_target
    for r in range(forces.shape[0]):
        if forces[r, 0] == HALF_SINE or forces[r, 0] == PULSE_TRAIN or forces[r, 0] == BLAST:
            return True
    return series_target.shape[0] > 0


@njit(**INLINE)
def next_break(t: float, ex) -> float:
    """The first break point of the loads after ``t`` (``inf`` if none)."""
    forces, series_t, series_ptr, series_target = ex.forces, ex.series_t, ex.series_ptr, ex.series_target
    first = np.inf
    for r in range(forces.shape[0]):
        row = forces[r]
        if row[0] == HALF_SINE:
            for tb in (row[3], row[3] + row[2]):
                if tb > t:
                    first = min(first, tb)
        elif row[0] == PULSE_TRAIN:
            width, period, t0, count = row[2], row[3], row[4], row[5]
            k = max(float(math.floor((t - t0) / period)), 0.0)
            tb = t0 + k * period
            if tb <= t:
                tb += width
            if tb <= t:
                tb = t0 + (k + 1.0) * period
                k += 1.0
            if count <= 0 or k < count:
                first = min(first, tb)
        elif row[0] == BLAST and row[4] > t:  # (the pulse's front)
            first = min(first, row[4])
    for s in range(series_target.shape[0]):
        lo, hi = series_ptr[s], series_ptr[s + 1]
        if t < series_t[lo]:
            first = min(first, series_t[lo])
        elif t < series_t[hi - 1]:
            first = min(first, series_t[segment(series_t, lo, hi, t) + 1])
    return first


@njit(**INLINE)
def stationary_start(p0, gen, z, draws) -> None:
    """The filters' initial state ``z = P0 n`` with ``n`` standard normals from ``gen``, drawn
    only where ``P0`` (the root of the stationary covariance) is not zero (else a start from
    rest, ``z = 0``); ``draws`` is scratch for ``n``."""
    drawn = stationary(p0)
    if drawn:
        for c in range(z.shape[0]):
            draws[c] = normal(gen)
    stationary_state(p0, draws, z, drawn)


@njit(**INLINE)
def stationary(p0) -> bool:
    """Whether the filters start from their stationary law (``P0`` not zero), not from rest:
    their stream's first normals are then the start's (``stationary_start``)."""
    for r in range(p0.shape[0]):
        for c in range(p0.shape[1]):
            if p0[r, c] != 0.0:
                return True
    return False


@njit(**INLINE)
def stationary_state(p0, draws, z, drawn: bool) -> None:
    """``z = P0 n`` (``draws``: ``n``), a sum in a fixed order; 0 where nothing was ``drawn`` (a
    start from rest: ``stationary``)."""
    for r in range(z.shape[0]):
        acc = 0.0
        for c in range(z.shape[0] if drawn else 0):
            acc += p0[r, c] * draws[c]
        z[r] = acc


@njit(**INLINE)
def advance_filters(z, zn, t: float, dt: float, phi, chol, envelopes, gen, draws):
    """``zn = Phi z + e(t + dt/2) L n``: the exact Gaussian step of the filter states
    (``draws`` is scratch for the standard normals ``n``)."""
    nz = z.shape[0]
    for c in range(nz):
        draws[c] = normal(gen)
    scale = 1.0
    for r in range(nz):
        # a filter's states share its envelope (comparing their rows a step cost the
        # ground-motion contact scene 5-10 % of its speed)
        if r == 0 or envelopes[r, ENVELOPE_FIRST] != 0.0:
            scale = envelope(t + 0.5 * dt, envelopes[r])
        zn[r] = filter_row(z, r, phi, chol, draws, scale)


@njit(**INLINE)
def filter_row(z, r: int, phi, chol, draws, scale: float) -> float:
    """Row ``r`` of ``advance_filters``' step: ``(Phi z)_r + scale (L n)_r`` (``draws``: ``n``)."""
    acc = 0.0
    noise = 0.0
    for c in range(z.shape[0]):  # (each term fused into its sum: one rounding a term)
        acc = fused(phi[r, c], z[c], acc)
        noise = fused(chol[r, c], draws[c], noise)
    return fused(scale, noise, acc)


@njit(**INLINE)
def filter_scales(t: float, dt: float, envelopes, scales) -> None:
    """Each filter state's envelope over the step from ``t``, ``e(t + dt/2)``, into ``scales``, as
    ``advance_filters`` takes it (a filter's states share its first's): what a batch of paths in
    SIMD lanes shares (``lanes.py``)."""
    scale = 1.0
    for r in range(scales.shape[0]):
        if r == 0 or envelopes[r, ENVELOPE_FIRST] != 0.0:
            scale = envelope(t + 0.5 * dt, envelopes[r])
        scales[r] = scale


@njit(**INLINE)
def readout(c, row: int, z, zn, theta: float) -> float:
    """``c[row] . ((1 - theta) z + theta zn)``: a filtered load between two grid states."""
    f = 0.0
    for r in range(z.shape[0]):
        f = fused(c[row, r], fused(theta, zn[r] - z[r], z[r]), f)
    return f


@njit(**INLINE)
def excitation(t: float, tm: float, theta: float, forces, series_t, series_v, series_ptr, series_target,
               filtered: bool, c_force, c_ground, z, zn, pc, on_grid: bool, has_ground: bool, load) -> float:
    """All loads at ``t``: the force on each floor into ``load``; returns the ground
    acceleration.  The filtered loads (if ``filtered``, a compile-time constant of the kernels)
    are read ``theta`` of the way from the grid states ``z`` to ``zn`` (``c_force`` has one
    read-out row per floor, ``c_ground`` one row); harmonic rows from the phasor cosines ``pc``
    if ``on_grid`` (see ``applied``).  Without ``has_ground`` (a compile-time constant of the
    kernels: the scene has no ground acceleration, ``Scene.has_ground``) the ground acceleration
    is the constant 0."""
    ground = applied(t, tm, forces, series_t, series_v, series_ptr, series_target, pc, on_grid, load)
    if filtered:
        for k in range(load.shape[0]):
            load[k] += readout(c_force, k, z, zn, theta)
        ground += readout(c_ground, 0, z, zn, theta)
    return ground if has_ground else 0.0


@njit(**KERNEL)
def load_path(ex, fl, dt: float, n_steps: int, gen, force, ground):
    """Force on each floor (``force``, shape ``(n_steps + 1, n_floors)``) and ground
    acceleration at ``t = i dt``, ``i = 0..n_steps``, with the filters advanced exactly as in
    the step loops (``fl`` as the kernels take it; ``gen``: the filter stream)."""
    phi, chol, envelopes, c_force, c_ground, z, zn, draws = (fl.phi, fl.chol, fl.envelope, fl.c_force,
                                                             fl.c_ground, fl.z, fl.zn, fl.draws)
    forces, series_t, series_v, series_ptr, series_target = (ex.forces, ex.series_t, ex.series_v,
                                                             ex.series_ptr, ex.series_target)
    copy_into(zn, z)
    for i in range(n_steps + 1):
        t = i * dt
        ground[i] = excitation(t, t, 0.0, forces, series_t, series_v, series_ptr, series_target, True,
                               c_force, c_ground, zn, zn, zn, False, True, force[i])
        if z.shape[0] > 0 and i < n_steps:
            copy_into(z, zn)
            advance_filters(z, zn, t, dt, phi, chol, envelopes, gen, draws)
