"""Many recordings in parallel on Dask distributed: skip what is finished, run the rest, summarise.

Scheduling
----------
``scheduler="local"`` starts a :class:`distributed.LocalCluster` of ``workers`` processes with one
thread each (the numerical work holds the GIL and numpy's own threads are pinned to one by Dask's
nanny); any other value is the address of a running scheduler (``tcp://host:8786``), reached with
:class:`distributed.Client`. On a real cluster the workers must have bayes_emt installed and see
the input and output paths (a shared file system): only file paths and plain settings are sent,
and each worker writes its recording's folder itself.

Resuming and killing
--------------------
Before submitting, every input whose result folder is finished (:func:`~bayes_emt.batch.jobs.is_finished`:
completion marker written atomically last, same input bytes, same settings) is skipped. Every
output is written atomically and the marker last, so killing the batch at any moment loses at
most the files in progress; their sampler checkpoints let the re-run continue their chains. The
summary (CSV, HTML, JSON) is rewritten from the folders after each completed file. On SIGINT or
SIGTERM a local cluster's worker processes are killed at once (not closed gracefully, which waits
for the files in progress); on SIGKILL of this process they end by themselves (each Dask worker
process watches its parent).
"""

from __future__ import annotations

import json
import logging
import sys
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from .._atomic import atomic_write_text
from .inputs import BatchInput, find_inputs
from .jobs import ERROR_FILE, BatchSettings, FileOutcome, is_finished, process_file, read_marker
from .summary import write_summary

__all__ = ["BatchResult", "run_batch", "open_client"]


@dataclass(frozen=True)
class BatchResult:
    """The outcome of a batch run.

    Attributes
    ----------
    out : the output folder (``summary.csv``, ``summary.html`` and one folder per recording).
    outcomes : one :class:`FileOutcome` per input, in input order (``skipped`` for those an
        earlier run had finished).
    counts : number of recordings by status on disk after the run: ``done``, ``error``, ``pending``.
    """

    out: Path
    outcomes: tuple[FileOutcome, ...]
    counts: dict

    @property
    def ran(self) -> tuple[str, ...]:
        """Folder names of the recordings this run processed (not skipped)."""
        return tuple(o.name for o in self.outcomes if o.status != "skipped")

    @property
    def errors(self) -> tuple[FileOutcome, ...]:
        return tuple(o for o in self.outcomes if o.status == "error")


def open_client(scheduler: str = "local", workers: int | None = None):
    """A Dask client: a new local cluster (``"local"``) or a connection to a scheduler address.

    Returns ``(client, cluster)``; ``cluster`` is None for a remote scheduler. Close both.
    """
    from distributed import Client, LocalCluster

    if scheduler == "local":
        import os

        n = workers or max(1, min(os.cpu_count() or 1, 4))
        if n < 1:
            raise ValueError(f"--workers must be at least 1, got {n}")
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR)
        return Client(cluster), cluster
    if workers is not None:
        raise ValueError("--workers applies to --scheduler local only (a remote cluster has its own workers)")
    try:
        return Client(scheduler, timeout="10s"), None
    except (OSError, TimeoutError, ValueError) as exc:
        raise ValueError(f"--scheduler {scheduler}: cannot connect ({exc})") from None


def run_batch(source: str | Path, out: str | Path, settings: BatchSettings, *, scheduler: str = "local",
              workers: int | None = None, progress: bool | None = None,
              on_outcome: Callable[[FileOutcome], None] | None = None, client=None) -> BatchResult:
    """Run ``settings.jobs`` on every recording of ``source`` in parallel; resumable.

    Parameters
    ----------
    source : a folder or a glob pattern (:func:`~bayes_emt.batch.inputs.find_inputs`).
    out : output folder (created); one sub-folder per recording, ``summary.csv``, ``summary.html``.
    settings : the jobs, model and sampler budget (:class:`~bayes_emt.batch.jobs.BatchSettings`).
    scheduler : ``"local"`` or a scheduler address; ``workers``: local worker processes
        (default: the number of cores, at most 4).
    progress : a tqdm bar over recordings on stderr (default: when stderr is a terminal).
    on_outcome : called in the client process with each :class:`FileOutcome` as it arrives.
    client : an open ``distributed.Client`` to use instead of ``scheduler``/``workers``.
    """
    out = Path(out)
    inputs = find_inputs(source, out=out)
    out.mkdir(parents=True, exist_ok=True)
    finished = {inp.name for inp in inputs if is_finished(inp, out / inp.name, settings)}
    todo = [inp for inp in inputs if inp.name not in finished]
    outcomes: dict[str, FileOutcome] = {}
    for inp in inputs:
        if inp.name in finished:
            marker = read_marker(out / inp.name) or {}
            outcomes[inp.name] = FileOutcome(inp.name, str(inp.path), "skipped",
                                             summary=marker.get("summary", {}),
                                             warnings=tuple(marker.get("warnings", ())))
    if todo:
        _run(todo, out, settings, scheduler, workers, progress, on_outcome, client, outcomes)
    counts = write_summary(inputs, out, jobs=settings.jobs, model=settings.model)
    return BatchResult(out=out, outcomes=tuple(outcomes[i.name] for i in inputs), counts=counts)


def _kill_local_workers(cluster) -> None:
    """SIGKILL the worker processes of a :class:`distributed.LocalCluster` this process started. A
    graceful close waits for the files in progress (seconds to minutes); their outputs are written
    atomically and the completion marker last, so a re-run redoes just those files."""
    import os
    import signal

    for nanny in list(getattr(cluster, "workers", {}).values()):
        pid = getattr(getattr(getattr(nanny, "process", None), "process", None), "pid", None)
        if pid:
            try:
                os.kill(pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass


def _run(todo: list[BatchInput], out: Path, settings, scheduler, workers, progress, on_outcome, client,
         outcomes: dict) -> None:
    from distributed import as_completed
    from tqdm.auto import tqdm

    own = client is None
    cluster = None
    if own:
        client, cluster = open_client(scheduler, workers)
    bar = tqdm(total=len(todo), disable=not (sys.stderr.isatty() if progress is None else progress),
               file=sys.stderr, desc="batch", unit="file")
    try:
        futures = {client.submit(process_file, inp, str(out / inp.name), settings, pure=False,
                                 key=f"bayes-emt-{inp.name}-{uuid.uuid4().hex[:8]}"): inp for inp in todo}
        all_inputs = sorted(set(todo) | {BatchInput(Path(o.file), o.name) for o in outcomes.values()},
                            key=lambda i: i.path)
        for fut in as_completed(futures):
            inp = futures[fut]
            try:
                res = fut.result()
            except Exception as exc:  # noqa: BLE001 (a worker died: report this file, keep the others)
                first = (str(exc).splitlines() or [""])[0]
                msg = f"the worker running it failed: {type(exc).__name__}: {first}"
                res = FileOutcome(inp.name, str(inp.path), "error", error=msg)
                (out / inp.name).mkdir(parents=True, exist_ok=True)
                record = {"file": str(inp.path), "error": msg, "type": type(exc).__name__}
                atomic_write_text(out / inp.name / ERROR_FILE, json.dumps(record))
            outcomes[inp.name] = res
            bar.update(1)
            if on_outcome is not None:
                on_outcome(res)
            write_summary(all_inputs, out, jobs=settings.jobs, model=settings.model)
    except KeyboardInterrupt:  # SIGINT or SIGTERM: end the local workers now, not after their files
        # the client's comms close under it: distributed logs each with a traceback (at INFO) on
        # stderr, where the user is owed one line ("interrupted"); nothing it would say helps now
        logging.getLogger("distributed").setLevel(logging.CRITICAL + 1)
        if cluster is not None:
            _kill_local_workers(cluster)
        raise
    finally:
        bar.close()
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
