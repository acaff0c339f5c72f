"""Step loops compiled ahead of the runs that need them, running nothing (a cluster image, a
notebook server): those of a scenario's runs (``compile_loops``) and the general loops of every
scheme (``compile_general``), ``vines-stoch compile``."""

from __future__ import annotations

import io
import multiprocessing
import os
import sys
import time
import warnings
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor
from contextlib import redirect_stderr
from typing import Any

import numpy as np

from ..kernels import DEFAULT_SIGNALS, EXECUTORS, advance, check_executor, start_path
from ..results import as_study
from ..scenario import History, Study
from ..scene import Scene, build_scene
from .chunks import recording
from .planning import plan, prepare_loops
from .running import run


def compile_loops(scenario: Study | Mapping[str, Any] | str | os.PathLike, *, executor: str = "lanes",
                  paths: bool = False, show: bool = True, specialised: bool = False) -> None:
    """Compile, or load from the cache on disk, the step loops that ``run`` of ``scenario`` with
    ``executor`` (and ``paths``) needs, and run nothing: ahead of the runs, for a cluster image
    or a notebook server (``vines-stoch compile``).  A loop depends on the structure (bodies,
    floors, absorber laws, loads, what the run records), not on the parameters' values, so one
    scenario covers its whole sweep and its uncertain parameters; ``show``: a line a loop on
    standard error (``prepare_loops``).  ``specialised``: the loops specialised to its structures
    (a long run's) whatever the run's work, which every later ensemble or ``solve`` of them with
    ``executor`` then takes, however short (``kernels.keeps_general``)."""
    check_executor(executor)
    study = as_study(scenario)
    base = study.base
    grid_spec = base.simulation.history or (History() if paths else None)
    the_plan = plan(study, executor=executor)
    signals, grid = recording(the_plan.scenes[0], grid_spec, base.output.spectra)
    prepare_loops(the_plan.scenes, base.ensemble.seed, base.ensemble.common_random_numbers, grid,
                  signals or DEFAULT_SIGNALS, show=show, executor=executor,
                  general=the_plan.general and not specialised, batch=the_plan.batch)


#: One small structure for each scheme the general loops are compiled for: a noisy
#: kick-drift-kick and SRA3 scene, a deterministic RK4 scene (every stream being one type,
#: ``streams.kinds``, a deterministic scene and a noisy one run the same loop).
GENERAL_SET = (("euler-maruyama", "white-noise"), ("sra", "white-noise"), ("rk4", "harmonic"))


def general_scene(scheme: str, load: str, storeys: int = 1) -> Scene:
    """A structure of ``storeys`` storeys with a cubic absorber under ``load``, run by ``scheme``."""
    force = {"type": load, "intensity": 0.1} if load == "white-noise" else {
        "type": load, "amplitude": 0.1, "frequency": 1.0}
    primary = ({"mass": 1.0, "stiffness": 1.0, "damping": 0.01} if storeys == 1 else
               {"masses": [1.0] * storeys, "stiffnesses": [1.0] * storeys, "dampings": [0.01] * storeys})
    data = {"name": "general-loops", "primary": primary,
            "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01}],
            "loads": [force], "simulation": {"duration": 0.1, "dt": 0.01, "scheme": scheme}}
    return build_scene(as_study(data).points[0])


def compile_general(*, show: bool = True, workers: int | None = None) -> None:
    """Compile, or load from the cache on disk, the general loops of every scheme (``GENERAL_SET``)
    for paths (``simulate``, ``solve``) and for chunks of both executors, and the pass loop (the
    lanes of every smooth kick-drift-kick structure: of three bodies or more, of any in a short
    run), keeping nothing: after
    it no run shorter than ``kernels.GENERAL_WORK`` path-steps compiles a step loop, whatever its
    structure (``vines-stoch compile --general``: a cluster image, a notebook server); then two
    tiny runs (``EVERY_LAW``) compile what a run compiles besides its loop.  The loops
    (``GENERAL_PIECES``) compile side by side in ``workers`` processes (default: one a core), the
    longest first; ``show``: a line a loop on standard error, as ``prepare_loops``."""
    workers = min(workers or os.cpu_count() or 1, len(GENERAL_PIECES))
    if workers == 1:
        for piece in GENERAL_PIECES:
            _compile_piece(piece, show)
        _finish_run(show)
        return
    if show:
        print(f"step loops: the general loops of every scheme and the pass loop in {workers} processes",
              file=sys.stderr, flush=True)
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        tasks = [pool.submit(_compile_piece, piece, show, True) for piece in GENERAL_PIECES]
        tasks.append(pool.submit(_finish_run, show, True))  # (beside the last loops: it runs on the first)
        for done in tasks:
            print(done.result(), end="", file=sys.stderr, flush=True)


def _every_law(absorbers: list[dict], loads: list[dict]) -> dict[str, Any]:
    """A two-storey frame with ``absorbers`` under ``loads``, a limit and history: 4 paths of 0.2 s."""
    return {"name": "every-law", "primary": {"masses": [1.0, 1.0], "stiffnesses": [4.0, 4.0],
                                              "dampings": [0.05, 0.05]},
            "absorbers": absorbers, "loads": loads, "limits": {"drift": {"metric": "x_max_1", "value": 0.1}},
            "ensemble": {"realizations": 4},
            "simulation": {"duration": 0.2, "dt": 1e-3, "history": {"points": 8}}}


#: Runs that touch what a run compiles besides its step loop (the summary's order statistics, the
#: formulas of every absorber law that the estimates beside an ensemble read outside the loop,
#: history and limits), run once by ``compile_general``: the smooth laws (estimated) and the
#: impact and contact ones.
EVERY_LAW = (
    _every_law([{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01},
                {"type": "bistable", "mass": 0.05, "stiffness": 1.0, "linear_stiffness": -0.05,
                 "damping": 0.01},
                {"type": "geometric", "mass": 0.05, "stiffness": 1.0, "free_length": 1.0, "length": 1.0,
                 "damping": 0.01},
                {"type": "gap", "mass": 0.05, "stiffness": 1.0, "gap": 0.01, "damping": 0.01}],
               [{"type": "white-noise", "intensity": 0.1},
                {"type": "ground-motion", "model": "kanai-tajimi", "soil": "medium", "intensity": 0.1}]),
    _every_law([{"type": "impact", "mass": 0.05, "clearance": 0.02, "restitution": 0.6},
                {"type": "hertz", "geometry": "double-sided", "mass": 0.05, "stiffness": 0.5, "damping": 0.01,
                 "offset": 0.0, "gap": 0.05, "contact_left": {"k": 1e5}, "contact_right": {"k": 1e5}}],
               [{"type": "white-noise", "intensity": 0.1}]),
)


def _finish_run(show: bool, kept: bool = False) -> str:
    """Run each of ``EVERY_LAW`` once, keeping nothing (``compile_general``'s last step); with
    ``kept``, its line is returned instead of written (a worker process's)."""
    if kept:
        with redirect_stderr(io.StringIO()) as lines:
            _finish_run(show)
        return lines.getvalue()
    start = time.monotonic()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for data in EVERY_LAW:
            run(data, workers=1)
    if show:
        print(f"the rest of a run (summary, every absorber law): ready in {time.monotonic() - start:.1f} s",
              file=sys.stderr, flush=True)
    return ""


#: The loops ``compile_general`` compiles, as (scheme, load, what) of ``GENERAL_SET``: the general
#: loop for paths then for chunks of both executors (``loops``: one compile, the chunks' wrappers
#: taking the loop the paths compiled, every stream being one type), or the pass loop (``pass``).
#: The longest come first.
GENERAL_PIECES = (("euler-maruyama", "white-noise", "loops"), ("euler-maruyama", "white-noise", "pass"),
                  ("sra", "white-noise", "loops"), ("rk4", "harmonic", "loops"))


def _compile_piece(piece: tuple[str, str, str], show: bool, kept: bool = False) -> str:
    """``compile_general`` of one of ``GENERAL_PIECES``; with ``kept``, its lines are returned
    instead of written (a worker process's, printed whole by the parent)."""
    if kept:
        with redirect_stderr(io.StringIO()) as lines:
            _compile_piece(piece, show)
        return lines.getvalue()
    scheme, load, what = piece
    if what == "pass":  # (the pass loop: ``kernels.in_pass_loop``)
        prepare_loops([general_scene(scheme, load, storeys=2)], 0, True, show=show, general=True)
        return ""
    scene = general_scene(scheme, load)
    if show:
        print(f"step loop: the general {scheme} loop for paths ({load}): compiling or loading ...", end="",
              file=sys.stderr, flush=True)
    start = time.monotonic()
    advance(start_path(scene, np.random.default_rng(0), stretches=False, general=True), scene.n_steps)
    if show:
        print(f" ready in {time.monotonic() - start:.1f} s", file=sys.stderr, flush=True)
    for executor in EXECUTORS:
        prepare_loops([scene], 0, True, show=show, executor=executor, general=True)
    return ""
