"""The Dask client studies and optimizations run on: a local cluster or a given scheduler."""

from __future__ import annotations

import os
import signal


def open_client(scheduler: str | None, workers: int | None, default_workers: int = 2):
    """(client, local cluster or None, numba threads per task or None, task slots).

    dask.distributed takes about a second to import: only imported when work runs.

    Raises
    ------
    RuntimeError
        If the scheduler cannot be reached (the message names ``scheduler``).
    """
    from dask.distributed import Client, LocalCluster

    if scheduler is None:
        n = workers or default_workers
        # worker processes inherit an ignored SIGINT: Ctrl-C reaches only this process,
        # which closes the cluster, instead of every worker printing a traceback
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
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


def close_client(client, cluster) -> None:
    """Close the client and the local cluster (if one was started)."""
    client.close()
    if cluster is not None:
        cluster.close()
