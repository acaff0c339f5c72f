"""The energy accounts of MODEL.md section 4 in expectation over the metrics window, from the
means and covariances of a path (``moments.Trajectory``): the input work (the energy stored at the
window's opening, then the loads' power ``sum_i m_i E[v_i (F_i / m_i - a_g)]`` and white noise's
Ito term ``sigma^2 / 2 m``), the dashpots' dissipation ``E[c w^2]``, the integral of ``E[E1]``, and
the EDM as the ratio of the expected absorbed and input energies (its first-order estimate)."""

from __future__ import annotations

import numpy as np

from ..physics.absorbers import (
    DAMPING,
    FREE_LENGTH,
    GAP,
    K_CUBIC,
    K_GAP,
    K_GEO,
    K_LEFT,
    K_LIN,
    K_RIGHT,
    LENGTH,
    REST,
    WALL_HI,
    WALL_LO,
    geometric_energy,
)
from .linearization import NODES, WEIGHTS, positive_moment
from .moments import Trajectory
from .system import Model, structure_matrices


def _second(path: Trajectory, i: int) -> np.ndarray:
    """``E[z z^T]`` at grid time ``i``."""
    return path.p[i] + np.outer(path.m[i], path.m[i])


def coupling_energy(row: np.ndarray, mu: float, s: float) -> float:
    """``E[V(u)]`` of an absorber's attachment and contacts (``physics.absorbers.coupling_energy``,
    ``physics.hertz.contact_energy``) for ``u ~ N(mu, s^2)``: the polynomial's moments
    (``E[y^4] = mu^4 + 6 mu^2 s^2 + 3 s^4``), Gauss-Hermite for the geometric term,
    ``k / 2 E[(|y| - g)_+^2]`` for a gap spring, ``0.4 K E[z_+^2.5]`` for a contact."""
    y = mu - row[REST]
    y2, y4 = y * y + s * s, y**4 + 6 * y * y * s * s + 3 * s**4
    e = 0.5 * row[K_LIN] * y2 + 0.25 * row[K_CUBIC] * y4
    if row[K_GEO] != 0.0:
        f = geometric_energy.py_func
        values = [f(y + s * n, row[K_GEO], row[FREE_LENGTH], row[LENGTH]) for n in NODES]
        e += float(WEIGHTS @ np.array(values))
    if row[K_GAP] != 0.0:
        g = row[GAP]
        e += 0.5 * row[K_GAP] * (positive_moment(y - g, s, 2.0) + positive_moment(-y - g, s, 2.0))
    for k, m in ((row[K_LEFT], row[WALL_LO] - mu), (row[K_RIGHT], mu - row[WALL_HI])):
        if k > 0.0:
            e += 0.4 * k * positive_moment(m, s, 2.5)
    return e


def accounts(path: Trajectory, i0: int, scene, base: Model, b_external: np.ndarray) -> dict[str, float]:
    """``input_energy``, ``absorber_dissipation``, ``primary_dissipation``, ``energy_integral`` and
    ``edm`` expected over the window from grid time ``i0``; ``base``: the model without absorbers
    (``system.bare``: the loads' read-outs), ``b_external``: its forcing on the grid (T, N)."""
    nb, nf = base.n_bodies, base.n_floors
    mass, t = scene.mass, path.t[i0:]
    k, c = structure_matrices(scene)
    loads = base.a[nb:2 * nb, 2 * nb:]  # the filters' read-outs on the bodies' accelerations
    ito = float(np.sum(scene.sigma**2 / (2.0 * mass[:nf])))
    m, p = path.m[i0:], path.p[i0:]
    second = p + np.einsum("ti,tj->tij", m, m)  # E[z z^T] on the window's grid
    sv = second[:, nb:2 * nb, nb:2 * nb]
    power = (np.einsum("i,ij,tij->t", mass, loads, second[:, nb:2 * nb, 2 * nb:])
             + (m[:, nb:2 * nb] * b_external[i0:, nb:2 * nb]) @ mass + ito)
    primary = np.einsum("ij,tij->t", c[:nf, :nf], sv[:, :nf, :nf])
    absorbed = np.zeros(len(t))
    for a in range(len(scene.kind)):
        j, h = nf + a, int(scene.host[a])
        absorbed += scene.rows[a, DAMPING] * (sv[:, j, j] - 2.0 * sv[:, j, h] + sv[:, h, h])
    e1 = 0.5 * (np.einsum("i,tii->t", mass[:nf], sv[:, :nf, :nf])
                + np.einsum("ij,tij->t", k[:nf, :nf], second[:, :nf, :nf]))
    stored = _stored(path, i0, scene, k)
    out = {"input_energy": stored + _integral(power, t), "absorber_dissipation": _integral(absorbed, t),
           "primary_dissipation": _integral(primary, t), "energy_integral": _integral(e1, t)}
    out["edm"] = out["absorber_dissipation"] / out["input_energy"] if out["input_energy"] > 0 else np.nan
    return out


def _integral(values: np.ndarray, t: np.ndarray) -> float:
    """The trapezoid rule over the window's grid (0 for a window of one time)."""
    return float(np.trapezoid(values, t)) if len(t) > 1 else 0.0


def _stored(path: Trajectory, i0: int, scene, k: np.ndarray) -> float:
    """The energy stored at the window's opening: every body's kinetic energy, the storeys' strain
    energy and the absorbers' attachments and contacts (``coupling_energy``)."""
    nb, nf = scene.mass.shape[0], scene.n_floors
    s2 = _second(path, i0)
    e = 0.5 * float(scene.mass @ np.diagonal(s2)[nb:2 * nb]) + 0.5 * float(np.sum(k[:nf, :nf] * s2[:nf, :nf]))
    for a in range(len(scene.kind)):
        j, h = nf + a, int(scene.host[a])
        mu = path.m[i0, j] - path.m[i0, h]
        var = path.p[i0, j, j] - 2.0 * path.p[i0, j, h] + path.p[i0, h, h]
        e += coupling_energy(scene.rows[a], mu, float(np.sqrt(max(var, 0.0))))
    return e
