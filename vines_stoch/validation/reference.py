"""Independent references for tests and benchmarks: scipy ``solve_ivp`` (DOP853, tight
tolerances) with event location, restarted after each Newton impact or at each Hertz contact
onset and end.  Pure Python, written from MODEL.md alone, sharing no code with the kernels."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def parallel_nes_reference(m1, k1, c1, cubic, impact, x_impulse, duration, rtol=1e-10, atol=1e-13,
                           max_impacts=5000):
    """Primary + cubic NES ``(m, k3, c)`` + impact NES ``(m, clearance, r)`` under an impulse.

    Returns ``(edm, impacts)``.  The reference has no sticking law: a chattering sequence
    raises RuntimeError after ``max_impacts``.
    """
    mc, k3, cc = cubic
    mi, clearance, r = impact

    def rhs(t, y):
        x1, xc, xi, v1, vc, vi, _ = y
        u, w = xc - x1, vc - v1
        f = -k3 * u**3 - cc * w
        return [v1, vc, vi, (-k1 * x1 - c1 * v1 - f) / m1, f / mc, 0.0, cc * w * w]

    def upper(t, y):
        return (y[2] - y[0]) - clearance

    def lower(t, y):
        return (y[2] - y[0]) + clearance

    upper.terminal, upper.direction = True, 1
    lower.terminal, lower.direction = True, -1
    y = np.array([0.0, 0.0, 0.0, x_impulse, 0.0, 0.0, 0.0])
    t, impacts, lost = 0.0, 0, 0.0
    while t < duration:
        sol = solve_ivp(rhs, (t, duration), y, method="DOP853", rtol=rtol, atol=atol,
                        events=(upper, lower))
        t, y = sol.t[-1], sol.y[:, -1].copy()
        if sol.status == 1:
            w = y[5] - y[3]
            total = m1 + mi
            lost += 0.5 * (1 - r * r) * m1 * mi / total * w * w
            y[3], y[5] = y[3] + mi * (1 + r) * w / total, y[5] - m1 * (1 + r) * w / total
            y[2] = y[0] + (clearance if w > 0 else -clearance)
            impacts += 1
            if impacts > max_impacts:
                raise RuntimeError(f"more than {max_impacts} impacts by t = {t}")
    return (y[6] + lost) / (0.5 * m1 * x_impulse**2), impacts


def hertz_reference(m1, k1, c1, m2, k2, c2, rest, k_left, k_right, walls, force, omega, u0, times,
                    rtol=1e-11, atol=1e-13, e1_step=1e-4):
    """Primary + Hertz absorber (MODEL.md section 2) under ``force cos(omega t)`` from rest with
    ``x2(0) - x1(0) = u0``; contact onsets and ends are located as events, so the integrator
    never steps across the ``z^1.5`` kink.  Returns ``(x1(times), e1_max over [0, times[-1]])``."""
    lo, hi = walls

    def rhs(t, y):
        x1, x2, v1, v2 = y
        u, w = x2 - x1, v2 - v1
        f = -k2 * (u - rest) - c2 * w
        f += k_left * max(lo - u, 0.0) ** 1.5 - k_right * max(u - hi, 0.0) ** 1.5
        return [v1, v2, (force * np.cos(omega * t) - k1 * x1 - c1 * v1 - f) / m1, f / m2]

    def left(t, y):
        return (y[1] - y[0]) - lo

    def right(t, y):
        return (y[1] - y[0]) - hi

    left.terminal = right.terminal = True
    y = np.array([0.0, u0, 0.0, 0.0])
    t, end = 0.0, times[-1]
    pieces = []
    while t < end:
        u, w = y[1] - y[0], y[3] - y[2]
        # at a surface (just after an event) the relative velocity says which side comes next
        in_left = u - lo < -1e-12 or (abs(u - lo) <= 1e-12 and w < 0)
        in_right = u - hi > 1e-12 or (abs(u - hi) <= 1e-12 and w > 0)
        left.direction = 1 if in_left else -1     # the next crossing of each surface only
        right.direction = -1 if in_right else 1
        sol = solve_ivp(rhs, (t, end), y, method="DOP853", rtol=rtol, atol=atol, events=(left, right),
                        dense_output=True)
        pieces.append((t, sol.t[-1], sol.sol))
        t, y = sol.t[-1], sol.y[:, -1].copy()
    x1 = np.empty(len(times))
    e1_max = 0.0
    for a, b, dense in pieces:
        for i, s in enumerate(times):
            if a <= s <= b:
                x1[i] = dense(s)[0]
        grid = np.linspace(a, b, max(2, int((b - a) / e1_step)))
        states = dense(grid)
        e1_max = max(e1_max, float(np.max(0.5 * m1 * states[2] ** 2 + 0.5 * k1 * states[0] ** 2)))
    return x1, e1_max
