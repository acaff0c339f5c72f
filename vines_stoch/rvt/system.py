"""The linear(ised) state-space model of a scene (MODEL.md section 6).

State ``z = (x, v, f)``: the displacements and velocities of every body (floors, lowest first,
then the absorbers) and the states of the load filters.  ``dz = (A z + b(t)) dt + B dW``, with

- ``A``: ``x' = v``, ``M v' = -K x - C v + (force read-outs of the filters) - M 1 a_g``, the
  filters' own drift; absorbers enter ``K`` and ``C`` through their equivalent stiffness and
  damping (exact for the linear law, statistical linearisation otherwise: ``linearization.py``);
- ``B``: one column a noise source, white noise on a floor (``sigma / m`` on its velocity) or a
  filter's input (its ``b``), each with the amplitude envelope of its load;
- ``b(t)``: the deterministic part: constant forces (an equivalent law's mean force, wind's mean
  force) and harmonic forces and ground accelerations, ``Re(g e^{i omega t})``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..physics.absorbers import DAMPING, HERTZ, IMPACT
from ..physics.filters import stationary_covariance
from ..physics.loads import FLOOR, GROUND, HARMONIC, STATIONARY


class NotApplicable(Exception):
    """The scene holds something no Gaussian estimate of this module covers (the message: what)."""


@dataclass
class Model:
    """``dz = (A z + b(t)) dt + B dW`` of one scene (module docstring)."""

    a: np.ndarray                       # (N, N) drift
    noise: np.ndarray                   # (N, q) noise columns
    envelopes: list                     # q envelope rows (physics.loads.envelope), None: constant
    constant: np.ndarray                # (N,) constant forcing
    harmonics: list = field(default_factory=list)  # (omega, g (N,), feed (n_bodies,)), complex:
    # b(t) += Re(g e^{i omega t}); feed: the forces' part of it on the bodies' accelerations
    feed: np.ndarray | None = None      # (n_bodies,) constant forces' accelerations (no ground part)
    ground: np.ndarray | None = None    # (N,) the read-out of the filtered ground acceleration
    m0: np.ndarray | None = None        # (N,) initial mean
    p0: np.ndarray | None = None        # (N, N) initial covariance
    n_bodies: int = 1
    n_floors: int = 1
    white_floors: tuple = ()            # floors under white noise (their acceleration is white)

    @property
    def size(self) -> int:
        return self.a.shape[0]

    @property
    def time_invariant_noise(self) -> bool:
        return all(e is None or e[0] == STATIONARY for e in self.envelopes)

    def x(self, body: int) -> np.ndarray:
        """The read-out row of body ``body``'s displacement."""
        return np.eye(1, self.size, body)[0]

    def v(self, body: int) -> np.ndarray:
        """The read-out row of body ``body``'s velocity."""
        return np.eye(1, self.size, self.n_bodies + body)[0]

    def acceleration(self, body: int) -> np.ndarray:
        """The read-out row of body ``body``'s absolute acceleration ``v' + a_g`` without its
        deterministic forces (``feed``): the ground acceleration cancels, ``M (v' + a_g) = -K x -
        C v + F``."""
        row = self.a[self.n_bodies + body].copy()
        row[2 * self.n_bodies:] += self.ground
        return row


def structure_matrices(scene) -> tuple[np.ndarray, np.ndarray]:
    """``(K, C)`` of the bare structure over every body (MODEL.md 1a; as
    ``physics.structure.structure_forces``: storey springs and dashpots, and the mass-proportional
    Rayleigh dashpots of a primary of several floors)."""
    n, nf = scene.mass.shape[0], scene.n_floors
    k, c = np.zeros((n, n)), np.zeros((n, n))
    for j in range(nf):
        for matrix, coefficient in ((k, scene.storey_k[j]), (c, scene.storey_c[j])):
            _couple(matrix, j, j - 1, coefficient)
        if nf > 1:
            c[j, j] += scene.floor_c[j]
    return k, c


def _couple(matrix: np.ndarray, i: int, j: int, coefficient: float) -> None:
    """Add a spring (dashpot) of ``coefficient`` between bodies ``i`` and ``j`` (``j < 0``: the
    ground) to a stiffness (damping) matrix."""
    matrix[i, i] += coefficient
    if j >= 0:
        matrix[j, j] += coefficient
        matrix[i, j] -= coefficient
        matrix[j, i] -= coefficient


def check_laws(scene) -> None:
    """Refuse what no Gaussian closure here covers: impacts with restitution (instantaneous
    velocity jumps), loads other than noise, harmonic and constant forces (shocks, records)."""
    if (scene.kind == IMPACT).any():
        raise NotApplicable("impact absorbers with restitution (instantaneous velocity jumps): no "
                            "Gaussian closure applies")
    if scene.series_ptr[-1] > 0:
        raise NotApplicable("recorded loads (a deterministic record): no closed form")
    if ((scene.forces[:, 0] != HARMONIC) if scene.forces.size else np.zeros(0, bool)).any():
        raise NotApplicable("shock or sweep loads (half-sine, pulse train, chirp, blast): no closed form")


def build(scene, scenario_filters: list, k_eq: np.ndarray, g0: np.ndarray) -> Model:
    """The model of ``scene`` with absorber ``a``'s law replaced by ``g0[a] + k_eq[a] u -
    c_a w`` (``u``, ``w``: its motion relative to its host floor; ``g0``, ``k_eq`` from
    ``linearization.py``; for the linear law ``k_eq = -k``, ``g0 = k R``, ``R`` the rest offset).
    ``scenario_filters``: ``scene.scene_filters`` of its scenario."""
    return with_absorbers(bare(scene, scenario_filters), scene, k_eq, g0)


def with_absorbers(base: Model, scene, k_eq: np.ndarray, g0: np.ndarray) -> Model:
    """``base`` (``bare``) with the absorbers' equivalent springs (slopes ``k_eq``), their constant
    forces ``g0`` and their dashpots between each absorber and its host floor."""
    nb = base.n_bodies
    a, constant, feed = base.a.copy(), base.constant.copy(), base.feed.copy()
    inv_m = 1.0 / scene.mass
    for i in range(scene.kind.shape[0]):
        j, h = base.n_floors + i, int(scene.host[i])
        for offset, coefficient in ((0, -k_eq[i]), (nb, scene.rows[i, DAMPING])):
            for body, other in ((j, h), (h, j)):  # (a spring of -k_eq: k_eq is the force's slope)
                a[nb + body, offset + body] -= coefficient * inv_m[body]
                a[nb + body, offset + other] += coefficient * inv_m[body]
        for body, sign in ((j, 1.0), (h, -1.0)):
            constant[nb + body] += sign * g0[i] * inv_m[body]
            feed[body] += sign * g0[i] * inv_m[body]
    return replace(base, a=a, constant=constant, feed=feed)


def bare(scene, scenario_filters: list) -> Model:
    """The model of ``scene`` without its absorbers' attachments (their masses free)."""
    check_laws(scene)
    nb, nf = scene.mass.shape[0], scene.n_floors
    k, c = structure_matrices(scene)
    n_f = sum(f.a.shape[0] for f in scenario_filters)
    size = 2 * nb + n_f
    inv_m = 1.0 / scene.mass
    a_mat = np.zeros((size, size))
    a_mat[:nb, nb:2 * nb] = np.eye(nb)
    a_mat[nb:2 * nb, :nb] = -inv_m[:, None] * k
    a_mat[nb:2 * nb, nb:2 * nb] = -inv_m[:, None] * c
    columns, envelopes = [], []
    for floor in np.flatnonzero(scene.sigma):
        column = np.zeros(size)
        column[nb + floor] = scene.sigma[floor] * inv_m[floor]
        columns.append(column)
        envelopes.append(None)
    m0 = np.concatenate([scene.x0, scene.v0, np.zeros(n_f)])
    p0 = np.zeros((size, size))
    start = 2 * nb
    for f in scenario_filters:
        s = slice(start, start + f.a.shape[0])
        a_mat[s, s] = f.a
        column = np.zeros(size)
        column[s] = f.b
        columns.append(column)
        envelopes.append(f.envelope)
        if f.ground:  # every body: v' -= a_g
            a_mat[nb:2 * nb, s] -= np.outer(np.ones(nb), f.c)
        elif f.profile is not None:
            a_mat[nb:nb + nf, s] += (inv_m[:nf] * f.profile)[:, None] * f.c
        else:
            a_mat[nb + f.floor, s] += inv_m[f.floor] * f.c
        if f.stationary:
            p0[s, s] = stationary_covariance(f.a, f.b)
        start += f.a.shape[0]
    feed = np.zeros(nb)
    constant = np.zeros(size)
    harmonics = []
    for row in scene.forces:  # (harmonic rows only: check_laws)
        g, force = np.zeros(size, complex), np.zeros(nb, complex)
        phasor = row[1] * np.exp(1j * row[3])
        if int(row[FLOOR]) == GROUND:
            g[nb:2 * nb] = -phasor
        else:
            force[int(row[FLOOR])] = phasor * inv_m[int(row[FLOOR])]
            g[nb:2 * nb] = force
        if row[2] == 0.0:
            constant += g.real
            feed = feed + force.real
        else:
            harmonics.append((float(row[2]), g, force))
    ground = np.zeros(n_f)
    start = 0
    for f in scenario_filters:
        if f.ground:
            ground[start:start + f.a.shape[0]] = f.c
        start += f.a.shape[0]
    return Model(a=a_mat, noise=np.array(columns).T.reshape(size, len(columns)), envelopes=envelopes,
                 constant=constant, harmonics=harmonics, feed=feed, ground=ground, m0=m0, p0=p0,
                 n_bodies=nb, n_floors=nf, white_floors=tuple(int(k) for k in np.flatnonzero(scene.sigma)))


def hertz_rows(scene) -> np.ndarray:
    """The absorbers with Hertz contact."""
    return np.flatnonzero(scene.kind == HERTZ)
