"""The protocol between a step loop (an executor: ``driver.step_loop``, ``lanes.lane_loop``, the
cuda kernel of ``launch.py``) and a scheme's step (``kdk.py``, ``sra3.py``, ``rk4.py``): what a
loop is specialised to (``Spec``), the step's functions (``Step``) and the accounts they pass
(``ACCOUNTS``).

The protocol (every function inlined; ``own``: the scheme's state and scratch, a named tuple
its ``start`` makes on the loop's stack; ``sc``: its scalar state, a tuple carried from step
to step; ``acct``: the accounts, ``ACCOUNTS``):

- ``start(spec arrays..., x, v, carry, resume, gen_bridge) -> (own, sc)``: the scheme's state
  at the path's start, or restored from the carry;
- ``opening(own, x, v, inv_mass, acc, bodies, absorbers)``: at the metrics window's opening, each
  floor's force or acceleration for the peaks into ``acc``;
- ``check(own, i, dt, ex)``: every ``common.CHECK_EVERY`` steps (the phasors' exact reset);
- ``step(i, x, v, inv_mass, acc, own, sc, acct, inside, peaks, bodies, absorbers, ex, fl,
  noise, grid, outputs, gen, gen_filter) -> (sc, acct)``: one step of the grid, ``x, v`` in
  place; ``acc`` is left with each floor's force or acceleration at the step's end for the
  peaks;
- ``save(carry, own, sc)``, ``finish(own, sc, fl, out)``: the scheme's part of the carry, and
  of the metric vector and the filter bundle at the end.

Two constants say how a scheme's step meets the accounts: ``integrates`` (the step integrates
``E1`` and ``x_k^2`` with its own stages and observes the peaks and first passages at its own
sub-steps' ends, as RK4 at its located events; otherwise the driver observes every step's end
and integrates by the trapezoid rule) and ``force_peaks`` (``acc`` holds floor forces, the
peak accelerations being the peak forces over the masses); a third, ``samples``, says whether
the driver takes Poincare samples around the scheme's steps (where the scene asks for them:
the deterministic scheme of regimes, ``scene.poincare_samples``; the others compile without).
A scheme whose step also runs in SIMD lanes (``kernels/lanes.py``) gives ``advance``: the step
after its loads and increments, ``advance(i, x, v, inv_mass, acc, own, seed, ag, ag_next, acct,
inside, bodies, absorbers, ex, fl, noise, dt, out, events, impulses) -> acct`` (``seed``: its
Brownian tree's), which finishes the lanes whose step holds an event.
"""

from __future__ import annotations

from typing import Any, NamedTuple

#: A size a loop reads from its arguments at run time (``Spec``), and the most items of it
#: that the loop's frame holds: floors, load rows, filter states (``ROOM``) and bodies
#: (``BODY_ROOM``); a larger count is a constant of its own loop (``paths.spec_of``).
RUN_TIME, ROOM = -1, 16
BODY_ROOM = 2 * ROOM


def rooms(spec) -> tuple[int, int, int, int]:
    """The items a loop's stack arrays hold (``jit.intrinsics.scratch_within``'s room) for its
    bodies, floors, load rows and filter states: a size the loop takes as a constant (``Spec``),
    or the most a run-time count may be, ``BODY_ROOM`` and ``ROOM`` (``paths.spec_of``).  An
    array of a count that numba types as a plain integer (a count worked out from others, or
    passed through a function) holds its room: with ``ROOM`` there, a structure of more floors
    than ``ROOM`` wrote past its arrays."""
    return tuple(size if size >= 0 else room for size, room in zip(
        (spec.n_bodies, spec.n_floors, spec.n_rows, spec.n_states), (BODY_ROOM, ROOM, ROOM, ROOM)))


#: What a scene holds that a loop may take as constants (``Spec``'s flags, in this order), and
#: their bits in the run's ``Grid.kinds``, which a loop built with ``RUN_TIME`` in their place
#: reads at run time (``common.kinds_of``).
KINDS = ("has_noise", "has_impact", "has_hertz", "partners", "filtered", "ground", "shaped")
KIND_BITS = {name: 1 << k for k, name in enumerate(KINDS)}

#: The accounts a step takes and returns, in this order (``energy``): input work, structure
#: and absorber dissipation, the sum (or integral) of ``E1``, its peak, the impacts' loss and
#: counts, contact time, peak contact force, limits not passed yet.
ACCOUNTS = ("work", "d_primary", "d_absorber", "e_sum", "e1_max", "loss", "n_left", "n_right",
            "contact_time", "peak_force", "pending")


class Spec(NamedTuple):
    """What a loop is specialised to (compile-time constants): the numbers of bodies, floors,
    closed-form load rows and filter states (the sizes of its arrays on the stack; the last two
    ``RUN_TIME`` where the loop reads them from its arguments), white
    noise, impact and Hertz absorbers, impacts between absorbers (an impact absorber in
    another's cavity: ``physics.structure.wall_of``), filtered loads, ground acceleration,
    shaped springs (geometric attachments, gap springs) and the cuda backend's loop
    (per-absorber flags on the stack).  What a run records beyond the built-in metrics (first
    passages, history rows, the event log, declared metrics) is not among them: the loop reads
    it from its output arrays at run time (``common.recording``), so that asking for it
    compiles nothing."""

    n_bodies: int
    n_floors: int
    n_rows: int
    n_states: int
    has_noise: bool
    has_impact: bool
    has_hertz: bool
    partners: bool
    filtered: bool
    ground: bool
    shaped: bool
    gpu: bool

    @property
    def kinds(self) -> int:
        """The bits (``KIND_BITS``) of the flags this spec sets: a run's ``Grid.kinds``."""
        return sum(bit for name, bit in KIND_BITS.items() if getattr(self, name) == 1)


class Step(NamedTuple):
    """A scheme's step and its hooks (see the module's docstring)."""

    start: Any
    opening: Any
    check: Any
    step: Any
    save: Any
    finish: Any
    integrates: bool
    force_peaks: bool
    samples: bool
    advance: Any = None
