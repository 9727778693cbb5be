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
  and temporary files removed, the lock released, the local Dask cluster closed.
  If the signal lands in code where Python cannot raise (a garbage-collector
  callback such as Dask's ``GCDiagnosis``, a finaliser), Python would print
  "Exception ignored in ..." with a traceback and go on; :func:`_on_unraisable`
  instead stays silent and sends the interrupt again to the main thread, where
  it unwinds as above; any other error a finaliser raises after Ctrl-C (an
  object the interrupt left half-built) is silenced as well;
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
_redeliver = threading.Event()  # the first Ctrl-C's KeyboardInterrupt was swallowed: raise it again, not as a second Ctrl-C
_previous_hook = [sys.unraisablehook]  # the unraisable hook handling() replaced
#: Delay before a swallowed interrupt is sent again, s: long enough for the hook that saw it to return.
REDELIVER_S = 0.01


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
    if _redeliver.is_set():  # the interrupt sent again by _on_unraisable: unwind (the grace timer already runs)
        if _inside_the_hook(frame):  # it came before the hook returned: again a moment later
            _send_again_soon()
            return
        _redeliver.clear()
        raise KeyboardInterrupt
    if _interrupted.is_set():  # a second Ctrl-C: stop at once
        exit_now()
    _interrupted.set()
    timer = threading.Timer(GRACE_S, exit_now)
    timer.daemon = True
    timer.start()
    raise KeyboardInterrupt


def _on_unraisable(unraisable) -> None:
    """The :func:`sys.unraisablehook` of :func:`handling`: a swallowed ``KeyboardInterrupt`` of this command is sent again.

    Measured: 3 of 8 ``study tuning --quick`` interrupted as their progress bar appeared raised it inside Dask's
    garbage-collector callback; Python printed "Exception ignored in ... GCDiagnosis._gc_callback" with the traceback,
    and the study ran on to its end before exiting 130. After Ctrl-C any other unraisable is silenced too (the command
    is being aborted; a finaliser failing on what the interrupt cut short is not news); before it, an unraisable goes to
    the hook that was installed before.
    """
    if _interrupted.is_set() and unraisable.exc_type is not None:
        if issubclass(unraisable.exc_type, KeyboardInterrupt):
            _redeliver.set()
            _send_again_soon()
        # else: the echo of the interrupt in a finaliser of an object it left half-built, silenced (measured in CI:
        # Ctrl-C inside numba's compiler left an llvmlite ``OutputString`` without ``_ptr``; its ``close`` raised
        # AttributeError and Python printed "Exception ignored in ..." with a traceback before ``lcnav: aborted``)
        return
    _previous_hook[0](unraisable)


def _send_again_soon() -> None:
    """SIGINT to the main thread from another thread, :data:`REDELIVER_S` from now (a real signal: it also wakes a
    blocking wait, which :func:`_thread.interrupt_main` would not)."""
    timer = threading.Timer(REDELIVER_S, signal.pthread_kill, (threading.main_thread().ident, signal.SIGINT))
    timer.daemon = True
    timer.start()


def _inside_the_hook(frame) -> bool:
    while frame is not None:
        if frame.f_code is _on_unraisable.__code__:
            return True
        frame = frame.f_back
    return False


@contextlib.contextmanager
def handling() -> Iterator[None]:
    """Install the SIGINT handler and :func:`_on_unraisable` for the block (main thread only; elsewhere a no-op) and
    restore the old ones after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _interrupted.clear()
    _redeliver.clear()
    _said[0] = False
    _previous_hook[0] = sys.unraisablehook
    sys.unraisablehook = _on_unraisable
    old = signal.signal(signal.SIGINT, _handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
        sys.unraisablehook = _previous_hook[0]
