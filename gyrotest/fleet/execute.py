"""Where the per-campaign analyses run: in this process, on a process pool, or on Dask.

Each campaign is one task (:func:`gyrotest.fleet.core.analyse_campaign`, which returns a
plain record); the lot summary is computed here from the records in the order the campaigns
were given, so every way of running gives the same numbers.

* ``jobs=1``: one after the other in this process;
* ``jobs=N`` (default: the number of CPU cores): a :class:`concurrent.futures.ProcessPoolExecutor`;
* ``scheduler="local"``: a Dask ``distributed.LocalCluster`` on this machine;
  ``scheduler="tcp://host:8786"``: an existing Dask cluster (the workers need gyrotest
  installed and the campaign files and logs at the same paths, e.g. on a shared file system).
  Dask is the optional extra ``gyrotest[dask]``.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

from ..core.errors import InputError
from .core import Fleet, analyse_campaign, summarise


def default_jobs() -> int:
    """Worker processes by default: the CPU cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def _serial(paths: list[str], progress) -> list[dict[str, Any]]:
    out = []
    for p in paths:
        out.append(analyse_campaign(p))
        if progress:
            progress(p)
    return out


def _pool(paths: list[str], jobs: int, progress) -> list[dict[str, Any]]:
    from concurrent.futures import ProcessPoolExecutor, as_completed

    with ProcessPoolExecutor(max_workers=min(jobs, len(paths))) as ex:
        futs = {ex.submit(analyse_campaign, p): i for i, p in enumerate(paths)}
        out: list[dict[str, Any] | None] = [None] * len(paths)
        for f in as_completed(futs):
            out[futs[f]] = f.result()
            if progress:
                progress(paths[futs[f]])
    return out


def _dask(paths: list[str], scheduler: str, jobs: int, progress) -> list[dict[str, Any]]:
    try:
        from distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise InputError("--scheduler needs Dask: install the extra with "
                         "pip install 'gyrotest[dask]'") from None
    cluster = None
    try:
        if scheduler == "local":
            cluster = LocalCluster(n_workers=min(jobs, len(paths)), threads_per_worker=1,
                                   processes=True, dashboard_address=None)
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler, timeout="10s")
            except OSError as e:
                raise InputError(f"--scheduler {scheduler}: cannot reach the Dask scheduler "
                                 f"({e}); give its address as tcp://HOST:PORT, or 'local'"
                                 ) from None
        try:
            return dask_map(client, paths, progress, as_completed)
        finally:
            client.close()
    finally:
        if cluster is not None:
            cluster.close()


def dask_map(client, paths: list[str], progress=None, as_completed=None) -> list[dict[str, Any]]:
    """Run :func:`analyse_campaign` for every path on a Dask ``client``; records in the order
    of ``paths`` (``pure=False``: a campaign may change on disk between runs)."""
    if as_completed is None:
        from distributed import as_completed as dask_as_completed

        as_completed = dask_as_completed
    futs = client.map(analyse_campaign, paths, pure=False)
    index = {f.key: i for i, f in enumerate(futs)}
    out: list[dict[str, Any] | None] = [None] * len(paths)
    for f in as_completed(futs):
        out[index[f.key]] = f.result()
        if progress:
            progress(paths[index[f.key]])
    return out


def run_fleet(paths: list[str], *, jobs: int | None = None, scheduler: str | None = None,
              client=None, progress: Callable[[str], None] | None = None) -> Fleet:
    """Analyse every campaign in ``paths`` and summarise the lot.

    ``jobs``: worker processes (default :func:`default_jobs`; 1 = in this process);
    ``scheduler``: ``"local"`` or a Dask scheduler address (runs on Dask instead of the pool);
    ``client``: an existing ``distributed.Client`` to use (tests, notebooks). A campaign that
    fails raises :class:`~gyrotest.core.errors.InputError` naming it.
    """
    paths = [str(p) for p in paths]
    if not paths:
        raise InputError("fleet: give one or more CAMPAIGN files")
    seen: dict[str, str] = {}
    for p in paths:
        key = os.path.realpath(p)
        if key in seen:
            raise InputError(f"fleet: campaign {p} is given twice (also as {seen[key]}); give "
                             "each campaign once")
        seen[key] = p
    jobs = default_jobs() if jobs is None else jobs
    if jobs < 1:
        raise InputError(f"--jobs {jobs}: give 1 or more worker processes")
    t0 = time.perf_counter()
    if client is not None:
        records, how = dask_map(client, paths, progress), "dask (given client)"
    elif scheduler:
        records, how = _dask(paths, scheduler, jobs, progress), f"dask ({scheduler})"
    elif jobs == 1 or len(paths) == 1:
        records, how = _serial(paths, progress), "serial"
    else:
        records, how = _pool(paths, jobs, progress), f"process pool ({jobs} workers)"
    for r in records:
        if "error" in r:
            raise InputError(r["error"] if r["error"].startswith(os.path.basename(r["campaign"]))
                             or r["campaign"] in r["error"]
                             else f"{r['campaign']}: {r['error']}")
    fleet = summarise(records)
    fleet.run = {"executor": how, "jobs": jobs, "campaigns": len(paths),
                 "seconds": time.perf_counter() - t0,
                 "campaign_seconds": sum(r["seconds"] for r in records)}
    return fleet
