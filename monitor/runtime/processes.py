"""Analysis processes that die with their parent and inherit none of its files or sockets.

A process pool forked from a server holds copies of every descriptor the
server had open, the listening socket included, and never learns that its
parent died: after ``kill -9`` of the server its children live on, keep the
port, and a restart fails with "address already in use". So the pools here:

- start their processes with ``multiprocessing``'s ``spawn`` method: a
  fresh interpreter started by ``exec``, which receives only the pipes it
  needs (Python opens every descriptor not inheritable), so none holds the
  server's socket or files. (The ``forkserver`` method would not do: each
  of its processes holds the pipe whose closing tells the fork server its
  parent died, so after a ``kill -9`` the fork server and its processes wait
  for each other for ever);
- make each process die with its parent: on Linux the kernel sends it
  ``SIGKILL`` when the thread that started it ends
  (``prctl(PR_SET_PDEATHSIG)``; pools are started by threads that live as
  long as the pool), and on any system a thread in it checks every
  :data:`WATCH_S` seconds that its parent is still the one it started with.

A new process imports the analysis modules itself, a few seconds once per
pool (the worker's pool lives as long as the worker). The batch, a command
that listens on nothing, forks its processes instead, so they start at once;
they die with it all the same. The worker ends its pool with
:func:`close_pool`, never leaving it to end by itself.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

__all__ = ["NICE", "WATCH_S", "analysis_pool", "close_pool", "die_with_parent", "session_processes"]

#: The niceness of the service's background processes, validators and analyses (0 is the server's,
#: 19 the lowest priority): where they and the server want the same core, reads are answered first.
NICE = 10

#: Seconds between an analysis process's looks at its parent (where the kernel does not tell it).
WATCH_S = 1.0
_PR_SET_PDEATHSIG = 1  # linux/prctl.h
_EXIT_ORPHANED = 70  # the exit status of a process whose parent died (EX_SOFTWARE)


def analysis_pool(max_workers: int, *, fork: bool = False) -> ProcessPoolExecutor:
    """A process pool whose processes die with this process and inherit none of its descriptors.

    Parameters
    ----------
    max_workers : int
        Processes at most.
    fork : bool, optional
        Fork the processes instead (Linux): they start at once with the modules this process has
        imported, but hold copies of its descriptors. Only for a process with no socket a child
        must not keep: the batch, a command line, never the server.

    Returns
    -------
    ProcessPoolExecutor
    """
    context = multiprocessing.get_context("fork" if fork and sys.platform.startswith("linux") else "spawn")
    return ProcessPoolExecutor(
        max_workers=max(1, max_workers),
        mp_context=context,
        initializer=die_with_parent,
        initargs=(os.getpid(),),
    )


def close_pool(pool: ProcessPoolExecutor) -> None:
    """End a pool now: its processes ended, its manager thread joined, its queues closed and released.

    Its running analyses are abandoned (the worker's jobs are taken back after their lease), so this
    returns within a moment rather than when they end. The pool's queues hold named semaphores, which the
    resource tracker reports as leaked unless they are unlinked and unregistered before this process
    ends. ``shutdown(wait=False)`` leaves that to the pool's manager thread, which releases its queues
    as it ends: a daemon thread when the pool's first submission came from one (it inherits the
    submitter's kind), which the interpreter's exit does not wait for and stops where it stands, one
    semaphore unlinked and not unregistered. Here the manager thread is joined first, so the shutdown
    drops the queues' last references in the caller's thread, which releases them within this call.

    Parameters
    ----------
    pool : ProcessPoolExecutor
        A pool of :func:`analysis_pool`, used or not, broken or not.
    """
    # a process that ends makes the pool "broken": its manager thread then fails what was submitted,
    # closes the queues and joins the processes, and ends
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()
    pool.shutdown(wait=True, cancel_futures=True)


def die_with_parent(parent: int) -> None:
    """Make this process end when its parent does (a pool's initializer).

    The kernel's parent-death signal where there is one (Linux), and a watching
    thread everywhere; a parent already gone before either was set ends the
    process at once.

    Parameters
    ----------
    parent : int
        The process id of the pool's owner, this process's parent. (Not "1 means orphaned": in a
        container the owner is often process 1 itself.)
    """
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # orphaned before the signal was set
        os._exit(_EXIT_ORPHANED)
    threading.Thread(target=_watch, args=(parent,), name="parent-watch", daemon=True).start()


def _watch(parent: int) -> None:
    while True:
        time.sleep(WATCH_S)
        if os.getppid() != parent:
            os._exit(_EXIT_ORPHANED)


def session_processes(session: int) -> list[int]:
    """The live processes of a session, zombies left out (Linux's ``/proc``; none elsewhere).

    A service started in a session of its own (``start_new_session``) has its session id equal to its
    process id: what is left of it after it was killed is this list.

    Parameters
    ----------
    session : int
        The session id.

    Returns
    -------
    list of int
        Process ids.
    """
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[3]) == session and fields[0] not in ("Z", "X"):
            found.append(int(stat.parent.name))
    return found
