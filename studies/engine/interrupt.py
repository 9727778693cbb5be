"""Ctrl-C for lcnav: exit 130 with one line ``lcnav: aborted``, whatever was running.

A terminal's Ctrl-C sends SIGINT to the whole process group: lcnav and any
Dask worker processes it started. Python's default handler raises
``KeyboardInterrupt`` wherever the main thread happens to be, and some of that
code swallows it (numba's compiler, Dask's event loop), so an interrupted
command used to exit 0 with nothing said, or hang on a lock. :func:`handling`
installs a handler that

* records the interrupt (:func:`interrupted`), so that :func:`studies.engine.io.output_folder`
  never writes ``.complete.json`` after it and :func:`studies.cli.main` exits 130
  even if the exception was swallowed on the way;
* raises ``KeyboardInterrupt`` once, so ``with`` blocks unwind: staging folders
  and temporary files removed, the lock released, the local Dask cluster closed;
* ends the process with status 130 if unwinding (or the interpreter's exit after
  it) takes longer than :data:`GRACE_S` or a second Ctrl-C arrives (``os._exit``; a killed run's temporary files are
  removed by the next command on the same ``--out``, see :func:`studies.engine.io.clean_stale`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator

#: Exit status of an interrupted command (128 + SIGINT, what shells report).
EXIT_ABORTED = 130
#: Longest time the unwinding after Ctrl-C may take (closing a Dask cluster takes a few seconds), s.
GRACE_S = 30.0
MESSAGE = "lcnav: aborted"

_interrupted = threading.Event()
_lock = threading.RLock()  # re-entrant: a second Ctrl-C may arrive (in the same thread) while the line is printed
_said = [False]  # the one line printed for this command


def interrupted() -> bool:
    """True once this command received SIGINT."""
    return _interrupted.is_set()


def check() -> None:
    """Raise ``KeyboardInterrupt`` if SIGINT arrived (for code that may have swallowed it)."""
    if _interrupted.is_set():
        raise KeyboardInterrupt


def report() -> int:
    """Print ``lcnav: aborted`` (once per process) and return :data:`EXIT_ABORTED`."""
    with _lock:
        if not _said[0]:
            _said[0] = True
            print(_fresh_line() + MESSAGE, file=sys.stderr, flush=True)
    return EXIT_ABORTED


def _fresh_line() -> str:
    """What puts the message on a line of its own after a progress bar the interrupt left unfinished (``tuning:  0%|...|``).

    On a terminal: back to column 0 and erase the bar (``\r``, ANSI erase-in-line); in a file or pipe, a line break if
    a bar may have been drawn (tqdm loaded); else nothing.
    """
    try:
        tty = sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced or closed stream
        tty = False
    return "\r\x1b[K" if tty else "\n" if "tqdm" in sys.modules else ""


def exit_now() -> None:
    """End the process with :data:`EXIT_ABORTED` after ``lcnav: aborted``, without the interpreter's teardown.

    The teardown runs library finalisers; one interrupted mid-way (numba compiling
    through LLVM) can then crash the process ("double free", SIGABRT) instead of
    exiting 130.
    """
    report()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # closed or broken pipe: nothing more to say
            pass
    os._exit(EXIT_ABORTED)


def _handler(signum, frame) -> None:
    if _interrupted.is_set():  # a second Ctrl-C: stop at once
        exit_now()
    _interrupted.set()
    timer = threading.Timer(GRACE_S, exit_now)
    timer.daemon = True
    timer.start()
    raise KeyboardInterrupt


@contextlib.contextmanager
def handling() -> Iterator[None]:
    """Install the SIGINT handler for the block (main thread only; elsewhere a no-op) and restore the old one after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _interrupted.clear()
    _said[0] = False
    old = signal.signal(signal.SIGINT, _handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
