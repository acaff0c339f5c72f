"""Command line:
``vines-stoch run | validate | estimate | loads | report | fragility | compare | optimize | bench |
reproduce``."""

from __future__ import annotations

import os
import sys
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from .environment import MissingExtra
from .notices import VinesStochWarning
from .scenario import ScenarioError, Study, load_scenario

if TYPE_CHECKING:
    import pandas as pd

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Stochastic Monte Carlo response analysis of vibration absorbers.")


def _version(shown: bool) -> None:
    """``--version``: the package's version, then exit."""
    if shown:
        from . import __version__

        typer.echo(f"vines-stoch {__version__}")
        raise typer.Exit()


@app.callback()
def _options(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                          help="Print the version and exit.")) -> None:
    """Stochastic Monte Carlo response analysis of vibration absorbers."""


def _fail(message: str) -> None:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(2)


def _warn(study: Study) -> None:
    """The study's warnings (``Study.warnings``: a coarse ``dt``, realisations that would all be
    the same), one ``warning:`` line each on standard error."""
    for line in study.warnings:
        typer.echo(f"warning: {line}", err=True)


def _warn_residuals(realizations: pd.DataFrame, study: Study) -> None:
    """One ``warning:`` line per sweep point with realisations whose energy balance does not
    close (``metrics.residual_warnings``)."""
    from .metrics import residual_warnings

    for line in residual_warnings(realizations, study.source, study.base.simulation.residual_tolerance):
        typer.echo(f"warning: {line}", err=True)


def _check_backend(backend: str) -> None:
    """Stop with one line unless ``--backend`` names a backend that can run here."""
    from .ensemble import BACKENDS

    if backend not in BACKENDS:
        _fail(f"--backend {backend}: must be one of {', '.join(BACKENDS)}")
    if backend == "cuda":
        from .gpu import GPUUnavailable, require

        try:
            require()
        except GPUUnavailable as exc:
            _fail(str(exc))


@app.command()
def run(
    scenario: Path = typer.Argument(..., help="Scenario TOML file."),
    out: Path | None = typer.Option(None, "--out", help="Output directory (overrides output.directory)."),
    workers: int | None = typer.Option(None, "--workers", min=1,
                                       help="Threads of the embedded scheduler (default: all cores)."),
    chunk: int | None = typer.Option(None, "--chunk", min=0,
                                     help="Realisations per task (overrides ensemble.chunk; "
                                          "0 = automatic)."),
    resume: bool = typer.Option(False, "--resume",
                                help="Keep the chunks an interrupted run of the same scenario finished."),
    overwrite: bool = typer.Option(False, "--overwrite",
                                   help="Discard the work an unfinished run kept in the folder (without "
                                        "--resume or --overwrite, a run refuses to)."),
    scheduler: str | None = typer.Option(None, "--scheduler",
                                         help="Address of a running dask.distributed scheduler "
                                              "(e.g. tcp://10.0.0.5:8786)."),
    scheduler_file: Path | None = typer.Option(None, "--scheduler-file",
                                               help="Scheduler file of a running dask.distributed scheduler "
                                                    "(dask scheduler --scheduler-file FILE)."),
    shard: str | None = typer.Option(None, "--shard",
                                     help="I/N: run only the I-th of N shares of the chunks (job arrays); "
                                          "then --resume writes the results."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress or summary output."),
    backend: str = typer.Option("cpu", "--backend",
                                help="cpu (numba on CPU threads) or cuda (an NVIDIA GPU through numba-cuda, "
                                     "one realisation a thread; its own random streams)."),
    executor: str = typer.Option("lanes", "--executor",
                                 help="How the CPU runs realisations: lanes (SIMD lanes, Philox streams) or "
                                      "scalar (one path at a time, PCG64 streams; slower, another sample)."),
) -> None:
    """Run a scenario and write realizations.parquet and summary.parquet."""
    from .ensemble import Interrupted, output_directory
    from .ensemble import run as run_study

    started = time.monotonic()
    _check_backend(backend)
    try:
        study = load_scenario(scenario)
    except ScenarioError as exc:
        _fail(str(exc))
    _warn(study)
    if scheduler_file is not None:
        if scheduler is not None:
            _fail("give --scheduler or --scheduler-file, not both")
        if not scheduler_file.is_file():
            _fail(f"--scheduler-file {scheduler_file}: no such file (start the scheduler with "
                  "dask scheduler --scheduler-file FILE first)")
        scheduler = str(scheduler_file)
    share = None
    if shard is not None:
        i, _, n = shard.partition("/")
        if not (i.isdigit() and n.isdigit()):
            _fail(f"--shard {shard}: give I/N with 0 <= I < N (e.g. --shard 0/4)")
        share = (int(i), int(n))  # (the range is checked by run_study)
    directory = output_directory(study, out)
    try:
        with warnings.catch_warnings():  # (their lines are printed here: _warn, _warn_residuals)
            warnings.simplefilter("ignore", VinesStochWarning)
            result = run_study(study, directory, workers=workers, chunk=chunk, resume=resume,
                               scheduler=scheduler, progress=not quiet, shard=share, backend=backend,
                               overwrite=overwrite, executor=executor)
    except KeyboardInterrupt as exc:  # (Interrupted says how many chunks are kept)
        typer.echo(f"\n{exc if isinstance(exc, Interrupted) else 'interrupted'}", err=True)
        raise typer.Exit(130) from None
    except (OSError, ValueError, TimeoutError, MissingExtra) as exc:
        _fail(str(exc))
    if share is not None:
        if not quiet:
            typer.echo(f"shard {shard}: its chunks are in {directory}/parts; once every shard has finished, "
                       "run again with --resume (no --shard) to write the results", err=True)
        return
    realizations, summary = result
    _warn_residuals(realizations, study)
    if quiet:
        return
    typer.echo(f"results: {directory}/realizations.parquet ({len(realizations)} rows), "
               f"{directory}/summary.parquet ({len(summary)} rows)"
               + (f", {directory}/history.parquet" if study.base.simulation.history else "")
               + f"; {time.monotonic() - started:.1f} s in all")
    import pandas as pd

    with pd.option_context("display.width", 200, "display.max_columns", 24, "display.precision", 4):
        shown = headline(study, summary)
        typer.echo(summary[shown].to_string(index=False))
        for line in undefined(summary, shown):
            typer.echo(f"note: {line}", err=True)
        from .rvt.table import parted

        for line in parted(summary):
            typer.echo(f"estimate: {line}", err=True)
        if result.rare is not None:
            typer.echo(f"\n{directory}/rare.parquet: P({study.base.rare.limit} exceeded), "
                       f"{study.base.rare.method}")
            typer.echo(result.rare[[*study.sweep_keys, "p", "cov", "p_lo", "p_hi", "paths", "replicas"]]
                       .to_string(index=False))
        if result.sensitivity is not None:
            typer.echo(f"\n{directory}/sensitivity.parquet: Sobol indices of {study.base.sensitivity.metric}")
            typer.echo(result.sensitivity.to_string(index=False))


def undefined(summary: pd.DataFrame, columns: list[str]) -> list[str]:
    """Why a statistic of ``columns`` is NaN: the summary's ``notes`` of each point where one is
    (``metrics.undefined_notes``: one realisation, no energy in), one line a point."""
    if "notes" not in summary:
        return []
    numeric = [c for c in columns if summary[c].dtype.kind == "f"]
    lines = []
    for i in range(len(summary)):
        if summary["notes"].iloc[i] and summary[numeric].iloc[i].isna().any():
            lines.append(f"point {int(summary['point'].iloc[i])}: {summary['notes'].iloc[i]}")
    return lines


def headline(study: Study, summary: pd.DataFrame) -> list[str]:
    """The summary columns the end-of-run table shows, those the scenario is about: the swept
    keys, the realisations ok and failed, the mean EDM and peak energy, the impacts where an
    absorber impacts, the objective of ``[optimize]``, each limit's exceedance probability
    ``p_NAME`` with its interval, and the energy residual (the run's check)."""
    means = ["edm", "e1_max"]
    if "impacts_mean" in summary and (summary["impacts_mean"].fillna(0) > 0).any():
        means.append("impacts")
    if study.base.optimize is not None and study.base.optimize.objective not in means:
        means.append(study.base.optimize.objective)
    limits = [c for c in summary.columns  # (p_NAME, p_NAME_lo, p_NAME_hi; not the estimates' columns)
              if c.startswith("p_") and not c.endswith(("_estimate", "_z"))]
    columns = [*study.sweep_keys, "n_ok", "n_failed", *(f"{m}_mean" for m in means), *limits,
               "energy_residual_mean"]
    return [c for c in dict.fromkeys(columns) if c in summary]


@app.command(name="compile")
def compile_(
    scenarios: list[Path] = typer.Argument(None, help="Scenario TOML files."),
    executor: str = typer.Option("lanes", "--executor",
                                 help="The executor the runs will use: lanes or scalar."),
    paths: bool = typer.Option(False, "--paths", help="Also the loops of runs that keep their paths."),
    general: bool = typer.Option(False, "--general",
                                 help="The general loops of every scheme and the pass loop: after them no "
                                      "run shorter than "
                                      "1e8 path-steps (VINES_STOCH_GENERAL_WORK) compiles a step loop, "
                                      "whatever its structure."),
    specialised: bool = typer.Option(False, "--specialised",
                                     help="The loops specialised to the files' structures, which a run of "
                                          "1e8 path-steps or more takes (8e8 for a smooth structure of one "
                                          "or two bodies under the lanes): with them on disk every later "
                                          "ensemble or solve of these structures with the same executor "
                                          "takes them, however short (2-3x faster, in SIMD lanes up to about "
                                          "13x, the same numbers), unless VINES_STOCH_GENERAL_WORK is set; a "
                                          "process that looked for them before they were there does not "
                                          "look again.")
) -> None:
    """Compile the step loops the scenarios' runs need, and run nothing (a cluster image, a
    notebook server): later runs load them from the cache on disk."""
    from .ensemble import compile_general, compile_loops

    if not scenarios and not general:
        _fail("compile: name scenario files, or --general")
    if general:
        compile_general()
    for scenario in scenarios or ():
        try:
            study = load_scenario(scenario)
            compile_loops(study, executor=executor, paths=paths, specialised=specialised)
        except ScenarioError as exc:
            _fail(str(exc))
        except ValueError as exc:
            _fail(f"{scenario}: {exc}")


@app.command()
def validate(scenario: Path = typer.Argument(..., help="Scenario TOML file.")) -> None:
    """Check a scenario file without running it."""
    try:
        study = load_scenario(scenario)
    except ScenarioError as exc:
        _fail(str(exc))
    _warn(study)
    typer.echo(f"{scenario}: ok ({len(study.points)} sweep point(s))")
    for line in _outline(study):
        typer.echo(line)


def _outline(study: Study) -> list[str]:
    """``validate``'s account of the base scenario: the bare structure's modal periods and
    effective masses, and the run's work (sweep points x realisations x steps)."""
    base = study.base
    periods, shares = base.primary.modes()
    modes = ", ".join(f"T{i + 1} = {t:.4g} s ({100 * m:.1f} %)"
                      for i, (t, m) in enumerate(zip(periods, shares)))
    steps = [max(1, round(p.simulation.duration / p.simulation.dt)) for p in study.points]
    count = base.ensemble.realizations if base.is_random else 1
    return [f"primary: {base.primary.n_floors} floor(s), {len(base.absorbers)} absorber(s); modes of the "
            f"bare structure (effective mass): {modes}",
            f"work: {len(steps)} sweep point(s) x {count} realisation(s) x {steps[0]:,} step(s)"
            + (" (at the first point)" if len(set(steps)) > 1 else "")
            + f" = {count * sum(steps):.3g} path-steps"]


@app.command()
def estimate(
    scenario: Path = typer.Argument(..., help="Scenario TOML file."),
    out: Path | None = typer.Option(None, "--out", help="Write the table to this Parquet file too."),
) -> None:
    """Estimate the response without an ensemble (exact linear random vibration, statistical
    linearisation, Rice / Poisson / Vanmarcke first passage): one row a sweep point."""
    import pandas as pd

    from .rvt import estimate as estimate_study

    try:
        study = load_scenario(scenario)
    except ScenarioError as exc:
        _fail(str(exc))
    started = time.monotonic()
    table = estimate_study(study)
    if out is not None:
        if not out.parent.is_dir():
            _fail(f"{out}: the folder {out.parent} does not exist")
        table.to_parquet(out, index=False)
    shown = [c for c in table.columns if c in ("point", "method", *study.sweep_keys) or c.startswith(
        ("x1_", "p_")) and not c.endswith("_poisson")]
    with pd.option_context("display.width", 200, "display.max_columns", 24, "display.precision", 4):
        typer.echo(table[shown].to_string(index=False))
    for p, note in zip(table["point"], table["note"]):
        if note:
            typer.echo(f"point {p}: {note}", err=True)
    typer.echo(f"{len(table)} sweep point(s) in {time.monotonic() - started:.2f} s"
               + (f"; written to {out}" if out is not None else ""), err=True)


@app.command()
def loads(
    scenario: Path = typer.Argument(..., help="Scenario TOML file."),
    out: Path = typer.Argument(..., help="File to write: .AT2 (ground acceleration in g) "
                                         "or .csv (comma-separated, a header row: t, force, ground)."),
    seed: int | None = typer.Option(None, "--seed", min=0, max=2**63 - 1,
                                    help="Seed (default: the scenario's ensemble.seed)."),
    realization: int = typer.Option(0, "--realization", min=0, max=2**63 - 1,
                                    help="Realisation whose loads to write."),
    point: int = typer.Option(0, "--point", min=0, help="Sweep point."),
    pga: float | None = typer.Option(None, "--pga", min=0.0, max=100.0,
                                     help="Scale the ground acceleration to this peak (in g)."),
    every: int = typer.Option(1, "--every", min=1, help="Keep every N-th sample of the time grid."),
) -> None:
    """Write one sample path of a scenario's loads (e.g. a synthetic accelerogram): the path
    realisation ``--realization`` of an ensemble run with ``--seed`` sees (the same streams)."""
    import numpy as np

    from .kernels import load_history, realization_streams
    from .records import G, write_at2
    from .scene import build_scene

    try:
        study = load_scenario(scenario)
    except ScenarioError as exc:
        _fail(str(exc))
    if point >= len(study.points):
        _fail(f"--point {point}: the scenario has {len(study.points)} sweep point(s)")
    if not out.parent.is_dir():
        _fail(f"{out}: the folder {out.parent} does not exist")
    ens = study.base.ensemble
    seed = ens.seed if seed is None else seed
    scene = build_scene(study.points[point])
    gens = realization_streams(scene, seed, point, realization, ens.common_random_numbers)
    t, force, ground = load_history(scene, gens)
    if every > len(t):
        _fail(f"--every {every}: the time grid has {len(t)} samples")
    t, force, ground = t[::every], force[::every], ground[::every]
    if pga is not None:
        peak = np.max(np.abs(ground))
        if peak == 0.0:
            _fail(f"--pga: {scenario} has no ground acceleration to scale")
        ground *= pga * G / peak
    try:
        if out.suffix.lower() == ".at2":
            write_at2(out, scene.dt * every, ground / G,
                      f"{study.name}, sweep point {point}, seed {seed}, realisation {realization}")
        else:
            floors = force.shape[1]
            names = ["force"] if floors == 1 else [f"force_{k}" for k in range(1, floors + 1)]
            np.savetxt(out, np.c_[t, force, ground], delimiter=",", comments="",  # (pandas.read_csv reads it)
                       header=",".join(["t", *names, "ground_acceleration"]))
    except OSError as exc:
        _fail(f"{out}: cannot write ({exc.strerror})")
    typer.echo(f"wrote {out} ({len(t)} samples)")


@app.command()
def report(
    directories: list[Path] = typer.Argument(..., help="Result directories (several: on the same plots)."),
    out: Path = typer.Option(Path("reports"), "--out",
                             help="Folder that receives <name>/report.md and the plots."),
    label: list[str] | None = typer.Option(None, "--label",
                                           help="Name of each run in tables and legends (in order)."),
    point: int | None = typer.Option(None, "--point", min=0,
                                     help="Sweep point of the EDM histogram and history plot "
                                          "(default: the middle one)."),
) -> None:
    """Write a Markdown report with tables and plots (PNG and SVG) of finished runs."""
    from .reports import report as write_report

    if label and len(label) != len(directories):
        _fail(f"--label: give one per directory ({len(directories)}), got {len(label)}")
    try:
        path = write_report(directories, out, label, point)
    except (OSError, ValueError, KeyError) as exc:
        _fail(str(exc))
    typer.echo(f"wrote {path}")


@app.command()
def fragility(
    directory: Path = typer.Argument(..., help="Result directory of a run with a limits table "
                                               "and a sweep over intensity."),
    limit: str = typer.Option(..., "--limit", help="Name of the limit (a key of the limits table)."),
    im: str = typer.Option(..., "--im",
                           help="Intensity measure: a column constant at each sweep point (a swept key)."),
    diverged: str = typer.Option("exclude", "--diverged",
                                 help="Realisations that did not end ok: 'exclude' or 'exceed' "
                                      "(count them as exceedances)."),
    samples: int = typer.Option(1000, "--samples", min=0,
                                help="Bootstrap replicates of the confidence bounds (0: none)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the bootstrap."),
) -> None:
    """Fit a lognormal fragility curve to the exceedances of a limit over the sweep points."""
    from .fragility import fragility as fit_fragility

    try:
        rows = fit_fragility(directory, limit, im, diverged, samples, seed)
    except (OSError, ValueError, KeyError) as exc:
        _fail(str(exc).strip("'\""))
    first = rows.iloc[0]
    typer.echo(f"{limit} against {im}: "
               f"median {first['median']:.5g} [{first['median_lo']:.5g}, {first['median_hi']:.5g}], "
               f"beta {first['beta']:.4g} [{first['beta_lo']:.4g}, {first['beta_hi']:.4g}] "
               f"(95 % bootstrap bounds, {first['bootstrap_fitted']} of {first['bootstrap']} replicates); "
               f"did not end ok: {first['diverged']}"
               + (f"\nnotes: {first['notes']}" if first["notes"] else ""))
    from .plotting import available

    plot = "".join(f", {directory / f'fragility_{limit}{suffix}'}" for suffix in (".png", ".svg")
                   if available())
    typer.echo(f"wrote {directory / 'fragility.parquet'}{plot}")


@app.command()
def compare(
    directories: list[Path] = typer.Argument(...,
                                             help="Two or more result directories of the same sweep grid."),
    out: Path = typer.Option(Path("reports/compare.md"), "--out", help="Markdown file to write."),
    metric: list[str] | None = typer.Option(None, "--metric",
                                            help="Metric to compare (repeatable; default edm, e1_max, "
                                                 "energy_integral, impacts): any metric column, or "
                                                 "p_NAME for a limit."),
    label: list[str] | None = typer.Option(None, "--label",
                                           help="A name for each run, in the directories' order (repeatable; "
                                                "default the folders' names)."),
) -> None:
    """Side-by-side summary metrics of several runs, with differences and their standard errors
    (any metric of the runs' summaries, floors' and declared ones included, or a limit's
    exceedance p_NAME)."""
    from .reports import COMPARED, Run, comparable, markdown
    from .reports import compare as compare_runs
    from .signals import floor_name, floors_in

    if len(directories) < 2:
        _fail("compare needs at least two result directories")
    if label and len(label) != len(directories):
        _fail(f"--label: {len(label)} label(s) for {len(directories)} directories; give one a directory")
    try:
        runs = [Run.read(d, name) for d, name in zip(directories, label or [None] * len(directories))]
        allowed = comparable(runs[0])
        floors = floors_in(runs[0].realizations.columns)
        for m in metric or []:
            if floor_name(m, floors) not in allowed:
                _fail(f"--metric {m}: must be one of {', '.join(allowed)} (or a floor's metric with _roof "
                      "for the top floor)")
        table = compare_runs(runs, tuple(floor_name(m, floors) for m in metric or COMPARED))
    except (OSError, ValueError, KeyError) as exc:
        _fail(str(exc))
    text = markdown(table)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(f"# Comparison of {', '.join(map(str, directories))}\n\n{text}\n")
    typer.echo(text)
    typer.echo(f"wrote {out}")


@app.command()
def optimize(
    scenario: Path = typer.Argument(..., help="Scenario TOML file with an optimize table."),
    out: Path | None = typer.Option(None, "--out",
                                    help="Output directory (default: <output directory>-optimum)."),
    workers: int | None = typer.Option(None, "--workers", min=1,
                                       help="Threads of the embedded scheduler (default: all cores)."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress output."),
) -> None:
    """Tune absorber parameters for the best mean EDM (or other metric); write the optimum,
    the objective history, a report and the results at the optimum."""
    from .ensemble import output_directory
    from .optimize import optimize_scenario

    try:
        study = load_scenario(scenario)
    except ScenarioError as exc:
        _fail(str(exc))
    directory = out or Path(f"{output_directory(study)}-optimum")
    echo = (lambda line: None) if quiet else typer.echo
    try:
        best, path = optimize_scenario(study, directory, workers, progress=not quiet, echo=echo)
    except KeyboardInterrupt:
        typer.echo(f"\ninterrupted: the evaluations so far are in {directory}/optimization.parquet", err=True)
        raise typer.Exit(130) from None
    except (OSError, ValueError) as exc:
        _fail(str(exc))
    if not quiet:
        shown = ", ".join(f"{k} = {v:.6g}" for k, v in best.values.items())
        typer.echo(f"optimum: {shown}; "
                   f"{study.base.optimize.objective} = {best.objective:.6g} +- {best.sem:.2g}")
        typer.echo(f"wrote {directory}/optimum.toml, {directory}/optimization.parquet, {path}")


@app.command()
def bench(
    out: Path = typer.Option(Path("reports/benchmarks.md"), "--out", help="Markdown report to write."),
    backend: str = typer.Option("cpu", "--backend",
                                help="cpu (the CPU report) or cuda (GPU ensembles: its own section of the "
                                     "same report, the rest of the file kept)."),
    paths: str | None = typer.Option(None, "--paths",
                                     help="With --backend cuda: path counts, comma-separated "
                                          "(default 10000,100000,1000000)."),
) -> None:
    """Measure throughput and error side by side; write the figures to reports/."""
    import importlib.util

    _check_backend(backend)
    if backend == "cuda":
        counts = (10_000, 100_000, 1_000_000)
        if paths is not None:
            try:
                counts = tuple(int(p) for p in paths.split(","))
            except ValueError:
                counts = ()
            if not counts or min(counts) < 1:
                _fail(f"--paths {paths}: give positive path counts, comma-separated (e.g. 10000,100000)")
        from .validation.bench_gpu import main as bench_gpu_main

        bench_gpu_main(out, counts)
        return
    if paths is not None:
        _fail("--paths: only with --backend cuda")
    missing = [name for name in ("sdeint", "distributed") if importlib.util.find_spec(name) is None]
    if missing:
        _fail(f"vines-stoch bench needs {' and '.join(missing)} (sdeint: the peer of its work-precision "
              "study; distributed: its cluster-overhead row), not installed: "
              'pip install "vines-stoch[bench]"')
    from .validation.bench import main as bench_main

    bench_main(out)


@app.command()
def reproduce(
    out: Path = typer.Option(Path("reports/seed-tables.md"), "--out", help="Markdown report to write."),
    scenarios: Path = typer.Option(Path("scenarios"), "--scenarios",
                                   help="Folder holding the seed00N_*.toml files."),
    ledger_only: bool = typer.Option(False, "--ledger-only",
                                     help="Rewrite only the ledger's section of --out (no run)."),
) -> None:
    """Write every seed paper figure and table with its status (reproduced, differs, qualitative,
    not reproduced, not built), then run the tested tables of seeds 000-003 beside the printed
    numbers (about 3 minutes on 2 cores)."""
    from .validation.ledger import refresh
    from .validation.reproduce import reproduce as reproduce_tables

    try:
        path = refresh(out) if ledger_only else reproduce_tables(scenarios, out)
    except (ScenarioError, OSError, ValueError) as exc:
        _fail(str(exc))
    typer.echo(f"wrote {path}")


def main() -> None:
    """Console entry point.  Mistakes in the input end in ``error: ...`` and exit status 2; an
    unexpected exception (a bug) in one line and exit status 3, with its traceback only where
    the environment variable ``VINES_STOCH_TRACEBACK`` is set."""
    from .environment import problems

    for line in problems():  # (before numba reads them: a mistake there is the user's, not a bug)
        typer.echo(f"error: {line}", err=True)
    if problems():
        sys.exit(2)
    try:
        app()
    except Exception as exc:  # the last line of defence: no traceback for users
        if os.environ.get("VINES_STOCH_TRACEBACK"):
            raise
        detail = str(exc).splitlines()[0][:200] if str(exc) else ""
        typer.echo(f"error: internal error {type(exc).__name__}: {detail} (a bug: please report it; set "
                   "VINES_STOCH_TRACEBACK=1 to see where it happened)", err=True)
        sys.exit(3)


if __name__ == "__main__":
    sys.exit(main())
