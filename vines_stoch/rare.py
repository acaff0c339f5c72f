"""Rare-event estimates of a limit's exceedance probability ``P(peak > value)`` (``[rare]``):
adaptive multilevel splitting on the running peak, and subset simulation as its cross-check.

**Adaptive multilevel splitting** (Cerou and Guyader, Stoch. Anal. Appl. 25 (2007) 417; the
generalised algorithm of Brehier, Gazeau, Goudenege, Lelievre and Rousset, Ann. Appl. Probab.
26 (2016) 3559, unbiased for any score).  ``n`` paths run to the end; a path's score is a
running peak (``Score``): for a limit on a floor's displacement or a storey's drift, the running
peak of the primary's energy ``E1``, which bounds that displacement at every instant
(``energy_bound``) and, unlike the displacement's own peak, grows with the motion's amplitude
whatever its phase (for one storey it is the envelope ``x^2 + v^2 / w^2``); for the other
limits, the limited metric's own running peak.  At each level the ``k`` lowest scores fix the
level ``z``; every path whose score is ``<= z`` is killed (``K >= k`` of them, ties included) and
replaced by a branch of a survivor drawn at random: the survivor's path up to the first step its
score exceeded ``z`` (replayed on its own streams from its last snapshot,
``kernels.Path.branch``), fresh streams after it.  The levels rise until they pass the score
every exceeding path must reach; the estimate is ``prod (1 - K_j / n)`` times the fraction of
the final paths whose limited metric exceeds the limit (for an indicator that vanishes below
that score this is the generalised algorithm's unbiased estimator).  The paths are
the engine's own step loop run in stretches (``kernels.start_path``, ``advance``), so impacts,
Hertz contact, filtered loads and uncertain parameters are those of an ensemble run.  The
paths of a stage (the initial paths, a level's probes, leads and branches) run together
(``run_paths``): on the cuda backend as one batch of GPU threads (``gpu.advance_many``), on
Philox streams.

**Subset simulation** (Au and Beck, Probab. Eng. Mech. 16 (2001) 263) with the modified
Metropolis algorithm on the Gaussian inputs: the white-noise increments a path replays
(``start_path(..., normals=...)``), the standard normals of its filtered loads (replayed from a
tape as the filter stream, ``rng.tape``: ``kernels.filter_draws`` of them) and, with uncertain
parameters, one standard normal a parameter (its law's value of that normal, or of its
probability for a law drawn from a uniform: ``Parameters``), a level a fraction ``P0`` of the
samples, each seed a Markov chain of ``1 / P0`` states.  Where a scene also seeds Brownian trees
(impacts or contact under white noise), each candidate draws its seed afresh from the prior (an
independent proposal, accepted as the others only inside the level).

Both run in independent replicas, one after another in a fixed order, until the coefficient of
variation of their mean, ``sd / (mean sqrt(R))``, reaches the target (from
``MIN_REPLICAS`` replicas on) or the budget of path-equivalents (steps run over the steps of a
path, replays included) is spent: the reported ``cov`` is the replicas' own spread, and the 95 %
interval Student's ``t`` on it.  Every replica's streams are keyed by (seed, purpose, sweep point,
replica, draw), so an estimate depends on nothing else.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .kernels import Path, advance, filter_draws, general_run, needed_streams, start_path
from .outputs import DRIFT_MAX_K, E1_MAX, LIMIT_E1, SLOTS, X_MAX_K, passage_slots
from .schemes import SCHEMES
from .streams import RARE, Streams
from .streams.pcg import state_of
from .streams.rng import keyed_stream, stream_key, tape

#: Methods of ``[rare]``.
METHODS = ("splitting", "subset")
#: Replicas before the coefficient of variation may stop an estimate (its spread needs a few).
MIN_REPLICAS = 5
#: Snapshots kept along a splitting path (a branch replays at most two stretches between them).
SNAPSHOTS = 32
#: Subset simulation: the fraction of samples that seeds the next level, and the proposal's
#: standard deviation of the modified Metropolis algorithm (per standard normal input).
P0, PROPOSAL = 0.1, 1.0
#: Subset simulation's most levels (``P0 ** 64``: far below any probability asked for).
MAX_LEVELS = 64
#: Sub-purposes of the rare-event streams (the key's second element).
PATHS, SELECTION, INPUTS = 0, 1, 2


def energy_bound(scene, limit: int) -> float | None:
    """``K`` with ``peak^2 <= 2 E1 / K`` at every instant for limit row ``limit`` of ``scene``
    (``scene.limit_row``), where one holds: a floor's displacement ``x_k = d_1 + ... + d_k`` is
    bounded by the strain energy of the storeys below it (Cauchy-Schwarz: ``x_k^2 <= (sum 1 /
    k_i) sum k_i d_i^2``, so ``K`` is the storeys' series stiffness), a storey's drift by its own
    (``K = k_k``); ``E1`` holds both strain energies (MODEL.md section 4).  None for the other
    limits, or where a storey on the way has no spring."""
    code, k = int(scene.limits[limit, 0]), int(scene.limits[limit, 1])
    springs = scene.storey_k
    if code == X_MAX_K or (code == DRIFT_MAX_K and k == 0):
        springs = springs[:k + 1]
    elif code == DRIFT_MAX_K:
        springs = springs[k:k + 1]
    else:
        return None
    return float(1.0 / np.sum(1.0 / springs)) if (springs > 0.0).all() else None


@dataclass(frozen=True)
class Score:
    """What a splitting path's score is: the running peak a limit row ``row`` watches (its code
    and floor, ``scene.limit_row``'s; its value 0), read as ``peak`` reads it, and ``top``, the
    score every path whose limited metric exceeds the limit's value has exceeded (the levels'
    end).  With ``energy`` the row is the primary's energy (``LIMIT_E1``) and ``top`` the energy
    ``K value^2 / 2`` of ``energy_bound`` (less a relative 1e-9 against rounding); ``scale``
    turns a score into the limited quantity's units over the limit (the levels reported)."""

    row: np.ndarray
    top: float
    energy: bool

    @classmethod
    def of(cls, scene, limit: int, bounds: set) -> Score:
        """The score of a splitting replica whose paths' scenes give the ``energy_bound``s
        ``bounds`` (the energy only where every path has the same bound)."""
        code, floor, value = (float(x) for x in scene.limits[limit])
        bound = next(iter(bounds)) if len(bounds) == 1 else None
        if bound is None:
            return cls(np.array([code, floor, 0.0]), value, False)
        return cls(np.array([float(LIMIT_E1), 0.0, 0.0]), 0.5 * bound * value * value * (1.0 - 1e-9), True)

    def scale(self, level: float) -> float:
        return math.sqrt(level / self.top) if self.energy else level / self.top


def peak(out: np.ndarray, row: np.ndarray, nf: int) -> float:
    """The running peak a limit row (``scene.limit_row``: code, floor, value) watches, read from
    a raw metric vector (as ``kernels.common.first_passages`` reads it in the loop)."""
    code, k = int(row[0]), int(row[1])
    if code == LIMIT_E1:
        return float(out[E1_MAX])
    if code == DRIFT_MAX_K and k == 0:
        code = X_MAX_K
    return float(out[len(SLOTS) + code * nf + k])


@dataclass
class Replica:
    """One replica's estimate: ``p``, the path-equivalents it spent, its levels (splitting: the
    level ``z_j`` and the survivors' fraction ``1 - K_j / n`` of each; subset: the thresholds)."""

    p: float
    paths: float
    levels: list[tuple[float, float]] = field(default_factory=list)


@dataclass
class Estimate:
    """A rare-event estimate: the mean ``p`` of the replicas, its coefficient of variation and
    95 % interval, the path-equivalents spent and the replicas themselves."""

    p: float
    cov: float
    p_lo: float
    p_hi: float
    paths: float
    levels: float
    method: str
    replicas: list[Replica]

    def row(self) -> dict[str, object]:
        """rare.parquet's columns."""
        return {"p": self.p, "cov": self.cov, "p_lo": self.p_lo, "p_hi": self.p_hi, "paths": self.paths,
                "levels": self.levels, "replicas": len(self.replicas), "method": self.method}


@dataclass(frozen=True)
class Parameters:
    """Subset simulation's uncertain parameters: their laws (``[uncertain]``, file order) and
    ``scene(values)``, the sweep point's scene with those values (``binding.Binding.scene``)."""

    laws: dict
    scene: Callable[[dict[str, float]], object]

    def at(self, z: np.ndarray) -> object:
        """The scene at standard normal inputs ``z`` (one a parameter): each law's value of its
        normal, or of ``Phi(z)`` for a law drawn from a uniform (``distributions``)."""
        from scipy.special import ndtr

        values = {key: float(law.value(np.array([z[k] if law.normal else min(max(ndtr(z[k]), 1e-16),
                                                                                   1.0 - 1e-16)]))[0])
                  for k, (key, law) in enumerate(self.laws.items())}
        return self.scene(values)


def rare_streams(seed: int, point: int, replica: int, draw: int, scene, philox: bool = False) -> Streams:
    """The streams of path ``draw`` of a rare-event replica, keyed by (seed, ``RARE``, point,
    replica, draw, purpose); only those ``scene`` draws from (``kernels.needed_streams``), each as
    the loop's PCG64 stream (``pcg.state_of``), which a path run in stretches carries from one to
    the next without a numpy generator to keep in step; with ``philox`` (the cuda backend) as
    Philox streams keyed by (seed, ``RARE``, point, replica, purpose), the draw their place."""
    def gen(purpose: int) -> np.ndarray:  # (the loop's own stream: nothing to sync back)
        if philox:
            return keyed_stream(stream_key(seed, RARE, PATHS, point, replica, purpose), draw)
        key = (RARE, PATHS, point, replica, draw, purpose)
        return state_of(np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=key))))

    increments, bridge, filters = needed_streams(scene)
    return Streams(gen(0) if increments else None, gen(1) if bridge else None, gen(2) if filters else None)


def _general(work: int, backend: str) -> bool | None:
    """``start_path``'s ``general`` for the paths of a run of ``work`` path-steps on ``backend``:
    the loops specialised to the structure for a long run; for a short one the general loop, or on
    the CPU ``start_path``'s own choice (None: the specialised loop where it is compiled already,
    ``kernels.keeps_general``; the GPU compiles loops of its own)."""
    short = general_run(work)
    return None if short and backend == "cpu" else short


def run_paths(paths: list[Path], stops: list[int], backend: str = "cpu") -> None:
    """Run each of ``paths`` to its stop: one after the other on the CPU (``kernels.advance``),
    or together on the GPU (``backend = "cuda"``: ``gpu.advance_many``, one path a thread)."""
    if backend == "cuda":
        from . import gpu

        gpu.advance_many(paths, stops)
    else:
        for path, stop in zip(paths, stops):
            advance(path, stop)


def _chooser(seed: int, point: int, replica: int, purpose: int) -> np.random.Generator:
    """A replica's own generator of ``purpose`` (``SELECTION``: which survivors are branched;
    ``INPUTS``: subset simulation's inputs and proposals)."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(
        seed, spawn_key=(RARE, purpose, point, replica))))


class _Particle:
    """A splitting path: the path (run to the end), its snapshots (copies never run themselves,
    shared with the particles branched from it; ``_Splitting``) with the score at each, its
    score at the end and whether its limited metric exceeds the limit's value."""

    __slots__ = ("path", "snaps", "peaks", "score", "exceeds")

    def __init__(self, path: Path, snaps: list[Path], peaks: list[float]):
        self.path, self.snaps, self.peaks, self.score, self.exceeds = path, snaps, peaks, 0.0, False


class _Splitting:
    """One replica of adaptive multilevel splitting (see the module).  A particle keeps a snapshot
    every ``stride`` steps and one at the step it was branched at, so that the first passage of a
    level is found by replaying one stretch: its first snapshot after the passage comes at most a
    stride after it.  The paths of a stage (the initial paths, a level's probes, leads and
    branches) run together (``run_paths``: on the GPU one a thread)."""

    def __init__(self, scenes: Callable[[int], object], limit: int, seed: int, point: int, replica: int,
                 n: int, backend: str = "cpu"):
        self.limit, self.seed, self.point, self.replica, self.backend = limit, seed, point, replica, backend
        self.scenes = [scenes(j) for j in range(n)]  # (the initial paths' scenes)
        self.first = self.scenes[0]
        self.score = Score.of(self.first, limit, {energy_bound(scene, limit) for scene in self.scenes})
        self.value = float(self.first.limits[limit, 2])
        self.n_steps, self.nf = self.first.n_steps, self.first.n_floors
        self.stride = max(1, -(-self.n_steps // SNAPSHOTS))
        self.steps = 0  # (steps run, replays included)
        self.draws = 0

    def _fresh(self) -> Streams:
        """The streams of the next path drawn (an initial path, or a branch after its branching
        step)."""
        self.draws += 1
        return rare_streams(self.seed, self.point, self.replica, self.draws - 1, self.first,
                            self.backend == "cuda")

    def _peak(self, path: Path) -> float:
        """The path's score so far (``Score``)."""
        return peak(path.out, self.score.row, self.nf)

    def _advance(self, paths: list[Path], stops: list[int]) -> None:
        self.steps += sum(stop - path.step for path, stop in zip(paths, stops))
        run_paths(paths, stops, self.backend)

    def _run(self, particles: list[_Particle]) -> list[_Particle]:
        """Run ``particles`` from the steps they have reached to the end, a snapshot at each
        stride."""
        going = [p for p in particles if p.path.step < self.n_steps]
        while going:
            stops = [min(self.n_steps, (p.path.step // self.stride + 1) * self.stride) for p in going]
            self._advance([p.path for p in going], stops)
            for particle, stop in zip(going, stops):
                if stop < self.n_steps:
                    particle.snaps.append(particle.path.branch())
                    particle.peaks.append(self._peak(particle.path))
            going = [p for p in going if p.path.step < self.n_steps]
        for particle in particles:
            path = particle.path
            particle.score = self._peak(path)
            particle.exceeds = peak(path.out, path.args[6].limits[self.limit], self.nf) > self.value
        return particles

    def start(self) -> list[_Particle]:
        """The initial paths, each on its own streams, run to the end."""
        general = _general(len(self.scenes) * self.n_steps, self.backend)  # (the initial paths' work)
        paths = [start_path(scene, self._fresh(), general=general) for scene in self.scenes]
        return self._run([_Particle(path, [path.branch()], [self._peak(path)]) for path in paths])

    def branch(self, survivors: list[_Particle], level: float) -> list[_Particle]:
        """New particles, one a survivor: the survivor up to the first step its score exceeded
        ``level``, fresh streams from there on."""
        plans = []
        for survivor in survivors:
            b = int(np.searchsorted(np.array(survivor.peaks) > level, True)) - 1  # (the last at or below it)
            snap = survivor.snaps[b]
            stop = survivor.snaps[b + 1].step if b + 1 < len(survivor.snaps) else self.n_steps
            # the level's first passage: the stretch replayed with the limit's row watching the
            # score, its value set to the level (its first-passage slot is still NaN at the
            # snapshot: the level lies below the top, which an exceeding path passes first)
            probe = snap.branch()
            outputs = probe.args[6]
            limits = outputs.limits.copy()
            limits[self.limit] = (*self.score.row[:2], level)
            probe.args = (*probe.args[:6], outputs._replace(limits=limits), *probe.args[7:])
            plans.append((survivor, b, snap, stop, probe))
        self._advance([plan[4] for plan in plans], [plan[3] for plan in plans])
        leads, ats = [], []
        for _, _, snap, stop, probe in plans:
            t = probe.out[passage_slots(self.nf) + self.limit]
            at = int(round(t / probe.args[5].dt))
            if not snap.step < at <= stop:
                raise RuntimeError(f"splitting: the level's first passage ({t}) lies outside the replayed "
                                   f"stretch ({snap.step}, {stop}]")
            leads.append(snap.branch())
            ats.append(at)
        self._advance(leads, ats)
        children = []
        for (survivor, b, *_), lead in zip(plans, leads):
            child = lead.branch(self._fresh())
            # (the survivor's snapshots up to the branching step are the child's too, then its own)
            children.append(_Particle(child, [*survivor.snaps[:b + 1], child.branch()],
                                      [*survivor.peaks[:b + 1], self._peak(child)]))
        return self._run(children)


def splitting(scenes: Callable[[int], object], limit: int, n: int, kill: int, seed: int, point: int,
              replica: int, backend: str = "cpu") -> Replica:
    """One replica of adaptive multilevel splitting with ``n`` paths, at least ``kill`` killed a
    level; ``scenes(j)``: the scene of initial path ``j`` (the sweep point's, or with its own
    uncertain parameters); ``limit``: the row of the scene's limits; ``backend``: where the
    paths run (``run_paths``).  Scores are running peaks, compared as the loop compares them
    with a limit's value (``peak > value``)."""
    run = _Splitting(scenes, limit, seed, point, replica, n, backend)
    top = run.score.top
    chooser = _chooser(seed, point, replica, SELECTION)
    particles = run.start()
    weight, levels = 1.0, []
    while True:
        scores = np.array([p.score for p in particles])
        level = float(np.partition(scores, kill - 1)[kill - 1])
        if level >= top:
            break
        killed = np.flatnonzero(scores <= level)
        if killed.shape[0] == n:  # (every path at the level: none above it)
            weight = 0.0
            break
        survivors = np.flatnonzero(scores > level)
        weight *= 1.0 - killed.shape[0] / n
        levels.append((run.score.scale(level), 1.0 - killed.shape[0] / n))
        parents = survivors[chooser.integers(0, survivors.shape[0], killed.shape[0])]
        for i, child in zip(killed, run.branch([particles[parent] for parent in parents], level)):
            particles[i] = child
    above = sum(p.exceeds for p in particles)
    return Replica(weight * above / n, run.steps / run.n_steps, levels)


def subset(scene, limit: int, n: int, seed: int, point: int, replica: int,
           parameters: Parameters | None = None, backend: str = "cpu") -> Replica:
    """One replica of subset simulation with ``n`` samples a level (``n P0`` chains of ``1 /
    P0`` states) on the standard normal inputs of ``scene``'s noise (the white-noise increments
    and the filters' normals, replayed from a tape: ``rng.tape``) and the uncertain
    ``parameters`` (see the module).  The chains move together, a state at a time, their
    candidates run as one batch (``run_paths``: on the GPU with ``backend = "cuda"``)."""
    noise = (scene.n_steps * SCHEMES[scene.scheme].normals * max(scene.noisy_floors, 1)
             if scene.has_white_noise else 0)
    filtered = filter_draws(scene)
    if noise + filtered == 0:
        raise ValueError("rare.method = 'subset': samples the standard normal inputs of a scene's noise; "
                         "this scene has none")
    dim = noise + filtered + (len(parameters.laws) if parameters is not None else 0)
    rng = _chooser(seed, point, replica, INPUTS)
    general = _general(n * scene.n_steps, backend)  # (a level's work, at least)
    row = scene.limits[limit]
    value = float(row[2])
    seeded = needed_streams(scene)[1]
    cuda = backend == "cuda"
    # (on the GPU every place holds a counter-based stream: the increments' an empty Philox one)
    unused = keyed_stream(0, 0) if cuda and noise else None

    def scores(inputs: np.ndarray, draws: np.ndarray) -> np.ndarray:
        """The scores of the samples ``inputs`` (a row each), sample ``k`` drawing its Brownian
        trees' seed as draw ``draws[k]``."""
        paths = []
        for u, draw in zip(inputs, draws):
            own = scene if parameters is None else parameters.at(u[noise + filtered:])
            bridge = rare_streams(seed, point, replica, int(draw), scene, cuda).bridge if seeded else None
            streams = Streams(unused, bridge, tape(u[noise:noise + filtered]) if filtered else None)
            paths.append(start_path(own, streams, normals=u[:noise] if noise else None, stretches=False,
                                    general=general))
        run_paths(paths, [scene.n_steps] * len(paths), backend)
        return np.array([peak(path.out, row, scene.n_floors) for path in paths])

    chain = round(1 / P0)
    seeds = max(1, n // chain)
    u = rng.standard_normal((seeds * chain, dim))
    y = scores(u, np.arange(u.shape[0]))
    count = u.shape[0]
    p, levels = 1.0, []
    while len(levels) < MAX_LEVELS:
        order = np.argsort(y)[::-1]
        # (the level halfway between the seeds' lowest and the next: every seed lies above it)
        level = 0.5 * float(y[order[seeds - 1]] + y[order[seeds]])
        if level >= value:
            break
        levels.append((level / value, P0))
        p *= P0
        # the proposals and the acceptance draws of the modified Metropolis moves, chain by
        # chain (the order of a chain run to its end before the next)
        steps = [[(PROPOSAL * rng.standard_normal(dim), rng.random(dim)) for _ in range(chain - 1)]
                 for _ in range(seeds)]
        cu, cy = u[order[:seeds]].copy(), y[order[:seeds]].copy()
        new_u, new_y = np.empty_like(u), np.empty_like(y)
        new_u[::chain], new_y[::chain] = cu, cy
        for step in range(1, chain):  # (component by component, then the level)
            candidates = np.empty_like(cu)
            for c in range(seeds):
                xi, draw = steps[c][step - 1]
                xi = cu[c] + xi
                candidates[c] = np.where(draw < np.exp(-0.5 * (xi * xi - cu[c] * cu[c])), xi, cu[c])
            # (a candidate draws its Brownian trees' seed as it did when each chain ran to its end
            # before the next: candidate ``c`` of this step as the level's ``c (chain - 1) + step
            # - 1``-th)
            y_candidates = scores(candidates, count + np.arange(seeds) * (chain - 1) + step - 1)
            above = y_candidates > level
            cu[above], cy[above] = candidates[above], y_candidates[above]
            new_u[step::chain], new_y[step::chain] = cu, cy
        count += seeds * (chain - 1)
        u, y = new_u, new_y
    return Replica(p * float(np.mean(y > value)), float(count), levels)


def combine(replicas: list[Replica], method: str) -> Estimate:
    """The replicas' mean, with its coefficient of variation and 95 % Student-t interval."""
    from scipy import stats  # (scipy.stats takes about 0.5 s to import: only where used)

    ps = np.array([r.p for r in replicas])
    mean = float(ps.mean())
    m = ps.shape[0]
    sem = float(ps.std(ddof=1) / math.sqrt(m)) if m > 1 else math.inf
    cov = sem / mean if mean > 0 else math.inf
    half = float(stats.t.ppf(0.975, m - 1)) * sem if m > 1 else math.inf
    levels = float(np.mean([len(r.levels) for r in replicas]))
    spent = float(sum(r.paths for r in replicas))
    return Estimate(mean, cov, max(0.0, mean - half), mean + half, spent, levels, method, replicas)


def estimate(scenes: Callable[[int], object], limit: int, method: str, seed: int, point: int, *,
             particles: int, target_cov: float, max_paths: float, kill: float = 0.1,
             replicas: int | None = None, note: Callable[[Estimate], None] | None = None,
             parameters: Parameters | None = None, done: list[Replica] | None = None,
             backend: str = "cpu") -> Estimate:
    """Replicas of ``method`` (``n = particles`` paths or samples each; splitting kills at least a
    fraction ``kill`` a level; subset simulation samples the uncertain ``parameters`` with the
    noise, where a scene has them) in stages: ``MIN_REPLICAS`` first, then as many more as their
    spread says the target needs (``R cov^2 / target_cov^2`` in all), until the coefficient of
    variation reaches ``target_cov`` at the end of a stage or ``max_paths`` path-equivalents are
    spent (with ``replicas``: exactly that many).  Testing the spread only at the end of a stage
    keeps the estimate from stopping on a lucky run of replicas, as testing after each would
    (the replicas' law is skewed: a low spread comes with a low mean).  ``note`` is called with
    the estimate so far after each replica run; ``done``: the first replicas, already run (a
    resumed estimate: its stages are taken again over them, so it stops where the estimate run
    in one go stops); ``backend``: where the paths run (``run_paths``)."""
    kept: list[Replica] = []
    goal = replicas if replicas is not None else MIN_REPLICAS
    while True:
        r = len(kept)
        if done is not None and r < len(done):
            kept.append(done[r])
        else:
            if method == "splitting":
                kill_at_least = max(1, int(kill * particles))
                kept.append(splitting(scenes, limit, particles, kill_at_least, seed, point, r, backend))
            else:
                kept.append(subset(scenes(0), limit, particles, seed, point, r, parameters, backend))
        result = combine(kept, method)
        if note is not None and len(kept) > len(done or ()):  # (after each replica run here)
            note(result)
        if replicas is None and result.paths >= max_paths:
            return result
        if len(kept) < goal:
            continue
        if replicas is not None or result.cov <= target_cov:
            return result
        if math.isfinite(result.cov):
            goal = max(goal + 1, math.ceil(len(kept) * (result.cov / target_cov) ** 2))
        else:  # (no replica above the limit yet: double)
            goal = 2 * len(kept)


def _saved_replicas(saved, point: int) -> list[Replica]:
    """The replicas of sweep point ``point`` a ``store.Saved`` holds (``_save_replicas``)."""
    ps, paths, counts = (saved.get(f"rare.{point}.{name}") for name in ("p", "paths", "counts"))
    if ps is None:
        return []
    levels = saved.get(f"rare.{point}.levels").reshape(-1, 2)
    ends = np.cumsum(counts)
    return [Replica(float(p), float(spent), [(float(z), float(f)) for z, f in levels[end - count:end]])
            for p, spent, count, end in zip(ps, paths, counts, ends)]


def _save_replicas(saved, point: int, replicas: list[Replica]) -> None:
    """Keep a sweep point's replicas in ``saved`` (a ``store.Saved``)."""
    levels = [level for r in replicas for level in r.levels]
    saved.put({f"rare.{point}.p": np.array([r.p for r in replicas]),
               f"rare.{point}.paths": np.array([r.paths for r in replicas]),
               f"rare.{point}.counts": np.array([len(r.levels) for r in replicas], np.int64),
               f"rare.{point}.levels": np.array(levels, dtype=float).reshape(-1, 2)})


def table(study, scene_of: Callable[[int, int], object], progress: bool = False,
          scene_at: Callable[[int, dict[str, float]], object] | None = None, saved=None,
          backend: str = "cpu") -> pd.DataFrame:
    """rare.parquet: one row per sweep point of ``study`` (its ``[rare]`` table): the point, its
    swept values, the estimate (``Estimate.row``), and as lists the replicas' estimates and
    path-equivalents (the estimate's convergence) and the first replica's levels (splitting:
    ``z_j``; subset: the intermediate thresholds, over the limit's value).  ``scene_of(point,
    j)``: the scene of path ``j`` of a point (its uncertain parameters drawn as realisation
    ``j``'s); ``scene_at(point, values)``: the point's scene with the uncertain parameters
    ``values`` (subset simulation's, where the study has them); ``saved``: a ``store.Saved`` that
    keeps each point's replicas as they end and gives back those of an interrupted run (the
    estimate goes on from them, to the same numbers); ``backend``: where the paths run
    (``run_paths``)."""
    spec, seed = study.base.rare, study.base.ensemble.seed
    cr = "\r" if sys.stderr.isatty() else ""
    limit = list(study.base.limits).index(spec.limit)
    rows = []
    for point in range(len(study.points)):
        def note(e: Estimate, point: int = point) -> None:
            if saved is not None:
                _save_replicas(saved, point, e.replicas)
            if progress:  # (one line, rewritten on a terminal; a line a replica in a log)
                print(f"{cr}rare: point {point}: p = {e.p:.3g}, cov {e.cov:.2f}, {len(e.replicas)} replicas, "
                      f"{e.paths:.0f} path-equivalents", end="" if cr else "\n", file=sys.stderr, flush=True)

        parameters = None
        if spec.method == "subset" and study.base.uncertain and scene_at is not None:
            parameters = Parameters(study.base.uncertain, lambda values, point=point: scene_at(point, values))
        result = estimate(lambda j, point=point: scene_of(point, j), limit, spec.method, seed, point,
                          particles=spec.n, target_cov=spec.target_cov, max_paths=spec.max_paths,
                          kill=spec.kill, note=note, parameters=parameters,
                          done=_saved_replicas(saved, point) if saved is not None else None,
                          backend=backend)
        if progress and cr:
            print(file=sys.stderr)
        rows.append({"point": point, **{k: study.grid[point][k] for k in study.sweep_keys}, **result.row(),
                     "limit": spec.limit,
                     "replica_p": [r.p for r in result.replicas],
                     "replica_paths": [r.paths for r in result.replicas],
                     "level_values": [z for z, _ in result.replicas[0].levels]})
    return pd.DataFrame(rows)
