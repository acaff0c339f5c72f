"""The one loop driver: every scheme's step loop is this loop around the scheme's step.

The driver owns what every scheme shares (MODEL.md section 4): the state in and out, the time
grid and its blocks (``common.block_end``), the metrics window's opening, the divergence
checks, the energy accounts and the per-floor peaks (``energy``), the first passages of the
limits, the history rows, the Poincare samples, the path's carry from one stretch to the next
(``carry``) and the metric vector.  A scheme plugs in as a ``Step`` of compiled functions that
the driver inlines (``kdk.kdk_step``, ``sra3.sra3_step``, ``rk4.rk4_step``; the registry
``schemes.SCHEMES`` names each scheme's step): a new scheme is one file with its ``Step`` and
one registry line.
The protocol between the loop and a scheme's step is ``protocol.py``'s.
"""

from __future__ import annotations

from functools import cache

from ..jit import njit
from ..jit.cache import stable_cache
from ..jit.flags import INLINE, KERNEL
from ..jit.intrinsics import borrowed, copy_into, no_builtins, plain
from ..outputs import CONTACT_TIME, FINAL_ENERGY, PEAK_FORCE, STATUS, STATUS_DIVERGED, declared_slots
from ..physics.structure import primary_energy
from .carry import (
    E1_PREV,
    HISTORY_NEXT,
    NEXT_SAMPLE,
    PENDING,
    restore_accounts,
    restore_floors,
    save_accounts,
    save_floors,
)
from .common import (
    CHECK_EVERY,
    HERTZ_BIT,
    IMPACT_BIT,
    bit_set,
    block_end,
    close_window,
    diverged,
    first_passages,
    floor_peaks,
    fold_declared,
    kinds_of,
    record_history,
    record_sample,
    recording,
    stack_scratch,
    start_history,
    stored_energy,
    write_floor_metrics,
)
from .energy import write_accounts
from .protocol import Spec, Step, rooms


@njit(**INLINE)
def copy_state(x, v, xc, vc) -> None:
    """The state ``x, v`` into ``xc, vc``: the copies an out-of-line call takes
    (``common.stored_energy``, ``common.history_row``), so that its address reaches no call and
    the state stays in registers."""
    for b in range(x.shape[0]):
        xc[b] = x[b]
        vc[b] = v[b]


@cache
def step_loop(plug: Step, spec: Spec):
    """The step loop of a scheme's ``Step`` specialised to ``spec``.  It takes the bundles
    ``(bodies, absorbers, ex, fl, noise, grid, outputs, gen, gen_bridge, gen_filter)`` of
    ``kernels/bundles.py``; runs steps ``grid.first`` to ``grid.n_steps`` (a later stretch of
    a path restores its state from the outputs' carry, ``carry.py``) and writes the metric
    vector (``outputs.SLOTS``), the history rows and the Poincare samples."""
    start, opening, check, step, save, finish = (plug.start, plug.opening, plug.check, plug.step, plug.save,
                                                 plug.finish)
    INTEGRATES = plug.integrates
    SAMPLES = plug.samples
    FORCE_PEAKS = plug.force_peaks
    NB, NF, GPU = spec.n_bodies, spec.n_floors, spec.gpu
    body_scratch, floor_scratch = stack_scratch(*rooms(spec)[:2])  # (arrays on the loop's stack)
    _, HAS_IMPACT, HAS_HERTZ, _, _, _, _ = kinds_of(spec)  # (what the scene holds, or ``RUN_TIME``)

    @njit(**KERNEL)
    def kernel(bodies_, absorbers_, ex_, fl_, noise_, grid_, outputs_, gen_, gen_bridge_, gen_filter_):
        # the bundles and the streams as borrowed views (``jit.intrinsics.borrowed``): no
        # reference counting in the loop, nor in the steps it inlines (a stream array passed to a
        # draw in a branch cost two atomic operations a draw, a quarter of a smooth step)
        if not GPU and NB < 0:  # (the general loops: no C library calls of their small loops)
            no_builtins()
        bodies, absorbers, ex, fl, noise, grid, outputs = borrowed(
            (bodies_, absorbers_, ex_, fl_, noise_, grid_, outputs_))
        gen, gen_bridge, gen_filter = borrowed((gen_, gen_bridge_, gen_filter_))
        nb = NB if NB >= 0 else bodies.mass.shape[0]  # (``RUN_TIME``: the counts read at run time)
        nf = NF if NF >= 0 else bodies.storey_k.shape[0]
        mass, storey_k = bodies.mass, bodies.storey_k
        kind, host, rows = absorbers.kind, absorbers.host, absorbers.rows
        dt, n_steps, i0, period, sample_from, stride, first = (grid.dt, grid.n_steps, grid.i0, grid.period,
                                                                grid.sample_from, grid.stride, grid.first)
        out, samples, history, signals, limits, carry = (outputs.out, outputs.samples, outputs.history,
                                                         outputs.signals, outputs.limits, outputs.carry)
        reductions, impulses = outputs.reductions, outputs.impulses
        declared_at = declared_slots(nf, limits.shape[0])
        # what the run records (run-time data, the same for every step: ``common.recording``)
        has_impact = HAS_IMPACT if HAS_IMPACT >= 0 else bit_set(grid.kinds, IMPACT_BIT)
        has_hertz = HAS_HERTZ if HAS_HERTZ >= 0 else bit_set(grid.kinds, HERTZ_BIT)
        declared, contact = recording(history.shape[0], signals, reductions, has_impact)
        resume = first > 0  # a later stretch of the path: its state from ``carry``
        # the state (copied back at the end) on the stack (see ``jit.intrinsics.scratch``); copies
        # of it for the out-of-line calls and for the Poincare samples' interpolation
        x, v, inv_mass = body_scratch(nb), body_scratch(nb), body_scratch(nb)
        xc, vc, xp, vp = body_scratch(nb), body_scratch(nb), body_scratch(nb), body_scratch(nb)
        for b in range(nb):
            x[b] = bodies.x[b]
            v[b] = bodies.v[b]
            inv_mass[b] = 1.0 / mass[b]
        # per floor: the force or acceleration for the peaks, the peaks, the x_k^2 integrals
        acc, x_max, drift_max = floor_scratch(nf), floor_scratch(nf), floor_scratch(nf)
        acc_max, x2_integral = floor_scratch(nf), floor_scratch(nf)
        peaks = (x_max, drift_max, acc_max, x2_integral)
        kept, sc = start(bodies, absorbers, ex, fl, noise, grid, carry, resume, x, v, gen_bridge)
        own = borrowed(kept)  # (the scheme's state: a borrowed view, as the bundles)
        # the accounts in registers, written to ``out`` once at the end (the trapezoid rule's
        # integrals as plain sums of the step ends' values, the window's ends at half weight)
        work = d_primary = d_absorber = e_sum = e1_max = 0.0
        loss = n_left = n_right = contact_time = peak_force = 0.0
        if resume:
            work, d_primary, d_absorber, e_sum, e1_max, loss, n_left, n_right, contact_time, peak_force = (
                restore_accounts(carry))
            e1_prev = carry[E1_PREV]
            pending, h_next = int(carry[PENDING]), int(carry[HISTORY_NEXT])
            next_sample = int(carry[NEXT_SAMPLE])
            restore_floors(carry, x_max, drift_max, acc_max, x2_integral)
        else:
            e1_prev = primary_energy(mass, storey_k, x, v, nf)
            h_next = -1
            if history.shape[0] > 0:
                copy_state(x, v, xc, vc)
                h_next = start_history(history, stride, signals, xc, vc, nf, e1_prev, mass, kind, host, rows,
                                       impulses, dt)
            pending = limits.shape[0]  # limits not passed yet
            next_sample = 0
        sampling = SAMPLES and samples.shape[0] > 0
        i = first
        inside = i0 == 0 or i0 < first
        while i < n_steps:
            # rare work between blocks of steps, out of the step loop: the window opening,
            # the divergence check, history rows
            if i == i0:
                inside = True
                copy_state(x, v, xc, vc)
                work = stored_energy(*plain((xc, vc, mass, nf, storey_k, kind, host, rows)))
                if INTEGRATES:
                    e1_max = primary_energy(mass, storey_k, x, v, nf)
                else:
                    e1_max = e1_prev
                    e_sum = 0.5 * e1_prev
                    for k in range(nf):
                        x2_integral[k] = 0.5 * x[k] * x[k]
                opening(own, x, v, inv_mass, acc, bodies, absorbers)
                floor_peaks(x, nf, acc, x_max, drift_max, acc_max)
                if declared:  # (``xc, vc``: the state's copies, above)
                    fold_declared(reductions, out, declared_at, xc, vc, nf, e1_max, mass, host, kind, rows,
                                  impulses, dt, True)
                if pending > 0:
                    pending = first_passages(limits, i * dt, nf, x_max, drift_max, acc_max, inv_mass,
                                             FORCE_PEAKS, e1_max, out)
            if i % CHECK_EVERY == 0:
                if diverged(x):
                    out[STATUS] = STATUS_DIVERGED
                    break
                check(own, i, dt, ex)
            end = block_end(i, n_steps, i0, h_next)
            begin = i
            for i in range(begin, end):
                if SAMPLES and sampling:  # (``SAMPLES`` first: without, nothing of it is compiled)
                    if GPU:  # (on the CPU this loop ran 6 % slower than a slice copy; copy_into matches one)
                        for b in range(nb):
                            xp[b] = x[b]
                            vp[b] = v[b]
                    else:
                        copy_into(xp, x)
                        copy_into(vp, v)
                if contact:  # (the impulses of this step's impacts, from none)
                    for a in range(impulses.shape[0]):
                        impulses[a] = 0.0
                acct = (work, d_primary, d_absorber, e_sum, e1_max, loss, n_left, n_right, contact_time,
                        peak_force, pending)
                sc, acct = step(i, x, v, inv_mass, acc, own, sc, acct, inside, peaks, bodies, absorbers, ex,
                                fl, noise, grid, outputs, gen, gen_filter)
                work, d_primary, d_absorber, e_sum, e1_max, loss, n_left, n_right, contact_time, peak_force, \
                    pending = acct
                if not INTEGRATES:  # the step's end observed: the trapezoid sums, the peaks
                    e1 = primary_energy(mass, storey_k, x, v, nf)
                    if inside:
                        e_sum += e1
                        e1_max = max(e1_max, e1)
                        for k in range(nf):
                            x2_integral[k] += x[k] * x[k]
                        floor_peaks(x, nf, acc, x_max, drift_max, acc_max)
                        if pending > 0:
                            pending = first_passages(limits, i * dt + dt, nf, x_max, drift_max, acc_max,
                                                     inv_mass, FORCE_PEAKS, e1_max, out)
                    e1_prev = e1
                if declared and inside:
                    copy_state(x, v, xc, vc)
                    fold_declared(reductions, out, declared_at, xc, vc, nf,
                                  primary_energy(mass, storey_k, x, v, nf) if INTEGRATES else e1_prev, mass,
                                  host, kind, rows, impulses, dt, False)
                if SAMPLES and sampling:
                    next_sample = record_sample(samples, next_sample, sample_from, period, i * dt, dt, xp,
                                                vp, x,
                                                v, n_left, n_right)
            i = end
            if i == h_next:
                copy_state(x, v, xc, vc)
                h_next = record_history(history, stride, h_next, signals, xc, vc, nf,
                                        primary_energy(mass, storey_k, x, v, nf) if INTEGRATES else e1_prev,
                                        mass, kind, host, rows, impulses, dt)
        if carry.shape[0] > 0:  # the path's state for its next stretch, raw
            save_accounts(carry, work, d_primary, d_absorber, e_sum, e1_max, loss, n_left, n_right,
                          contact_time, peak_force)
            carry[E1_PREV], carry[PENDING], carry[HISTORY_NEXT], carry[NEXT_SAMPLE] = (e1_prev, pending,
                                                                                       h_next,
                                                                                       next_sample)
            save_floors(carry, x_max, drift_max, acc_max, x2_integral)
            save(carry, kept, sc)
        if diverged(x):
            out[STATUS] = STATUS_DIVERGED
        for b in range(nb):
            bodies.x[b] = x[b]
            bodies.v[b] = v[b]
        finish(kept, sc, fl, out)
        if INTEGRATES:
            e_integral = e_sum
        else:
            e_integral = close_window(inside and i0 < n_steps, dt, e_sum, e1_prev, x, nf, x2_integral,
                                      acc_max, inv_mass, FORCE_PEAKS)
        write_accounts(out, work, d_primary, d_absorber, e_integral, e1_max, loss, n_left, n_right)
        if has_hertz:
            out[CONTACT_TIME] = contact_time
            out[PEAK_FORCE] = peak_force
        copy_state(x, v, xc, vc)
        out[FINAL_ENERGY] = stored_energy(*plain((xc, vc, mass, nf, storey_k, kind, host, rows)))
        write_floor_metrics(out, nf, x_max, drift_max, acc_max, x2_integral)

    stable_cache(kernel)  # (its closure holds the step's functions: see ``jit.cache.stable_cache``)
    return kernel
