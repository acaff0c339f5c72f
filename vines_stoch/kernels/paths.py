"""One realisation's path: the loop a scene runs (``kernel_for``), its arguments (``bundles``), its
streams, and the path run in one go (``simulate``) or in stretches (``start_path``, ``advance``).
"""

from __future__ import annotations

import copy
import importlib
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..environment import GENERAL_SWITCH, GENERAL_WORK, general_problem, general_work
from ..jit.cache import NotCompiled, compile_once, compiling_nothing, refusing
from ..outputs import EVENT_COLUMNS, SLOTS, new_events, new_metrics
from ..schemes import SCHEMES
from ..signals import declare
from ..streams import Streams
from ..streams.pcg import set_state, state_of
from ..streams.rng import STREAM_WORDS, uniform
from .bundles import Absorbers, Bodies, Filters, Grid, Loads, Noise, Outputs
from .carry import SEED_HIGH, SEED_LOW, new_carry
from .driver import step_loop
from .loads import load_path, stationary_start
from .protocol import BODY_ROOM, ROOM, RUN_TIME, Spec

_NO_NORMALS = np.zeros(0)
#: A stream the kernel has no use for: an empty Philox stream (``rng.philox_stream``), never drawn
#: from (every stream is one type, ``streams.kinds``: a loop given it compiles nothing more).
_UNUSED = np.zeros(STREAM_WORDS, np.uint64)
_NO_HISTORY = np.zeros((0, 2))
_NO_SIGNALS = np.zeros((0, 2), np.int64)
_NO_EVENTS = new_events(0)
#: The carry of a path run in one go: none kept.
_NO_CARRY = np.zeros(0)
#: The loops this process has run, with the kinds of their generators (``cache.compile_once``
#: saw them first: a loop given PCG64 and then Philox streams compiles twice, both times with
#: the faster front end).
_STARTED: set = set()
#: The loops, with the kinds of their generators, that a look compiling nothing
#: (``jit.cache.compiling_nothing``) found neither compiled nor on disk: looked for once a process.
_MISSED: set = set()


def step_of(name: str):
    """The ``protocol.Step`` factory of the step a scheme names (``schemes.Scheme.step``): the
    function ``<name>_step`` of ``kernels/<name>.py``, so that a new scheme is one file and one
    line of the registry."""
    return getattr(importlib.import_module(f"{__package__}.{name}"), f"{name}_step")


def spec_of(scene, gpu: bool = False, lanes: bool = False, general: bool = False) -> Spec:
    """What a scene's loop is specialised to (``protocol.Spec``); what its scheme does not use is
    left out (white noise and filtered loads of the RK4 step, the filter states of steps that
    read none from the grid; the RK4 step reads its load rows' count, for their phasors), so that
    one loop serves the scenes that differ only there.  The load rows and filter states, up to
    ``protocol.ROOM`` of each, are sizes the scalar loop reads at run time (``protocol.RUN_TIME``:
    a new force or filter compiles nothing); the cuda loop (``gpu``: a thread's arrays on its
    stack, of sizes known when it compiles) and the lanes' row layout (``lanes``) take them as
    constants.  ``general``: the scheme's general scalar loop, which reads every size and kind
    at run time (``protocol.KINDS``; the bodies and floors within ``protocol.BODY_ROOM`` and
    ``protocol.ROOM``, else constants of a loop of their own): one loop serves every structure
    of the scheme."""
    step = SCHEMES[scene.scheme].step
    grid = step != "rk4"
    bodies, floors = scene.mass.shape[0], scene.n_floors
    rows, states = scene.forces.shape[0], scene.filters["phi"].shape[0]
    constant = gpu or lanes
    sized = constant or not general or bodies > BODY_ROOM or floors > ROOM
    kind = (lambda present: present) if constant or not general else (lambda present: RUN_TIME)
    return Spec(n_bodies=bodies if sized else RUN_TIME, n_floors=floors if sized else RUN_TIME,
                n_rows=rows if constant or rows > ROOM else RUN_TIME,
                n_states=(states if constant or states > ROOM else RUN_TIME) if grid else 0,
                has_noise=kind(scene.has_white_noise) if grid else False, has_impact=kind(scene.has_impact),
                has_hertz=kind(scene.has_hertz), partners=kind(scene.has_partners),
                filtered=kind(scene.has_filters) if grid else False,
                ground=kind(scene.has_ground) if grid else False, shaped=kind(scene.has_shaped), gpu=gpu)


def general_run(path_steps: int) -> bool:
    """Whether a run of ``path_steps`` path-steps (realisations times steps, all sweep points
    together) runs a loop compiled once for every structure, the general loop of its scheme
    (``spec_of``; or the pass loop where it takes a chunk's lanes, ``chunk.in_pass_loop``):
    below ``GENERAL_WORK`` (10^8), or below ``VINES_STOCH_GENERAL_WORK`` where that is
    set (``environment.general_work``).  A longer run takes a loop specialised to its structure,
    compiled for it (and cached): at 10-25 M path-steps/s on one core the general loop runs 10^8
    path-steps in about the 10-20 s that compiling a specialised loop takes, which then runs 2-3x
    faster (and in SIMD lanes, where the scheme has them, up to about 13x).  The two give the same numbers,
    bitwise (``tests/unit/kernels/test_general_loop.py``).  An ensemble counts the path-steps of
    the chunks that a short run gives to the pass loop and a long one would not 8 times cheaper
    (``ensemble.planning.PASS_WORK``)."""
    work = general_work()
    if work is None:
        raise ValueError(general_problem())
    return path_steps < work


def keeps_general(general: bool, specialised: Callable[[], bool]) -> bool:
    """Whether a run whose work makes it short (``general``, ``general_run``) takes the general
    loops: unless ``VINES_STOCH_GENERAL_WORK`` is unset (set, the work alone decides) and
    ``specialised()`` finds the loops specialised to its structures compiled already, in this
    process or on disk (looking compiles no loop: ``compiled_already``).  The two give the same
    numbers, bitwise; the specialised loops run 2-3x faster, in SIMD lanes up to about 13x."""
    return general and (GENERAL_SWITCH in os.environ or not specialised())


def compiled_already(run: Callable[[], Any]) -> bool:
    """Whether ``run`` (a call that compiles or loads its loops first: ``compile_first``) runs
    with no loop compiled: each compiled in this process already, or loaded now from the cache on
    disk (``jit.cache.compiling_nothing``)."""
    try:
        with compiling_nothing():
            run()
    except NotCompiled:
        return False
    return True


def kernel_for(scene, gpu: bool = False, general: bool = False):
    """The compiled loop for a scene's scheme and structure: the loop driver around the
    scheme's step (``driver.step_loop``; ``gpu``: the loop the cuda backend compiles; ``general``:
    the scheme's general loop, ``spec_of``).  It records what its output arrays ask
    (``common.recording``)."""
    spec = spec_of(scene, gpu, general=general)
    return step_loop(step_of(SCHEMES[scene.scheme].step)(spec), spec)


def sample_buffer(scene) -> np.ndarray:
    """Empty Poincare sample rows (positions, velocities, impacts left and right)."""
    if scene.period <= 0:
        return np.empty((0, 2 * scene.mass.shape[0] + 2))
    return np.full((scene.n_samples, 2 * scene.mass.shape[0] + 2), np.nan)


def filter_tuple(scene, generator: np.random.Generator | np.ndarray | None) -> Filters:
    """The kernels' filter arrays with the initial filter state: zero (from rest) or a draw
    from the stationary law (``p0`` is the root of its covariance) from ``generator`` (the
    filter stream: a PCG64 or Philox stream, or a numpy Generator, ``loads.stationary_start``;
    None: from rest);
    then the next state's and the normals' scratch (``loads.advance_filters``)."""
    f = scene.filters
    z = np.zeros(f["phi"].shape[0])
    if z.shape[0] and generator is not None:  # (a sum in a fixed order, not a BLAS product: the
        # same bits on every machine; no generator: from rest, as ``chunk.simulate_chunk`` starts)
        stationary_start(f["p0"], generator, z, np.zeros(z.shape[0]))
    return Filters(phi=f["phi"], chol=f["chol"], envelope=f["envelope"], c_force=f["c_force"],
                   c_ground=f["c_ground"], z=z, zn=z.copy(), draws=np.zeros(z.shape[0]))


def needed_streams(scene, replay: bool = False) -> tuple[bool, bool, bool]:
    """Which streams a scene's kernel draws from: step increments (white noise not replayed),
    the seed of the Brownian trees inside the steps (white noise with impact or Hertz
    absorbers: ``brownian``), filter noise (filtered loads)."""
    white = scene.has_white_noise
    return white and not replay, white and (scene.has_impact or scene.has_hertz), scene.has_filters


def filter_draws(scene) -> int:
    """The standard normals a path of ``scene`` draws from its filter stream: one a filter state
    for a stationary start (``loads.stationary_start``), then one a state and step
    (``loads.advance_filters``); 0 where its scheme reads no filtered load."""
    if not spec_of(scene).filtered:
        return 0
    states = scene.filters["phi"].shape[0]
    return states * (scene.n_steps + int(bool(np.any(scene.filters["p0"] != 0.0))))


def _streams_for(scene, replay: bool, streams: Streams | np.random.Generator | None) -> tuple[tuple, tuple]:
    """The kernel's generators (increments, bridge, filter), and the numpy generators they stand
    for (``_as_streams``).  A generator is passed only where the kernel draws from it, the stream
    ``_UNUSED`` elsewhere (an array costs next to nothing to pass); a stream array given is passed
    all the same.  Every stream is one type (``streams.kinds``), so a path, a replayed path, a
    chunk of either executor and the cuda backend's simulator run one loop, compiled once."""
    wanted = needed_streams(scene, replay)
    if isinstance(streams, np.random.Generator):
        streams = Streams.shared(streams)
    chosen = (None, None, None) if streams is None else (streams.increments, streams.bridge, streams.filter)
    if streams is None and any(wanted):
        raise ValueError("streams: this scene draws random numbers (white or filtered noise, or the "
                         "Brownian trees' seed of impacts and contact under white noise); pass a numpy "
                         "generator (one for every purpose) or vines_stoch.streams.Streams")
    for name, want, gen in zip(("increments", "bridge", "filter"), wanted, chosen):
        if want and gen is None:
            raise ValueError(f"streams: this scene draws from the {name} stream; it is None")
    gens = [gen if want or isinstance(gen, np.ndarray) else _UNUSED for want, gen in zip(wanted, chosen)]
    return _as_streams(gens)


def _as_streams(gens: Sequence) -> tuple[tuple, tuple]:
    """``gens`` with each numpy Generator of a ``PCG64`` bit generator replaced by its stream
    (``pcg.state_of``: the loop an ensemble runs, and the same numbers; one stream for a
    generator given in several places), and the pairs ``(generator, stream)`` whose state goes
    back to the generator after each use (``_sync``)."""
    pairs: dict[int, tuple] = {}
    out = []
    for gen in gens:
        if isinstance(gen, np.random.Generator):
            pair = pairs.setdefault(id(gen), (gen, state_of(gen)))
            gen = gen if pair[1] is None else pair[1]
        out.append(gen)
    return tuple(out), tuple(pair for pair in pairs.values() if pair[1] is not None)


def _sync(sources: tuple, back: bool = True) -> None:
    """The streams of ``sources`` (``_as_streams``) written back to their generators (``back``),
    or read from them again (a user may draw from a generator between two stretches)."""
    for gen, stream in sources:
        if back:
            set_state(gen, stream)
        else:
            state_of(gen, stream)


def _streams_for_copy(gens: list, streams: Streams | np.random.Generator) -> tuple[tuple, tuple]:
    """The generators of a branch on ``streams``: each place a path's loop draws from (a
    generator that is not the unused stream ``_UNUSED``) takes the stream of its purpose."""
    if isinstance(streams, np.random.Generator):
        streams = Streams.shared(streams)
    chosen = (streams.increments, streams.bridge, streams.filter)
    fresh = []
    for name, old, new in zip(("increments", "bridge", "filter"), gens, chosen):
        if old is _UNUSED:
            fresh.append(old)
        elif new is None:
            raise ValueError(f"branch: this path draws from the {name} stream; it is None")
        else:
            fresh.append(new)
    return _as_streams(fresh)


def loads_of(scene) -> Loads:
    """A scene's loads bundle (``kernels/loads.py``)."""
    return Loads(forces=scene.forces, series_t=scene.series_t, series_v=scene.series_v,
                 series_ptr=scene.series_ptr, series_target=scene.series_target)


def bundles(scene, x: np.ndarray, v: np.ndarray, fl: Filters, normals: np.ndarray, out: np.ndarray,
            samples: np.ndarray, history: np.ndarray, stride: int, gens: tuple, refine: int = 1,
            carry: np.ndarray = _NO_CARRY, signals: np.ndarray = _NO_SIGNALS,
            events: np.ndarray = _NO_EVENTS) -> tuple:
    """The kernels' arguments (``kernels/bundles.py``): bodies (masses, storey stiffnesses and
    dashpots, mass-proportional dashpots, state), absorbers (kinds, hosts, rows), loads, filters,
    noise (intensity per floor, replayed normals, replayed fine steps a step), grid, outputs
    (the history rows with the ``signals`` they hold, ``signals.declare``; the limits whose first
    passages the metric vector records, the ``carry`` of a path run in stretches:
    ``kernels/carry.py``, the event log ``events``: ``outputs.EVENT_COLUMNS``); then the three
    generators of ``gens`` (increments, bridge, filter) as arguments of their own (see
    ``kernels/bundles.py``).  The grid runs the whole path from its start."""
    return (
        Bodies(mass=scene.mass, storey_k=scene.storey_k, storey_c=scene.storey_c, floor_c=scene.floor_c,
               x=x, v=v),
        Absorbers(kind=scene.kind, host=scene.host, rows=scene.rows, wall=scene.wall),
        loads_of(scene),
        fl,
        Noise(sigma=scene.sigma, normals=normals, refine=refine),
        Grid(dt=scene.dt, n_steps=scene.n_steps, i0=scene.i0, period=scene.period,
             sample_from=scene.sample_from, stride=stride, first=0, kinds=spec_of(scene).kinds),
        Outputs(out=out, samples=samples, history=history, signals=signals, limits=scene.limits, carry=carry,
                events=events, reductions=scene.reductions, impulses=np.zeros(scene.kind.shape[0])),
        *gens,
    )


@dataclass
class Path:
    """A realisation run in stretches of steps (``start_path``, ``advance``): its step loop,
    the loop's arguments (``bundles``: the state, the metric vector, the carry and the
    generators, each stretch continuing where the last one stopped) and the step reached."""

    kernel: Any
    args: tuple
    step: int = 0
    #: The numpy generators the path's streams stand for, with the streams (``_as_streams``).
    sources: tuple = ()
    #: The scene: what another backend compiles the path's loop from (``gpu.advance_many``).
    scene: Any = None

    @property
    def x(self) -> np.ndarray:
        """The bodies' positions at ``step``."""
        return self.args[0].x

    @property
    def v(self) -> np.ndarray:
        """The bodies' velocities at ``step``."""
        return self.args[0].v

    @property
    def out(self) -> np.ndarray:
        """The raw metric vector (``SLOTS``) of the steps run so far."""
        return self.args[6].out

    @property
    def t(self) -> float:
        """The time reached, ``step dt``."""
        return self.step * self.args[5].dt

    def branch(self, streams: Streams | np.random.Generator | None = None) -> Path:
        """A copy of this path at the step it has reached, to be run on by ``advance`` on its
        own: the state, the filters' state, the metrics and accounts so far, the history rows,
        the Poincare samples, the event log and the carry (restarts for rare-event splitting).  Without
        ``streams`` the copy continues on copies of this path's generators (it runs on as this
        path would, bitwise); with ``streams`` (as ``start_path`` takes them) its noise from here
        on is theirs, and so is the seed of its Brownian trees (``brownian``), so that branches
        on independent streams are independent from the branching state on."""
        bodies, absorbers, loads, fl, noise, grid, outputs, *gens = self.args
        outputs = outputs._replace(out=outputs.out.copy(), samples=outputs.samples.copy(),
                                   history=outputs.history.copy(), carry=outputs.carry.copy(),
                                   events=outputs.events.copy(), impulses=outputs.impulses.copy())
        if self.step > 0 and outputs.carry.shape[0] == 0:
            raise ValueError("branch: this path keeps no carry (start_path(..., stretches=False))")
        sources = ()
        if streams is None:
            _sync(self.sources, back=False)
            # (one copy of a stream given in several places; the never-drawn placeholders kept as
            # they are, so that a copy branches on new streams as its original would)
            copies = {id(_UNUSED): _UNUSED}
            gens = [copies.setdefault(id(g), g.copy()) if isinstance(g, np.ndarray)
                    else copy.deepcopy(g, copies) for g in gens]
        else:
            gens, sources = _streams_for_copy(gens, streams)
            gens = list(gens)
            if self.step > 0 and gens[1] is not _UNUSED:  # (drawn at the path's start: redrawn)
                _sync(sources, back=False)
                outputs.carry[SEED_HIGH], outputs.carry[SEED_LOW] = uniform(gens[1]), uniform(gens[1])
                _sync(sources)
        fl = fl._replace(z=fl.z.copy(), zn=fl.zn.copy(), draws=fl.draws.copy())
        args = (bodies._replace(x=bodies.x.copy(), v=bodies.v.copy()), absorbers, loads, fl, noise, grid,
                outputs, *gens)
        return Path(self.kernel, args, self.step, sources, self.scene)


#: The signals of a history given without names: the roof's displacement and ``E1``, then with
#: ``2 + n_floors`` columns every floor's displacement.
DEFAULT_SIGNALS = ("x1", "e1")


def history_columns(scene, history: np.ndarray, signals: Sequence[str] | None) -> np.ndarray:
    """The declared columns (``signals.declare``) of a history buffer: ``signals`` by name, one
    column each, or without names ``DEFAULT_SIGNALS`` (and every floor's ``x_k`` where the buffer
    has ``2 + n_floors`` columns)."""
    nf = scene.n_floors
    if signals is None:
        signals = DEFAULT_SIGNALS + tuple(f"x_{k}" for k in range(1, nf + 1) if history.shape[1] == 2 + nf)
    if history.ndim != 2 or history.shape[1] != len(signals):
        raise ValueError(f"history: {history.shape[1] if history.ndim == 2 else history.shape} columns for "
                         f"{len(signals)} signals ({', '.join(signals)})")
    return declare(signals, nf, scene.kind.shape[0])


def start_path(scene, streams: Streams | np.random.Generator | None = None, *,
               normals: np.ndarray | None = None, samples: np.ndarray | None = None,
               history: np.ndarray | None = None, stride: int = 1, refine: int = 1,
               stretches: bool = True, signals: Sequence[str] | None = None,
               events: np.ndarray | None = None, general: bool | None = None) -> Path:
    """A realisation of ``scene`` at its start (step 0, the scene's initial state), to be run
    by ``advance``; the arguments are those of ``simulate``.  With ``stretches`` the loop keeps
    its carry (``kernels/carry.py``), so that the path may be run in several stretches.
    ``general``: whether it runs the scheme's general loop (None: where its own steps make a
    short run, ``general_run``; a caller running many paths says from their work)."""
    out = new_metrics(scene.n_floors, scene.limits.shape[0], scene.reductions.shape[0])
    x, v = scene.x0.copy(), scene.v0.copy()
    if samples is None:
        samples = sample_buffer(scene)
    replay = normals is not None
    needed = scene.n_steps * SCHEMES[scene.scheme].normals * max(scene.noisy_floors, 1) * refine
    if refine < 1 or (refine > 1 and (not replay or scene.scheme != "euler-maruyama")):
        raise ValueError(f"refine: {refine} fine steps a step; must be >= 1, and more than 1 only with "
                         "replayed normals and the euler-maruyama scheme")
    if replay and normals.shape[0] < needed:
        raise ValueError(f"normals: need {needed} values, got {normals.shape[0]}")
    gens, sources = _streams_for(scene, replay, streams)
    fl = filter_tuple(scene, gens[2])
    _sync(sources)
    carry = (new_carry(scene.n_floors, scene.kind.shape[0], scene.forces.shape[0]) if stretches
             else _NO_CARRY)
    history = _NO_HISTORY if history is None else history
    columns = _NO_SIGNALS if history.shape[0] == 0 else history_columns(scene, history, signals)
    events = _NO_EVENTS if events is None else events
    if events.ndim != 2 or events.shape[1] != len(EVENT_COLUMNS):
        raise ValueError(f"events: an event log has shape (rows, {len(EVENT_COLUMNS)}) (outputs.new_events), "
                         f"not {events.shape}")
    args = bundles(scene, x, v, fl, normals if replay else _NO_NORMALS, out, samples, history, stride, gens,
                   refine, carry, columns, events)
    if general is None:  # (a specialised loop compiled already: loaded, not run)
        general = keeps_general(general_run(scene.n_steps), lambda: compiled_already(
            lambda: compile_first(kernel_for(scene), args, args[7:])))
    return Path(kernel_for(scene, general=general), args, sources=sources, scene=scene)


def compile_first(dispatcher, args: tuple, gens: Sequence) -> None:
    """Before the first run in this process of ``dispatcher`` (a step loop, or a loop around
    one) with streams of the kinds of ``gens``: compile it for ``args`` (or load it) with the
    faster front end, one process at a time (``cache.compile_once``)."""
    started = (dispatcher, *((type(gen), getattr(gen, "dtype", None)) for gen in gens))
    if started in _STARTED:
        return
    if started in _MISSED and refusing() and not dispatcher.overloads:
        raise NotCompiled(f"{dispatcher} was not found before")
    try:
        compile_once(dispatcher, args)
    except NotCompiled:
        _MISSED.add(started)
        raise
    _STARTED.add(started)


def stretch_to(path: Path, stop: int) -> bool:
    """Whether ``path`` has steps to run to ``stop`` (a path of no steps still writes its metrics
    at step 0); a ``ValueError`` where ``stop`` lies outside its reach."""
    n_steps = path.args[5].n_steps
    if not path.step <= stop <= n_steps:
        raise ValueError(f"advance: stop {stop} must lie between the step reached ({path.step}) and the "
                         f"scene's step count ({n_steps})")
    if path.step > 0 and path.args[6].carry.shape[0] == 0:
        raise ValueError("advance: this path keeps no carry (start_path(..., stretches=False)); it runs in "
                         "one stretch only")
    return not (stop == path.step and stop > 0)


def advance(path: Path, stop: int) -> Path:
    """Run ``path`` from the step it has reached to step ``stop`` (at most the scene's step
    count), in place; returns it.  Its state, metric vector, history rows, Poincare samples and
    generators continue where the last stretch stopped, so a path run in stretches ends in the
    state and with the metrics of the path run in one go, bitwise (``tests/unit/kernels/
    test_stretches.py``); the metric vector after a stretch holds the metrics of the steps so
    far, as if the path ended there."""
    if not stretch_to(path, stop):
        return path
    grid = path.args[5]
    args = (*path.args[:5], grid._replace(n_steps=stop, first=path.step), *path.args[6:])
    compile_first(path.kernel, args, args[7:])
    _sync(path.sources, back=False)
    path.kernel(*args)
    _sync(path.sources)
    path.step = stop
    return path


def simulate(scene, streams: Streams | np.random.Generator | None = None, *,
             normals: np.ndarray | None = None, final: np.ndarray | None = None,
             samples: np.ndarray | None = None, history: np.ndarray | None = None,
             stride: int = 1, refine: int = 1, signals: Sequence[str] | None = None,
             events: np.ndarray | None = None) -> np.ndarray:
    """Run one realisation of ``scene``; returns the raw metric vector (see ``SLOTS``).

    ``streams`` (``vines_stoch.streams.Streams``: increments, bridge draws, filter noise; or
    one numpy Generator for every purpose) is required where the scene draws random numbers
    (a ``ValueError`` says so); ``normals`` replays a given Brownian path (one standard normal
    per noisy floor and step, two with the ``sra`` scheme: see ``grid.step_normals``) instead of
    drawing the increments (and a tape as the filter stream, ``rng.tape``, replays the filters'
    noise: ``filter_draws`` normals); with ``refine`` (kick-drift-kick only) it holds ``refine`` fine
    normals a step and noisy floor, fine step by fine step, and the run sees the path of the
    fine steps, inside a step too (``brownian``): a coarse run and the run of the fine steps
    (``refine = 1``, ``dt / refine``) on the same normals and streams integrate the same path;
    ``final`` (shape ``(2, n_bodies)``) receives the final positions and velocities;
    ``samples`` (from ``sample_buffer``) receives the Poincare
    samples of periodic scenes; ``history`` (shape ``(G, len(signals))``) receives the
    ``signals`` (names of ``signals.signal_names``: ``x1``, ``e1``, ``x_k``, ``v_k``,
    ``drift_k``, ``xa_j``, ``va_j``, ``stroke_j``, ``contact_j``; without names, ``history_columns``) at
    ``t = j stride dt``, ``j < G`` (rows after a divergence keep their previous content);
    ``events`` (from ``outputs.new_events``) receives the event log, the impacts and Hertz
    contacts' onsets in the metrics window (``outputs.EVENT_COLUMNS``), as many as it has rows.
    Asking for one of these compiles nothing: the loop reads it from its arrays.  (A path
    run in stretches: ``start_path``, ``advance``.)
    """
    path = start_path(scene, streams, normals=normals, samples=samples, history=history, stride=stride,
                      refine=refine, stretches=False, signals=signals, events=events)
    advance(path, scene.n_steps)
    if final is not None:
        final[0], final[1] = path.x, path.v
    return path.out


def load_history(
    scene, streams: Streams | np.random.Generator | np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One sample path of a scene's loads on its time grid: ``(t, force on each floor (shape
    (n_steps + 1, n_floors)), ground acceleration)``; filtered loads start from the same law
    and take the same exact steps as in the step loops (white noise, having no path value, is
    left out); ``streams`` gives the filter stream (default: a generator seeded with 0; a
    Philox stream array is a GPU realisation's), so the streams of an ensemble's realisation
    give the path that realisation saw."""
    n = scene.n_steps
    force, ground = np.zeros((n + 1, scene.n_floors)), np.zeros(n + 1)
    if streams is None:
        streams = np.random.default_rng(0)
    gen = streams if isinstance(streams, (np.random.Generator, np.ndarray)) else streams.filter
    if gen is None:
        gen = np.random.default_rng(0)  # a scene without filters draws nothing
    (gen,), sources = _as_streams([gen])
    load_path(loads_of(scene), filter_tuple(scene, gen), scene.dt, n, gen, force, ground)
    _sync(sources)
    return scene.dt * np.arange(n + 1), force, ground


__all__ = ["GENERAL_WORK", "SLOTS", "Path", "advance", "bundles", "compiled_already", "filter_draws",
           "general_run", "keeps_general", "kernel_for", "load_history", "sample_buffer", "simulate",
           "start_path"]
