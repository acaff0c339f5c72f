"""Numba step loops, specialised to what a scene contains (floors, noise, impacts, contact) and
compiled once.

``simulate(scene, streams)`` runs one realisation and returns the raw metric vector
(``common.SLOTS``, then the per-floor blocks of ``common.FLOOR_SLOTS``).  Kernels are
memoised by scene structure (the numbers of bodies and floors included); the parameters are
arguments, so a sweep of parameters never recompiles.  Every kernel takes the same bundles
(``bundles``, the named tuples of ``kernels/bundles.py``): bodies, absorbers, loads, filters,
noise, grid, outputs and the three streams.

The package's one front: nothing outside ``kernels/`` imports one of its modules
(``tests/integration/test_layout.py``).  ``paths.py``: one realisation's loop, arguments and
streams; ``chunk.py``: a chunk of realisations in one compiled call (``simulate_chunk``);
``protocol.py``: what a loop and a scheme's step pass each other; ``driver.py``, ``lanes.py``,
``passes.py`` and ``launch.py`` the executors (the scalar loop, the SIMD lanes specialised to a
structure, the SIMD lanes' pass loop for structures of any size, the cuda kernel); ``kdk.py``,
``sra3.py`` and ``rk4.py`` the schemes' steps.
"""

from __future__ import annotations

from typing import Any

from .chunk import (
    EXECUTORS,
    check_executor,
    chunk_loop,
    chunk_runner,
    ground_paths,
    in_pass_loop,
    lane_scene,
    parameter_draws,
    realization_streams,
    scalar_general,
    seed_keys,
    simulate_chunk,
)
from .lanes import LANES, SPARE_ROWS, lane_normals
from .passes import pass_loop, pass_scene
from .paths import (
    DEFAULT_SIGNALS,
    SLOTS,
    Path,
    advance,
    bundles,
    compile_first,
    compiled_already,
    filter_draws,
    general_run,
    history_columns,
    keeps_general,
    kernel_for,
    load_history,
    needed_streams,
    sample_buffer,
    simulate,
    spec_of,
    start_path,
    step_of,
    stretch_to,
)


def launcher(*args: Any, **kwargs: Any):
    """``launch.launcher``: the cuda kernel around a step loop (numba-cuda imported on first use)."""
    from .launch import launcher as make

    return make(*args, **kwargs)


def stretcher(*args: Any, **kwargs: Any):
    """``launch.stretcher``: the cuda kernel advancing paths by stretches (numba-cuda on first use)."""
    from .launch import stretcher as make

    return make(*args, **kwargs)


__all__ = ["DEFAULT_SIGNALS", "EXECUTORS", "LANES", "SLOTS", "SPARE_ROWS", "Path", "advance", "bundles",
           "check_executor", "chunk_loop", "chunk_runner", "compile_first", "compiled_already",
           "filter_draws", "general_run", "ground_paths", "history_columns", "in_pass_loop", "keeps_general",
           "kernel_for", "lane_normals", "lane_scene",
           "launcher", "load_history", "needed_streams", "parameter_draws", "pass_loop", "pass_scene",
           "realization_streams", "sample_buffer", "scalar_general", "seed_keys", "simulate",
           "simulate_chunk", "spec_of", "start_path", "step_of", "stretch_to", "stretcher"]
