"""The Dask client studies and optimizations run on: a local cluster or a given scheduler."""

from __future__ import annotations

import os
import shutil
import signal
from pathlib import Path

#: the local cluster's scratch folder (Dask's locks and worker spill), inside ``--out``
#: while a run lasts and removed when it closes, so nothing is written outside ``--out``
SCRATCH = ".dask-scratch"

_LOCAL_SCHEMES = ("inproc", "ucx")


def check_scheduler(scheduler: str | None) -> None:
    """Refuse a scheduler that is not an address, before any file or cluster exists.

    Checks the form only (``tcp://HOST:PORT`` or ``HOST:PORT``); whether anything answers
    there is only known when the run connects.

    Raises
    ------
    ValueError
        Naming ``scheduler``.
    """
    if scheduler is None:
        return
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise ValueError(f"scheduler: {scheduler!r} is not a scheduler address (tcp://HOST:PORT)")
    from distributed.comm.addressing import get_address_host_port, parse_address

    try:
        scheme, _ = parse_address(scheduler)
        if scheme not in _LOCAL_SCHEMES:
            get_address_host_port(scheduler)
    except (ValueError, TypeError) as exc:
        raise ValueError(
            f"scheduler: {scheduler!r} is not a scheduler address (tcp://HOST:PORT): {exc}"
        ) from None


def open_client(
    scheduler: str | None,
    workers: int | None,
    default_workers: int = 2,
    out: Path | None = None,
):
    """(client, local cluster or None, numba threads per task or None, task slots).

    dask.distributed takes about a second to import: only imported when work runs. A
    local cluster keeps its scratch files in ``out / SCRATCH`` (Dask's default is the
    system's temporary folder); :func:`close_client` removes it.

    Raises
    ------
    RuntimeError
        If the scheduler cannot be reached (the message names ``scheduler``).
    """
    import dask
    from dask.distributed import Client, LocalCluster

    if scheduler is None:
        n = workers or default_workers
        scratch = {} if out is None else {"temporary-directory": str(Path(out) / SCRATCH)}
        # worker processes inherit an ignored SIGINT: Ctrl-C reaches only this process,
        # which closes the cluster, instead of every worker printing a traceback
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            # the workers copy the configuration when they start (restarts included)
            with dask.config.set(scratch):
                cluster = LocalCluster(
                    n_workers=n,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    silence_logs=50,
                )
        finally:
            signal.signal(signal.SIGINT, previous)
        return Client(cluster), cluster, max(1, (os.cpu_count() or 2) // n), n
    try:
        client = Client(scheduler, timeout="10s")
    except (OSError, TimeoutError) as exc:
        raise RuntimeError(f"scheduler: cannot reach {scheduler}: {exc}") from None
    except ValueError as exc:  # not an address at all ("foo": no port)
        raise ValueError(
            f"scheduler: {scheduler!r} is not a scheduler address (tcp://HOST:PORT): {exc}"
        ) from None
    n = workers or max(1, len(client.scheduler_info().get("workers", {})))
    return client, None, None, n


def close_client(client, cluster, out: Path | None = None) -> None:
    """Close the client and the local cluster (if one was started); remove its scratch.

    The scratch goes even when closing fails or is interrupted (a second Ctrl-C while the
    workers stop left it behind).
    """
    try:
        client.close()
        if cluster is not None:
            cluster.close()
    finally:
        if cluster is not None and out is not None:
            shutil.rmtree(Path(out) / SCRATCH, ignore_errors=True)
