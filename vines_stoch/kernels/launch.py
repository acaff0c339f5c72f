"""The CUDA kernels around a step loop: one realisation a thread from its start (``launcher``),
or one stretch of a path run in stretches a thread (``stretcher``; ``gpu.py``).

Imported only by the cuda backend: it needs numba-cuda (``numba.cuda``), an optional extra.
A launcher compiles through ``jit.cache.compile_once`` (numba-cuda's copy of the faster front
end, one process at a time) and is cached on disk beside the step loops (``jit.cache.cache_on_disk``).
"""

from __future__ import annotations

from functools import cache

import numpy as np
from numba import cuda, float64, uint64

from ..jit import njit
from ..jit.cache import cache_on_disk
from ..jit.intrinsics import register_cuda_model
from ..streams.rng import STREAM_WORDS, open_stream
from .bundles import Absorbers, Bodies, Filters, Grid, Loads, Noise, Outputs
from .loads import stationary_start

register_cuda_model()  # (the steps' stack arrays: ``jit.intrinsics.StackArray``)


def _plain(array):
    """The numpy array behind an array the simulator hands its kernels (the step loop is
    compiled for the CPU there and takes numpy arrays)."""
    return array._item._ary


@cache
def launcher(kernel, n_bodies: int, simulated: bool):
    """The CUDA kernel that runs ``kernel`` (a step loop of ``kernels/``, taking its bundles) for
    one realisation a thread; memoised by loop and body count (its stack arrays' size), and
    cached on disk (``jit.cache.cache_on_disk``; not under the simulator, which compiles
    nothing).  The arguments are ``gpu.PER_PATH`` (a leading axis: one entry, or one a
    realisation) and ``gpu.SHARED``, in their order; each thread builds the loop's bundles from
    its slices, by field name (``kernels/bundles.py``)."""
    NB = n_bodies
    WORDS = STREAM_WORDS
    plain = _plain if simulated else njit(inline="always")(lambda a: a)

    @cuda.jit
    def launch(first, n, per_path, place, keys, mass, storey_k, storey_c, floor_c, x0, v0, rows, forces,
               sigma, limits, phi, chol, envelope, c_force, c_ground, p0, kind, host, wall, series_t,
               series_v, series_ptr, series_target, reductions, normals, dt, n_steps, i0, period, sample_from,
               stride, kinds, template, signals, out, samples, history, events, work):
        t = cuda.grid(1)
        if t >= n:
            return
        p = t if per_path else 0
        r = first + t
        x = cuda.local.array(NB, float64)
        v = cuda.local.array(NB, float64)
        impulses = cuda.local.array(NB, float64)  # (one an absorber, fewer than the bodies)
        for b in range(NB):
            x[b] = x0[p, b]
            v[b] = v0[p, b]
        # the realisation's streams: step increments, Brownian trees' seed, filter noise
        inc = cuda.local.array(WORDS, uint64)
        bri = cuda.local.array(WORDS, uint64)
        fil = cuda.local.array(WORDS, uint64)
        open_stream(inc, keys[0], place | uint64(r))
        open_stream(bri, keys[1], place | uint64(r))
        open_stream(fil, keys[2], place | uint64(r))
        row = plain(out[t])
        for j in range(row.shape[0]):
            row[j] = template[j]
        own_samples = plain(samples[t])
        for a in range(own_samples.shape[0]):
            for b in range(own_samples.shape[1]):
                own_samples[a, b] = np.nan
        own_history = plain(history[t])
        for a in range(own_history.shape[0]):
            for b in range(own_history.shape[1]):
                own_history[a, b] = np.nan
        own_events = plain(events[t])
        for a in range(own_events.shape[0]):
            for b in range(own_events.shape[1]):
                own_events[a, b] = np.nan
        z, zn, draws = plain(work[t, 0]), plain(work[t, 1]), plain(work[t, 2])
        f0 = plain(p0[p])
        stationary_start(f0, fil, z, draws)
        kernel(Bodies(mass=plain(mass[p]), storey_k=plain(storey_k[p]), storey_c=plain(storey_c[p]),
                      floor_c=plain(floor_c[p]), x=x, v=v),
               Absorbers(kind=plain(kind), host=plain(host), rows=plain(rows[p]), wall=plain(wall)),
               Loads(forces=plain(forces[p]), series_t=plain(series_t), series_v=plain(series_v),
                     series_ptr=plain(series_ptr), series_target=plain(series_target)),
               Filters(phi=plain(phi[p]), chol=plain(chol[p]), envelope=plain(envelope[p]),
                       c_force=plain(c_force[p]), c_ground=plain(c_ground[p]), z=z, zn=zn, draws=draws),
               Noise(sigma=plain(sigma[p]), normals=plain(normals), refine=1),
               Grid(dt=dt, n_steps=n_steps, i0=i0, period=period, sample_from=sample_from, stride=stride,
                    first=0, kinds=kinds),
               Outputs(out=row, samples=own_samples, history=own_history, signals=plain(signals),
                       limits=plain(limits[p]), carry=row[:0], events=own_events,
                       reductions=plain(reductions), impulses=impulses),
               inc, bri, fil)

    if not simulated:
        cache_on_disk(launch)
    return launch


@cache
def stretcher(kernel, simulated: bool):
    """The CUDA kernel that runs one stretch of ``kernel`` (a step loop of ``kernels/``) for each
    of a batch of paths (``kernels.Path``, ``gpu.advance_many``), one a thread: path ``t`` from
    step ``firsts[t]`` to ``stops[t]``, every array of its bundles its own (a leading axis, one
    row a path: its state, metrics, carry and streams continue where its last stretch stopped),
    the grid's other fields shared.  Memoised by loop; cached on disk as ``launcher`` is."""
    plain = _plain if simulated else njit(inline="always")(lambda a: a)

    @cuda.jit
    def stretch(n, mass, storey_k, storey_c, floor_c, x, v, kind, host, rows, wall, forces, series_t,
                series_v, series_ptr, series_target, phi, chol, envelope, c_force, c_ground, z, zn, draws,
                sigma, normals, refine, dt, i0, period, sample_from, stride, kinds, firsts, stops, out,
                samples, history, signals, limits, carry, events, reductions, impulses, inc, bri, fil):
        t = cuda.grid(1)
        if t >= n:
            return
        kernel(Bodies(mass=plain(mass[t]), storey_k=plain(storey_k[t]), storey_c=plain(storey_c[t]),
                      floor_c=plain(floor_c[t]), x=plain(x[t]), v=plain(v[t])),
               Absorbers(kind=plain(kind[t]), host=plain(host[t]), rows=plain(rows[t]), wall=plain(wall[t])),
               Loads(forces=plain(forces[t]), series_t=plain(series_t[t]), series_v=plain(series_v[t]),
                     series_ptr=plain(series_ptr[t]), series_target=plain(series_target[t])),
               Filters(phi=plain(phi[t]), chol=plain(chol[t]), envelope=plain(envelope[t]),
                       c_force=plain(c_force[t]), c_ground=plain(c_ground[t]), z=plain(z[t]), zn=plain(zn[t]),
                       draws=plain(draws[t])),
               Noise(sigma=plain(sigma[t]), normals=plain(normals[t]), refine=refine),
               Grid(dt=dt, n_steps=stops[t], i0=i0, period=period, sample_from=sample_from, stride=stride,
                    first=firsts[t], kinds=kinds),
               Outputs(out=plain(out[t]), samples=plain(samples[t]), history=plain(history[t]),
                       signals=plain(signals[t]), limits=plain(limits[t]), carry=plain(carry[t]),
                       events=plain(events[t]), reductions=plain(reductions[t]), impulses=plain(impulses[t])),
               plain(inc[t]), plain(bri[t]), plain(fil[t]))

    if not simulated:
        cache_on_disk(stretch)
    return stretch

