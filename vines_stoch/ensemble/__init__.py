"""Monte Carlo ensembles: chunk plan, per-realisation random streams, dask execution,
streamed Parquet parts, resume and convergence stopping.

Realisation ``r`` draws from one stream per purpose (``streams``: step increments, bridge
draws, filter noise, uncertain parameters), each keyed by (seed, purpose, realisation): its
numbers depend on nothing else, so results are bitwise identical for any chunk size, worker
count or scheduler, and with common random numbers the same at every sweep point.  Chunks run on
dask's embedded threaded scheduler or a ``dask.distributed`` cluster; each finished chunk is
written at once as an atomic part file, and the driver folds chunks into the history
statistics and the ``target_sem`` test in realisation order, so neither depends on which chunk
finished first.

The package by concern: ``planning`` (the chunks, their sizes, the backends and the loops
compiled before the first chunk), ``chunks`` (a chunk run in one compiled call into its table
and paths), ``folding`` (each point's chunks folded in realisation order, the checkpoint),
``tables`` (the result tables gathered and written), ``control`` (Ctrl-C, the cluster's
client), ``running`` (``run``, ``sample``, ``solve``) and ``ahead`` (loops compiled ahead of the
runs: ``compile_loops``, ``compile_general``).
"""

from __future__ import annotations

from ..metrics import METRICS
from ..streams import generator
from .ahead import compile_general, compile_loops
from .chunks import chunk_parameters, draw_parameters, poincare_columns, recording, run_chunk, run_chunk_cuda
from .control import Interrupted
from .folding import TARGET_STEP, PointState
from .planning import BACKENDS, CHUNKS_PER_POINT, Plan, plan, prepare_loops, structure
from .running import output_directory, run, sample, solve

__all__ = ["BACKENDS", "CHUNKS_PER_POINT", "METRICS", "TARGET_STEP", "Interrupted", "Plan", "PointState",
           "chunk_parameters", "compile_general", "compile_loops", "draw_parameters", "generator",
           "output_directory", "plan", "poincare_columns", "prepare_loops", "recording", "run", "run_chunk",
           "run_chunk_cuda", "sample", "solve", "structure"]
