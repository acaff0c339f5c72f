"""The GPU roofline of ``make bench-gpu`` (``bench_gpu.py``): the smooth scene as the shortest
numba-cuda loop of the same scheme.  Imported only by the cuda benchmark: it needs numba-cuda."""

from __future__ import annotations

import math

from numba import cuda, uint64

from ..streams.rng import STREAM_WORDS, open_stream, philox_normal


@cuda.jit
def roofline(key, n_steps, dt, out):
    """One thread a path: kick-drift-kick Euler-Maruyama of the LPO m = k = 1 with the cubic
    NES eps = 0.05, c = 0.01, k3 = 1 under ``0.1 cos t`` (a turned phasor, set exactly every
    1024 steps) and white noise 0.05, drawn by ``philox_normal`` on the thread's stream (key
    ``key``, place the path); writes the running maximum of ``E1`` to ``out[path]``."""
    t = cuda.grid(1)
    if t >= out.shape[0]:
        return
    stream = cuda.local.array(STREAM_WORDS, uint64)
    open_stream(stream, key, uint64(t))
    x1 = v1 = x2 = v2 = 0.0
    s = 0.5 * 0.05 * math.sqrt(dt)  # half of sigma dW in each kick
    h = 0.5 * dt
    rc, rs = math.cos(dt), math.sin(dt)
    pc, ps = 1.0, 0.0
    load = 0.1
    e_max = 0.0
    for i in range(n_steps):
        if i % 1024 == 0:
            pc, ps = math.cos(i * dt), math.sin(i * dt)
        u, w = x2 - x1, v2 - v1
        f = -u * u * u - 0.01 * w
        dw = s * philox_normal(stream)
        v1 += h * (load - x1 - f) + dw
        v2 += h * f / 0.05
        x1 += dt * v1
        x2 += dt * v2
        u, w = x2 - x1, v2 - v1
        f = -u * u * u - 0.01 * w
        pc, ps = pc * rc - ps * rs, ps * rc + pc * rs
        load = 0.1 * pc
        v1 += h * (load - x1 - f) + dw
        v2 += h * f / 0.05
        e_max = max(e_max, 0.5 * (v1 * v1 + x1 * x1))
    out[t] = e_max


__all__ = ["roofline"]
