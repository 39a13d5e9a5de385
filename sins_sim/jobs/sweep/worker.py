"""What runs on the sweep's Dask workers besides the runs: quiet shutdown logs.

This module imports only the standard library at the top, so that unpickling anything from it on a worker
does not load numba before the worker's environment is set.
"""

from __future__ import annotations

import logging

__all__ = ["mute_distributed_logs", "restore_logs", "mute_worker_logs", "SHUTDOWN_LOGGERS"]

#: Loggers whose records during the cluster's shutdown are the cluster's business, not the user's: a worker's
#: heartbeat that meets a scheduler already closing logs ``CommClosedError ... heartbeat_worker`` with its
#: traceback (distributed.worker.Worker.heartbeat, logger.exception), the nannies log the processes they stop.
SHUTDOWN_LOGGERS = ("distributed", "tornado", "asyncio")


def mute_distributed_logs() -> list:
    """Silence :data:`SHUTDOWN_LOGGERS` and every child logger in this process; returns what
    :func:`restore_logs` needs to put the levels back.

    Called on every worker (``client.run``) and in the client's process just before the cluster closes, and
    only then: while the runs go on, a worker's error still reaches its log.
    """
    names = [n for n in list(logging.root.manager.loggerDict)
             if any(n == r or n.startswith(r + ".") for r in SHUTDOWN_LOGGERS)]
    saved = []
    for name in sorted(set(names) | set(SHUTDOWN_LOGGERS)):
        lg = logging.getLogger(name)
        saved.append((lg, lg.level, lg.disabled))
        lg.setLevel(logging.CRITICAL + 1)
        lg.disabled = True
    return saved


def restore_logs(saved: list) -> None:
    """Undo :func:`mute_distributed_logs`."""
    for lg, level, disabled in saved:
        lg.setLevel(level)
        lg.disabled = disabled


def mute_worker_logs() -> None:
    """:func:`mute_distributed_logs` on a worker (``client.run``; the worker process ends with the cluster)."""
    mute_distributed_logs()
