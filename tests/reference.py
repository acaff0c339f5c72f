"""Independent reference: scipy ``solve_ivp`` (DOP853, tight tolerances) with event location
and restart after each Newton impact.  Pure Python, written from MODEL.md alone."""

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
