"""Atomic file output: every file lcnav writes appears whole or not at all.

Writers put the bytes in a temporary file in the destination folder and
``os.replace`` it onto the final name, so an interrupted run never leaves a
half-written table, light curve or recording behind.

A command that fills an output folder does it inside :func:`output_folder`:

* a lock (``fcntl.flock`` on ``OUT/.lcnav.lock``, non-blocking, the file removed
  on release): a second lcnav writing to the same folder is refused at once,
  naming the holder's pid;
* under the lock, stale temporary files of a killed run (``.NAME.XXXX.tmp``,
  ``.lcnav-stage-*``) are removed and the completion marker is taken away;
* the command writes into a private staging folder (or, for a resumable study,
  into ``OUT`` itself); only when everything has succeeded are the staged files
  renamed into ``OUT`` and the marker ``OUT/.complete.json`` (command, lcnav
  version, UTC time, files) written last. On failure the staged files are
  removed, and a folder the command created is removed again.

So a folder without ``.complete.json`` is unfinished (killed, interrupted or
failed), never mistaken for a result.

A full file system (``ENOSPC``, also pyarrow's ``[errno 28]`` text) while
writing becomes :class:`NoSpaceError` naming the folder being written (the
``--out`` folder for a command's outputs), after the partial files are removed.
"""

from __future__ import annotations

import contextlib
import datetime
import errno
import fcntl
import json
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from studies.engine import interrupt

if TYPE_CHECKING:  # pandas is imported by the writers that need it, not by every command
    import pandas as pd


class NoSpaceError(OSError):
    """The file system of an output folder is full (``ENOSPC``); ``filename`` is the folder."""


def _is_no_space(e: OSError) -> bool:
    # pyarrow reports a full disk as a plain OSError whose text holds "[errno 28]", without errno set
    return isinstance(e, NoSpaceError) or e.errno in (errno.ENOSPC, errno.EDQUOT) or f"errno {errno.ENOSPC}]" in str(e).lower()


def no_space(folder) -> NoSpaceError:
    """A :class:`NoSpaceError` naming ``folder``, the folder whose file system is full."""
    return NoSpaceError(errno.ENOSPC, "no space left on device: expected a folder on a file system with free space", str(folder))


@contextlib.contextmanager
def _full_disk_names(folder) -> Iterator[None]:
    """Turn a full-disk OSError raised in the block into a :class:`NoSpaceError` naming ``folder`` (the outermost: the user's folder)."""
    try:
        yield
    except OSError as e:
        if _is_no_space(e):
            raise no_space(folder) from None
        raise


@contextlib.contextmanager
def _temporary(path) -> Iterator[Path]:
    """A new empty file ``.NAME.XXXX.tmp`` next to ``path`` (ordinary permissions); removed on exit if still there."""
    path = Path(path)
    with _full_disk_names(path.parent):
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    # mkstemp makes the file owner-only (0600); give it the permissions an
    # ordinary new file would have (0666 less the umask).
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    tmp = Path(tmp)
    try:
        with _full_disk_names(path.parent):
            yield tmp
    finally:
        if tmp.exists():
            tmp.unlink()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike):
    """Yield a temporary path next to ``path``; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched.
    """
    with _temporary(path) as tmp:
        yield tmp
        os.replace(tmp, path)


def write_text(path, text: str) -> Path:
    """Write ``text`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_json(path, obj) -> Path:
    """Write ``obj`` as indented JSON, atomically."""
    return write_text(path, json.dumps(obj, indent=2, sort_keys=False) + "\n")


def write_table(path, df: pd.DataFrame, *, csv: bool = False) -> Path:
    """Write ``df`` as Parquet (and, with ``csv=True``, a CSV twin for humans), atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        df.to_parquet(tmp, index=False)
    if csv:
        with atomic_path(path.with_suffix(".csv")) as tmp:
            df.to_csv(tmp, index=False)
    return path


LOCK_FILE = ".lcnav.lock"
COMPLETE_FILE = ".complete.json"
STAGE_PREFIX = ".lcnav-stage-"


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("lcnav")
    except PackageNotFoundError:
        return "unknown"


@contextlib.contextmanager
def atomic_paths(*paths) -> Iterator[list[Path]]:
    """Temporary paths next to each of ``paths``; all renamed onto them only if the block succeeds.

    For a command writing several files that belong together (a light curve and
    its recording): on any exception none of them is written. Each file's lock
    (:func:`file_lock`) is held meanwhile, so a second lcnav writing the same
    file is refused instead of racing this one.
    """
    with contextlib.ExitStack() as stack:
        for p in paths:
            Path(p).parent.mkdir(parents=True, exist_ok=True)
            stack.enter_context(file_lock(p))
        tmps = [stack.enter_context(_temporary(p)) for p in paths]
        yield tmps
        for tmp, path in zip(tmps, paths):
            os.replace(tmp, path)


_STALE_TMP = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp$")  # what _temporary (mkstemp) names


def clean_stale(out: Path, depth: int = 2) -> list[Path]:
    """Remove what a killed lcnav left in ``out`` (and ``depth`` levels below): temporary files and staging folders.

    Only names lcnav makes are touched (``.NAME.XXXXXXXX.tmp``, ``.lcnav-stage-*``); call under the lock.
    """
    removed = []
    for level in range(depth + 1):
        for p in sorted(out.glob("/".join(["*"] * level + [".*"]))):
            if p.is_file() and _STALE_TMP.match(p.name):
                p.unlink(missing_ok=True)
                removed.append(p)
            elif level == 0 and p.is_dir() and p.name.startswith(STAGE_PREFIX):
                shutil.rmtree(p, ignore_errors=True)
                removed.append(p)
    return removed


def is_complete(out) -> dict | None:
    """The completion record of ``out`` (``.complete.json``), or None if the folder is unfinished."""
    path = Path(out) / COMPLETE_FILE
    try:
        rec = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return rec if isinstance(rec, dict) else None


class FolderBusy(ValueError):
    """Another lcnav holds the lock of the output folder."""


@contextlib.contextmanager
def _lock(path: Path, what: str) -> Iterator[None]:
    """Hold the lock file ``path`` (non-blocking ``flock``); FolderBusy ``<what>: another lcnav is writing to it (pid N)`` otherwise.

    The lock file holds the holder's pid and is removed on release. A waiter
    that opened the file just before it was removed would lock a file no one
    else sees, so after locking the inode is compared with the path's and the
    attempt repeated if they differ (the usual lock-file protocol).
    """
    for _ in range(100):
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            if e.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise
            raise FolderBusy(f"{what}: another lcnav is writing to it (pid {holder}): expected a path no other lcnav is using "
                             "(wait for it to finish or choose another)") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)  # locked a lock file that its holder removed meanwhile: try the new one
    else:  # pragma: no cover - 100 lost races in a row
        raise FolderBusy(f"{what}: could not take its lock: expected a path no other lcnav is using")
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        path.unlink(missing_ok=True)  # still under the lock: a waiter sees no file or a new one
        os.close(fd)


def folder_lock(out: Path):
    """Hold ``OUT/.lcnav.lock``: a second lcnav writing to ``out`` is refused at once, naming this one's pid."""
    return _lock(Path(out) / LOCK_FILE, f"--out {str(out)!r}")


def file_lock(path: Path):
    """Hold ``.NAME.lcnav.lock`` next to the output file ``path`` (a bare ``--out lc.ecsv``), as :func:`folder_lock` does for a folder."""
    path = Path(path)
    return _lock(path.parent / f".{path.name}{LOCK_FILE}", repr(str(path)))


@contextlib.contextmanager
def output_folder(out, command: str, *, staged: bool = True, check=None) -> Iterator[Path]:
    """Write a command's outputs into ``out`` as one unit (see the module docstring).

    Yields the folder to write into: a private staging folder inside ``out``
    (``staged=True``; its files are renamed into ``out`` when the block
    succeeds) or ``out`` itself (``staged=False``, for a resumable study whose
    runs land one by one). ``check(out)``, if given, runs under the lock before
    anything in ``out`` changes (e.g. that a folder to resume holds the same
    study). ``OUT/.complete.json`` is written last, on success only; with
    ``staged=False`` the caller removes the old marker before its first write.
    """
    out = Path(out)
    with _full_disk_names(out):
        with _output_folder(out, command, staged, check) as stage:
            yield stage


@contextlib.contextmanager
def _output_folder(out: Path, command: str, staged: bool, check) -> Iterator[Path]:
    created = []
    p = out
    while not p.exists():
        created.append(p)
        p = p.parent
    out.mkdir(parents=True, exist_ok=True)
    ok = False
    try:
        with folder_lock(out):
            if check is not None:
                check(out)
            clean_stale(out)
            stage = Path(tempfile.mkdtemp(prefix=STAGE_PREFIX, dir=out)) if staged else out
            try:
                yield stage
                interrupt.check()  # a Ctrl-C swallowed by the block's code still leaves the folder unfinished
                names = []
                if staged:
                    (out / COMPLETE_FILE).unlink(missing_ok=True)
                    for f in sorted(stage.rglob("*")):
                        if f.is_file():
                            dest = out / f.relative_to(stage)
                            dest.parent.mkdir(parents=True, exist_ok=True)
                            os.replace(f, dest)
                            names.append(str(f.relative_to(stage)))
                write_json(out / COMPLETE_FILE, {"command": command, "lcnav_version": _version(),
                                                 "finished_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                                                 **({"files": names} if staged else {})})
                ok = True
            finally:
                if staged:
                    shutil.rmtree(stage, ignore_errors=True)
    finally:
        if not ok and created:
            # a folder this command created and left empty is removed again
            for d in [out / "runs", *created]:
                with contextlib.suppress(OSError):
                    d.rmdir()
