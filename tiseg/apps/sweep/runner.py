"""Running a sweep on Dask: the folder checks, the task graph, retries, progress and the result."""

from __future__ import annotations

import functools
import json
import logging
import math
import os
import time as _time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable


from ...errors import InputError, TisegError
from ...backend import available_cores
from ...log import stderr_line
from ...post.analysis.fingers import count_text
from .members import (
    check_member_folder,
    compiled_fingerprint,
    execute_batch,
    execute_run,
    read_marker,
    refresh_metrics,
    scene_fingerprint,
)
from .spec import PROGRESS_TOPIC, Sweep, SweepRun, _canonical
from .table import _csv_text, _write_outputs
from .dataset import write_dataset
from .probability import PROBABILITY_FILE, write_probability
from .sensitivity import plot_sensitivity, sensitivity_columns, sensitivity_rows
from ...output import write_text_atomic
from ...output.diagnostics import json_clean
from ...backend import threads_problem
from ...output.atomic import remove_stale_temporaries
from ...output.paths import refuse_symlinks

log = logging.getLogger(__name__)


@dataclass
class SweepResult:
    out: Path
    table: Path
    records: list[dict]  # one per run, grid order; status done / reused / failed / busy
    results: list[Path] = field(default_factory=list)  # sweep.nc, sensitivity.csv and .png

    def count(self, status: str) -> int:
        return sum(1 for r in self.records if r.get("status") == status)

    def as_dict(self) -> dict:
        """The summary ``tiseg sweep --json`` prints: folders, counts and one entry per run."""
        keep = (
            "name",
            "status",
            "error",
            "holder",
            "wall_s",
            "steps",
            "rhs_evaluations",
            "nx",
            "ny",
            "t_end",
        )
        runs = [{k: r[k] for k in keep if k in r} for r in self.records]
        counts = {}
        for r in self.records:
            counts[r.get("status", "?")] = counts.get(r.get("status", "?"), 0) + 1
        return {
            "out": str(self.out),
            "table": str(self.table),
            "results": [str(p) for p in self.results],
            "counts": counts,
            "runs": runs,
        }


SWEEP_OUTPUTS = ("sweep.json", "sweep.csv", "summary.csv", "sweep.nc")
# every file a sweep writes in its --out (sensitivity-<grid values>.png besides)
RESULT_NAMES = SWEEP_OUTPUTS + (PROBABILITY_FILE, "sensitivity.csv", "sensitivity.png")
# a calibration's result file (tiseg.apps.calibration.runner.RESULT_FILE; not imported: the
# calibration imports this module)
CALIBRATION_FILE = "calibration.json"
# what makes two sweeps the same: the runs and what is tabulated (not the file's place or text)
SAME_SWEEP_KEYS = ("name", "scene", "set", "grid", "sample", "times")


def check_dask_options(
    workers: int | None, scheduler: str | None, threads_per_task, batch: int | None = None
) -> None:
    """The options of where members run (`check_workers`, --threads-per-task: at least 0,
    and on a local cluster no more than this process may use, and --batch: at least 1),
    checked before any run."""
    check_workers(workers, scheduler)
    if batch is not None and (isinstance(batch, bool) or not isinstance(batch, int) or batch < 1):
        raise InputError(f"--batch {batch!r}: give a whole number of members >= 1")
    if threads_per_task is not None and threads_per_task < 0:
        raise InputError(f"--threads-per-task={threads_per_task}: must be >= 0 (0 = all cores)")
    if threads_per_task and scheduler is None:
        problem = threads_problem(threads_per_task, "--threads-per-task")
        if problem:
            raise InputError(problem)


def create_output_folder(out: Path) -> None:
    """``out`` and its parents, or an InputError naming it."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder {str(out)!r}: {exc.strerror}") from None


def check_workers(workers: int | None, scheduler: str | None) -> None:
    """Refuse a number of local worker processes below 1 or above the cores this process may
    use: each runs one member with a Taichi runtime of its own (some 300 MB) and at least one
    thread, so more only share the cores and the memory (a --workers of 10000 started
    processes until the machine gave out). With --scheduler the cluster's own workers run the
    members and the number is not used."""
    if workers is None:
        return
    if workers < 1:
        raise InputError(f"--workers={workers}: must be at least 1")
    cores = available_cores()
    if scheduler is None and workers > cores:
        raise InputError(
            f"--workers={workers}: this machine offers {cores} core(s) to this process and "
            f"each worker runs one member on at least one; use at most {cores} (the default)"
        )


def check_sweep_folder(sweep: Sweep, out) -> None:
    """Refuse an ``out`` that holds another sweep (its ``sweep.json`` defines other runs) or a
    table that no sweep.json of tiseg's accounts for: running there would replace the other
    sweep's table and, under shared folder names, its finished runs."""
    out = Path(out)
    if not out.is_dir():
        return
    hint = "choose a new --out, or pass --overwrite to replace it"
    if (out / CALIBRATION_FILE).exists():  # its members share the sweeps' folder names
        raise InputError(
            f"--out {str(out)!r} holds a calibration ({CALIBRATION_FILE}), whose members a "
            f"sweep there could replace; {hint}"
        )
    present = [n for n in SWEEP_OUTPUTS if (out / n).exists()]
    if not present:
        return
    try:
        stored = json.loads((out / "sweep.json").read_text(encoding="utf-8"))["sweep"]
        # "sample": absent from the sweep.json of a grid written before samples existed
        theirs = {k: stored[k] if k != "sample" else stored.get(k) for k in SAME_SWEEP_KEYS}
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError):
        raise InputError(
            f"--out {str(out)!r} holds {', '.join(present)} that no sweep of tiseg's wrote "
            f"there (no readable sweep.json); {hint}"
        ) from None

    # as sweep.json stores it (tuples as lists, non-finite numbers as null)
    ours = json.loads(json.dumps(json_clean({k: sweep.to_dict()[k] for k in SAME_SWEEP_KEYS})))
    if _canonical(theirs) != _canonical(ours):
        differ = [k for k in SAME_SWEEP_KEYS if _canonical(theirs[k]) != _canonical(ours[k])]
        raise InputError(
            f"--out {str(out)!r} holds another sweep ({theirs['name']!r}, its "
            f"{', '.join(differ)} differ from this one's); {hint}"
        )


def run_sweep(
    sweep: Sweep,
    out,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    threads_per_task: int | None = None,
    arch: str = "cpu",
    echo: Callable[[str], None] | None = stderr_line,
    progress_interval: float = 30.0,
    overwrite: bool = False,
    report: Callable[[str], None] | None = None,
    batch: int | None = None,
) -> SweepResult:
    """Run every unfinished member of ``sweep`` on Dask and write ``OUT/sweep.csv``.

    ``scheduler``: address of an existing Dask scheduler (``tcp://host:8786``); default: a
    ``LocalCluster(processes=True, threads_per_worker=1, n_workers=workers)`` started and
    stopped here. ``workers``: local worker processes (default: as many as CPU cores, at most
    the number of runs). ``threads_per_task``: Taichi CPU threads per run (default: cores /
    workers locally, the worker's own thread count on a remote cluster). ``echo``: where
    progress lines go (default stderr; the command line: the ``tiseg`` logger; None: silent). ``progress_interval``: seconds between progress lines
    of one running run. ``overwrite``: write into an ``out`` that holds
    another sweep, and replace files that tiseg did not write in member folders (by default
    both are refused, see `check_sweep_folder`). ``report``: where the closing line of results
    goes (default ``echo``; the command line: stdout, which ``-q`` keeps). ``batch``: members
    that share their compiled kernels (`compiled_fingerprint`) run up to this many to a Dask
    task, advanced together on one operator with a member axis (`execute_batch`: one launch
    a stage for all, start-up and compilation paid once); 1 runs each alone (a worker's
    members on the kernels it built for its first, `execute_run`'s reuse); None (default)
    chooses enough tasks to keep every worker busy (`batch_size`).

    The local cluster starts its workers with multiprocessing's "spawn", which re-imports the
    calling script: call this from under ``if __name__ == "__main__":`` in a script.
    """
    out = Path(out)
    say = echo or (lambda _s: None)
    check_dask_options(workers, scheduler, threads_per_task, batch)
    if not overwrite:
        check_sweep_folder(sweep, out)
    create_output_folder(out)
    # before any run, as `tiseg run` does: the results are never written through a link
    charts = tuple(p.name for p in out.glob("sensitivity*.png"))
    refuse_symlinks(out, RESULT_NAMES + charts)
    # a killed sweep's half-written files (the names are glob patterns)
    remove_stale_temporaries(out, RESULT_NAMES + ("sensitivity*.png",))

    records: dict[str, dict] = {}
    pending: list[SweepRun] = []
    for run in sweep.runs:
        rec = read_marker(out / run.name, run.scene)
        if rec is not None:
            rec = refresh_metrics(out / run.name, rec)
            records[run.name] = {**rec, "status": "reused"}
        else:
            pending.append(run)
    for run in pending:  # before anything runs: never another command's finished member
        check_member_folder(
            out / run.name,
            run.scene,
            overwrite,
            "choose a new --out, or pass --overwrite to replace it",
        )
    say(
        f"sweep {sweep.name!r}: {len(sweep.runs)} runs, {len(records)} already finished, "
        f"{len(pending)} to run; output in {out}/"
    )
    # written now and after every finished run (a partial table survives an interruption)
    table = _write_outputs(sweep, out, records)
    if pending:
        _run_on_dask(
            sweep,
            out,
            pending,
            records,
            scheduler,
            workers,
            threads_per_task,
            arch,
            say,
            progress_interval,
            overwrite=overwrite,
            batch=batch,
        )
    result = SweepResult(
        out, table, [records.get(r.name, {"name": r.name, "status": "missing"}) for r in sweep.runs]
    )
    written = write_results(sweep, out, records)
    result.results = written
    (report or say)(
        f"sweep {sweep.name!r}: {result.count('done')} ran, {result.count('reused')} reused, "
        f"{result.count('failed')} failed; table {table}, ensembles "
        f"{table.parent / 'summary.csv'}, dataset {', '.join(str(p) for p in written)}"
    )
    return result


def write_results(sweep: Sweep, out, records: dict) -> list[Path]:
    """Write what is drawn from the finished members once the sweep has run: ``sweep.nc``
    (`tiseg.apps.sweep.dataset`), with ``[probability]`` ``probability.nc``
    (`tiseg.apps.sweep.probability`) and, for a "sobol" sample, ``sensitivity.csv`` and its
    bar charts (`tiseg.apps.sweep.sensitivity`). Returns the paths written."""
    out = Path(out)
    paths = [write_dataset(sweep, out, records)]
    prob = write_probability(sweep, out, records)
    if prob is not None:
        paths.append(prob)
    else:  # an older probability.nc is not this sweep's now: `tiseg render` would draw it
        why = (
            "the sweep has no [probability] table"
            if getattr(sweep, "probability", None) is None
            else "no finished member's peak fields could be stacked"
        )
        drop_stale(out / PROBABILITY_FILE, why)
    rows = sensitivity_rows(sweep, records)
    if rows:
        path = out / "sensitivity.csv"
        write_text_atomic(path, _csv_text(sensitivity_columns(sweep), rows))
        paths.append(path)
        drawn = plot_sensitivity(sweep, rows, out)
        paths += drawn
        for old in out.glob("sensitivity*.png"):
            if old not in drawn:
                drop_stale(old, "no output has Sobol' indices to draw")
    return paths


def drop_stale(path: Path, why: str) -> None:
    """Remove a result of an earlier invocation that this one could not make again (``why``):
    left in place it would pass for this one's (and `tiseg render` would draw it)."""
    try:
        path.unlink()
    except FileNotFoundError:
        return
    except OSError as exc:
        log.warning("cannot remove the stale %s (%s): %s", path, why, exc.strerror or exc)
        return
    log.warning("removed the stale %s of an earlier run: %s", path, why)


def _run_on_dask(
    sweep,
    out,
    pending,
    records,
    scheduler,
    workers,
    threads_per_task,
    arch,
    say,
    progress_interval,
    overwrite=False,
    batch=None,
) -> None:
    client, cluster, threads, where = open_dask(
        scheduler, workers, threads_per_task, len(pending), say
    )
    size = batch or default_batch(pending, worker_count(client), scheduler is None, arch)
    tasks = batches(pending, size)
    per = "the worker's" if threads is None else (threads or "all")
    grouped = f" in {len(tasks)} tasks of up to {size} runs advanced together" if size > 1 else ""
    say(
        f"running {len(pending)} runs{grouped} on the {where}, {per} Taichi thread"
        f"{'' if threads == 1 else 's'} per run"
    )

    on_progress = progress_handler(say, progress_interval)

    from distributed import as_completed

    futures = {}
    try:
        try:
            client.subscribe_topic(PROGRESS_TOPIC, on_progress)
        except Exception:  # older distributed: no events, only completion lines
            pass
        futures = submit_tasks(client, tasks, out, arch, threads, overwrite)
        done = 0
        for fut in as_completed(list(futures), loop=client.loop):
            task = futures[fut]
            for run, rec in zip(task, task_records(fut, task)):
                done += 1
                if rec.get("status") == "failed":
                    say(f"[{done}/{len(pending)}] {run.name}: FAILED ({rec['error']})")
                else:
                    say(f"[{done}/{len(pending)}] {run.name}: {_summary(rec)}")
                records[run.name] = rec
            _write_outputs(sweep, out, records)  # a partial table survives an interruption
    except BaseException:
        for fut in futures:
            fut.cancel()
        raise
    finally:
        try:
            client.unsubscribe_topic(PROGRESS_TOPIC)
        except Exception:
            pass
        close_dask(client, cluster)


def close_dask(client, cluster) -> None:
    """Close ``client`` and, where it was started here, its local ``cluster``, whose workers
    first stop logging errors (`quiet_workers`)."""
    if cluster is not None:
        quiet_workers(client)
    client.close()
    if cluster is not None:
        cluster.close()


def quiet_workers(client) -> None:
    """Silence the Dask loggers of the client's workers, before their cluster closes: a
    worker whose heartbeat meets the closing scheduler logs a traceback ("Failed to
    communicate with scheduler during heartbeat", dask/distributed#7105) after runs that
    all succeeded. (Not for a --scheduler's workers, which go on serving others.)"""
    try:
        client.run(_silence_dask_logs)
    except Exception:  # a worker already gone: nothing of it left to silence
        pass


def _silence_dask_logs() -> None:
    for name in [n for n in logging.root.manager.loggerDict if n.split(".")[0] == "distributed"]:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    logging.getLogger("distributed").setLevel(logging.CRITICAL + 1)


def progress_handler(say, progress_interval: float):
    """A handler of the members' progress events (topic `PROGRESS_TOPIC`): one line per run
    at most every ``progress_interval`` seconds."""
    last_report: dict[str, float] = {}

    def on_progress(event) -> None:
        # event = (timestamp, msg); throttled per run so long sweeps stay readable
        msg = event[1] if isinstance(event, tuple) else event
        try:
            name, now = msg["run"], _time.monotonic()
            if now - last_report.get(name, -math.inf) < progress_interval:
                return
            last_report[name] = now
            say(
                f"  running {name}: t = {msg['t']:.2f} / {msg['t_end']:.2f} s "
                f"({100 * msg['t'] / msg['t_end']:.0f} %), {msg['steps']} steps, "
                f"{msg['wall']:.0f} s"
            )
        except Exception:
            pass

    return on_progress


def open_dask(scheduler, workers, threads_per_task, n_runs: int, say):
    """The Dask client the members run on: ``(client, cluster, threads, where)``.

    ``scheduler``: the address of an existing scheduler (``cluster`` is then None and
    ``threads`` is ``threads_per_task``: None lets each task take its worker's thread count);
    else a local cluster of ``workers`` processes (default: the cores, at most ``n_runs``), one
    task each, with ``threads`` Taichi threads per task (default cores / workers). The caller
    closes the client and the cluster. ``where`` names it for the progress lines."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise TisegError(
            "sweeps need Dask: pip install 'tiseg[sweep]' (dask[distributed])"
        ) from None
    cores = available_cores()
    if scheduler:
        _probe_scheduler(scheduler)
        try:
            # not Dask's default client: one that fails to connect would stay the default
            # (and the default scheduler) for every later Dask or xarray computation in this
            # process, which then tried to reach it (writing sweep.nc, probability.nc)
            client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT}s", set_as_default=False)
        except Exception as exc:  # OSError, TimeoutError, ValueError for a bad address...
            raise _no_scheduler(scheduler, exc) from None
        try:
            _wait_for_a_worker(client, scheduler, say)
        except BaseException:
            client.close()
            raise
        # None: each task takes as many threads as its worker runs (its --nthreads)
        return client, None, threads_per_task, f"Dask scheduler {scheduler}"
    n = workers or max(1, min(cores, n_runs))
    threads = max(1, cores // n) if threads_per_task is None else threads_per_task
    # processes=True: Taichi's runtime is per process, one run per worker at a time.
    # The scheduler always serves HTTP; ":0" picks a free port so that several sweeps
    # (or other Dask users) on one machine never collide on 8787.
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    )
    client = Client(cluster)
    say(f"Dask dashboard: {client.dashboard_link}")
    return (
        client,
        cluster,
        threads,
        f"local Dask cluster ({n} worker{'s' if n > 1 else ''} x 1 task)",
    )


# seconds to reach a --scheduler and have it answer as Dask does, and to wait for it to have a
# worker (a scheduler without one would hold the tasks for ever)
CONNECT_TIMEOUT = 10.0
WORKER_TIMEOUT = 120.0


def _no_scheduler(scheduler: str, exc: BaseException) -> InputError:
    first = next((ln for ln in str(exc).splitlines() if ln.strip()), "").strip()
    if isinstance(exc, TimeoutError) or not first:
        first = (
            f"no answer as a Dask scheduler within {CONNECT_TIMEOUT:g} s (nothing listens "
            "there, or a service that is not Dask)"
        )
    return InputError(
        f"cannot connect to the Dask scheduler at {scheduler!r}: {first} (give an address "
        "like tcp://host:8786)"
    )


def _probe_scheduler(scheduler: str) -> None:
    """Refuse (`InputError`) an address that does not answer Dask's handshake within
    `CONNECT_TIMEOUT`, before a `distributed.Client` is made: the client waits for ever on a
    TCP service that is not Dask (its own timeout does not cover the handshake), and one made
    with a malformed address raised a TimeoutError traceback at exit when collected."""
    import asyncio

    from distributed.comm import connect

    async def probe() -> None:
        comm = await asyncio.wait_for(
            connect(scheduler, timeout=CONNECT_TIMEOUT), CONNECT_TIMEOUT + 1.0
        )
        await comm.close()

    try:
        asyncio.run(probe())
    except Exception as exc:  # OSError, TimeoutError, ValueError for a bad address...
        raise _no_scheduler(scheduler, exc) from None


def _wait_for_a_worker(client, scheduler: str, say) -> None:
    """Return once the scheduler has a worker; say so when it has none yet, and refuse after
    `WORKER_TIMEOUT` seconds (it would hold the tasks for ever, silently)."""
    if client.scheduler_info().get("workers"):
        return
    say(
        f"the Dask scheduler at {scheduler} has no workers yet; waiting up to "
        f"{WORKER_TIMEOUT:g} s for one (start one with: dask worker {scheduler})"
    )
    try:
        client.wait_for_workers(1, timeout=WORKER_TIMEOUT)
    except TimeoutError:
        raise InputError(
            f"the Dask scheduler at {scheduler!r} has no workers (waited "
            f"{WORKER_TIMEOUT:g} s): start some with `dask worker {scheduler}`, or leave "
            "--scheduler out to run on this machine"
        ) from None


# the most members of one batch task by default: a lost worker loses at most this many runs
# progress (each finished member keeps its done.json), and the shared start-up of a batch
# this large is already a small part of its wall time
MAX_AUTO_BATCH = 16
# the largest member a CPU batch takes by default. On a 2-core VM (benchmarks/sweep_batch),
# against members one at a time that share their worker's start-up (execute_run's reuse),
# 16 seeds batched took 0.93, 0.89 and 0.96 of the time at 4,500, 10,125 and 18,000 cells a
# member, and 1.13 at 28,125 (1.24 for 64 seeds): a batch's fields are its members' together,
# and once they outgrow the caches its steps lose what the shared launches save
MAX_CPU_BATCH_CELLS = 20_000


def batch_size(n_runs: int, workers: int) -> int:
    """The default members per task: enough tasks to keep each of ``workers`` busy (about
    two per worker, so that a long member does not leave the others idle at the end), at
    most `MAX_AUTO_BATCH`."""
    per = math.ceil(n_runs / max(2 * workers, 1))
    return max(1, min(per, MAX_AUTO_BATCH))


def default_batch(runs: list, workers: int, local: bool, arch: str = "cpu") -> int:
    """The members per task when --batch is not given: `batch_size`, and on a local cluster
    no more than the largest member's batch can hold in a worker's share of the memory
    available now (`tiseg.run.batch.members_that_fit`; a remote cluster's memory is not
    known here). On the CPU, members of more than `MAX_CPU_BATCH_CELLS` cells run one at a
    time: their start-up is a small part of their run, and together they share the caches
    and the memory bandwidth (docs/performance.md)."""
    size = batch_size(len(runs), workers)
    if arch == "cpu" and runs:
        if max(r.scene.domain.nx * r.scene.domain.ny for r in runs) > MAX_CPU_BATCH_CELLS:
            return 1
    if local and size > 1 and runs:
        from ...run.batch import members_that_fit

        largest = max(runs, key=lambda r: r.scene.domain.nx * r.scene.domain.ny)
        fit = members_that_fit(largest.scene, share=workers)
        if fit is not None:
            size = min(size, fit)
    return size


def batches(runs: list, size: int) -> list[list]:
    """The runs as tasks of up to ``size`` members sharing a compiled fingerprint, the
    longest (by cost) first, each task's members longest first."""
    groups: dict[str, list] = {}
    for run in sorted(runs, key=lambda r: -r.cost):
        groups.setdefault(compiled_fingerprint(run.scene), []).append(run)
    tasks = [g[i : i + size] for g in groups.values() for i in range(0, len(g), size)]
    return sorted(tasks, key=lambda t: -sum(r.cost for r in t))


def submit_tasks(client, tasks: list[list], out, arch: str, threads, overwrite: bool) -> dict:
    """Submit each task (a list of runs, `batches`) to Dask: {future: task}. A task of
    several members runs them together (`execute_batch`), a task of one alone
    (`execute_run`), on the simulation of the worker's last member when that was compiled
    for it (``reuse``: the Taichi start-up, seconds, is paid once a worker and kernels)."""
    futures = {}
    for task in tasks:  # longest first: better packing
        specs = [member_spec(run, out, arch, threads, overwrite) for run in task]
        if len(task) > 1:
            # (a batch runs its members through this module's execute_run, the function
            # every task of the runner calls, so that a replacement of it covers them too)
            fn, arg = functools.partial(execute_batch, run=execute_run), specs
        else:
            fn, arg = execute_run, {**specs[0], "reuse": True}
        # retries=1: a transient failure outside execute_run (a worker lost) is tried once
        # more; execute_run returns a run's own error as a failed record (no retry, no Dask
        # traceback) and retries a failed ti.init itself. A batch's members that finished
        # before such a failure are reused by the retry (their done.json), the others
        # continue from their checkpoints.
        fut = client.submit(
            fn,
            arg,
            key=f"tiseg-{task[0].name}-{os.urandom(4).hex()}",
            pure=False,
            priority=int(sum(r.cost for r in task) // 1e6),
            retries=1,
        )
        futures[fut] = task
    return futures


def task_records(fut, task: list) -> list[dict]:
    """The completion records of a finished task's runs, in the task's order: a failed
    record for each where the task itself failed (the others go on)."""
    try:
        recs = fut.result()
        return recs if isinstance(recs, list) else [recs]
    except Exception as exc:
        first = next((ln for ln in str(exc).splitlines() if ln.strip()), "")
        error = f"{type(exc).__name__}: {first.strip()}"
        return [{"name": run.name, "status": "failed", "error": error} for run in task]


def worker_count(client) -> int:
    """The Dask workers the client sees now (1 if it cannot tell)."""
    try:
        return max(1, len(client.scheduler_info().get("workers", {})))
    except Exception:
        return 1


def member_spec(run: SweepRun, out, arch: str, threads, overwrite: bool = False) -> dict:
    """The task of one member for `execute_run`: its folder ``out/<run name>`` and scene."""
    return {
        "name": run.name,
        "dir": str((Path(out) / run.name).resolve()),
        "scene_toml": run.scene.to_toml(),
        "scene_name": run.scene.name,
        "fingerprint": scene_fingerprint(run.scene),
        "arch": arch,
        "threads": threads,
        "report": True,
        "overwrite": overwrite,
    }


def _summary(rec: dict) -> str:
    if rec.get("status") == "busy":
        return (
            f"skipped: another process is running it now ({rec.get('holder')}); "
            "run the sweep again when it has finished"
        )
    m = rec.get("metrics") or {}
    last = {
        k: (m.get(k) or [None])[-1] for k in ("time", "finger_count", "wavelength", "elongation")
    }
    wl = last["wavelength"]
    xl = last["elongation"]
    verb = "reused" if rec.get("status") == "reused" else "done"
    return (
        f"{verb} in {rec.get('wall_s', 0):.1f} s ({rec.get('steps')} steps, "
        f"{rec.get('rhs_evaluations')} operator evaluations); at t = {last['time']:g} s: "
        f"{count_text(last['finger_count'])}, wavelength "
        f"{'-' if wl is None else f'{100 * wl:.1f} cm'}, elongation "
        f"{'-' if xl is None else f'{xl:.3f} m'}"
    )


# =================================================================================================
# The table
# =================================================================================================
