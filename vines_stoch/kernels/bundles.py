"""The step loops' arguments as named bundles, the one place that fixes their fields and order.

Every step loop takes ``(bodies, absorbers, loads, filters, noise, grid, outputs, gen,
gen_bridge, gen_filter)``: the seven named tuples below, then the three generators (the step
increments, the Brownian trees' seed, the filter noise; arguments of their own, not a bundle:
numba types a tuple holding a numpy Generator in Python, about 20 us a call).  The CPU builds
them from a scene (``kernels.bundles``), the CUDA launcher from a realisation's slices of the
device arrays (``kernels.launch``), both by field name.  numba types a named tuple as it does a
tuple (unpacking one in a step loop is free), at about a microsecond more a bundle per call.
"""

from __future__ import annotations

from typing import Any, NamedTuple


class Bodies(NamedTuple):
    """Masses, storey stiffnesses and dashpots, mass-proportional dashpots (one per floor) and
    the state (positions, velocities: read at the start, the end state written back)."""

    mass: Any
    storey_k: Any
    storey_c: Any
    floor_c: Any
    x: Any
    v: Any


class Absorbers(NamedTuple):
    """Each absorber's law code, host floor, parameter row (``physics.absorbers``) and the body
    that holds its walls (``physics.structure.wall_of``)."""

    kind: Any
    host: Any
    rows: Any
    wall: Any


class Loads(NamedTuple):
    """The loads of ``kernels/loads.py``: closed-form rows, the records' samples and pointers,
    their target floors."""

    forces: Any
    series_t: Any
    series_v: Any
    series_ptr: Any
    series_target: Any


class Filters(NamedTuple):
    """The noise filters (``loads.advance_filters``): transition, Cholesky factor, envelopes,
    read-outs on the floors' forces and the ground; the state, the next state and the
    normals' scratch."""

    phi: Any
    chol: Any
    envelope: Any
    c_force: Any
    c_ground: Any
    z: Any
    zn: Any
    draws: Any


class Noise(NamedTuple):
    """White-noise intensity per floor, the replayed normals (empty: drawn) and the replayed
    fine steps a step."""

    sigma: Any
    normals: Any
    refine: Any


class Grid(NamedTuple):
    """Step, the step the run stops at (the scene's step count for a whole path), the metrics
    window's first step, the forcing period and the first Poincare sample's time (none: period
    0), the history rows' stride in steps, and the step the run starts at (0: a path's start;
    later: a path's next stretch, its state from the outputs' carry), and what the scene holds
    (``protocol.KIND_BITS``: read by a loop that takes it at run time, ``common.kinds_of``)."""

    dt: Any
    n_steps: Any
    i0: Any
    period: Any
    sample_from: Any
    stride: Any
    first: Any
    kinds: Any


class Outputs(NamedTuple):
    """The raw metric vector, the Poincare samples, the history rows and the signals they hold
    (``signals.declare``: a column each), the limits whose first passages the metric vector
    records (``common.first_passages``), the path's carry to its next stretch
    (``kernels/carry.py``; empty: none kept), the event log (``outputs.EVENT_COLUMNS``;
    empty: none kept), the declared metrics the metric vector records after the first
    passages (``signals.declare_metrics``) and, one an absorber, the impulses of the impacts on
    its host in the step that ended (the signal ``contact_j``).  Which of these a run keeps the
    loop reads from their sizes at run time (``common.recording``): asking compiles nothing."""

    out: Any
    samples: Any
    history: Any
    signals: Any
    limits: Any
    carry: Any
    events: Any
    reductions: Any
    impulses: Any
