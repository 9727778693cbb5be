"""Input validation shared by every ``lcnav`` command: bounded numbers, counts, text and paths.

Every check raises :class:`InputError` (a ``ValueError``) with ONE line of the
form ``<what> <value>: expected <form>``, e.g.
``--rate-hz 1000000.0: expected a number within (0, 10]``; ``studies.cli.main``
prints it as ``lcnav: error: ...`` and exits 2. Values are quoted as plain
Python values (``'10'``, ``1e+23``), never as ``np.str_('10')``.

The typer option callbacks (:func:`number`, :func:`count`, :func:`seed`,
:func:`text`, :func:`out_dir`, :func:`out_file`, :func:`in_file`) run while the
command line is parsed, so a bad option stops the command before anything is
computed or written. Each bound is a sane ceiling, so that no option can make a
command hang or exhaust memory (e.g. ``--rate-hz 1e6`` or ``--duration 1e300``).
"""

import errno
import math
import os
import re
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

#: Largest seed (numpy's ``default_rng`` takes any non-negative int; 63 bits fit every table and JSON reader).
MAX_SEED = 2**63 - 1
#: Largest input file read whole (light curves, measurements, priors, configs), bytes.
MAX_INPUT_BYTES = 256 * 2**20
#: Longest text option (names, patterns).
MAX_TEXT = 1000
#: A decimal number as people write it (no hex, no ``1_0``, no ``nan``/``inf``).
DECIMAL = re.compile(r"^\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\s*$")


class InputError(ValueError):
    """A command-line value, file or field is not of the expected form (one line)."""


def plain(value: Any, limit: int = 80) -> str:
    """``value`` quoted as a plain Python value (numpy scalars unwrapped), control characters escaped, shortened."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, Path):
        value = str(value)
    text = repr(value) if isinstance(value, str) else str(value)
    text = text.encode("unicode_escape").decode("ascii") if any(ord(c) < 32 or ord(c) == 127 for c in text) else text
    return text if len(text) <= limit else text[: limit - 3] + "..."


def fail(what: str, value: Any, expected: str) -> NoReturn:
    """Raise :class:`InputError` ``<what> <value>: expected <expected>``."""
    raise InputError(f"{what} {plain(value)}: expected {expected}")


def _interval(lo, hi, lo_open: bool, hi_open: bool) -> str:
    return f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def check_number(what: str, value, lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False, unit: str = "") -> float:
    """``value`` as a finite float within the interval; InputError otherwise."""
    expected = f"a finite number within {_interval(lo, hi, lo_open, hi_open)}{' ' + unit if unit else ''}"
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        fail(what, value, expected)  # text, lists, None: not numbers (a JSON "0.1" is not 0.1)
    try:
        v = float(value)
    except OverflowError:  # an int beyond the float range
        fail(what, value, expected)
    if not math.isfinite(v) or v < lo or v > hi or (lo_open and v == lo) or (hi_open and v == hi):
        fail(what, value, expected)
    return v


def check_count(what: str, value, lo: int, hi: int) -> int:
    """``value`` as an int within ``[lo, hi]`` (bools, fractions and non-finite values refused)."""
    expected = f"an integer within [{lo}, {hi}]"
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        fail(what, value, expected)
    if isinstance(value, float | np.floating) and not (math.isfinite(value) and float(value).is_integer()):
        fail(what, value, expected)
    v = int(value)
    if not lo <= v <= hi:
        fail(what, value, expected)
    return v


def check_text(what: str, value: str, *, choices: Iterable[str] | None = None, max_len: int = MAX_TEXT) -> str:
    """Text without NUL or control characters, at most ``max_len`` characters, one of ``choices`` if given."""
    choices = None if choices is None else list(choices)
    if choices is not None and value not in choices:
        fail(what, value, "one of " + ", ".join(choices))
    if len(value) > max_len or any(ord(c) < 32 or ord(c) == 127 for c in value):
        fail(what, value, f"text of at most {max_len} printable characters")
    return value


def check_path_text(what: str, path) -> Path:
    """A path without NUL bytes and of a length the file system accepts."""
    s = os.fspath(path)
    if "\x00" in s or not s or len(os.fsencode(s)) > 4000 or any(len(os.fsencode(p)) > 255 for p in Path(s).parts):
        fail(what, s, "a path without NUL bytes, each name at most 255 bytes")
    return Path(s)


def _writable_parent(what: str, path: Path) -> None:
    """The nearest existing ancestor of ``path`` must be a folder this process may write into."""
    parent = path.absolute().parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        fail(what, str(path), f"a path under a folder, but {str(parent)!r} is a file")
    if not os.access(parent, os.W_OK | os.X_OK):
        fail(what, str(path), f"a path in a folder you may write to ({str(parent)!r} is not writable)")


def check_out_dir(what: str, path) -> Path:
    """An output folder: a folder or a new path, in a writable place."""
    path = check_path_text(what, path)
    if path.exists():
        if not path.is_dir():
            fail(what, str(path), "a folder or a new path, not an existing file")
        if not os.access(path, os.W_OK | os.X_OK):
            fail(what, str(path), "a folder you may write to")
        return path
    _writable_parent(what, path)
    return path


def check_out_file(what: str, path, suffix: str) -> Path:
    """An output file named ``*<suffix>``, not a folder, in a writable place."""
    path = check_path_text(what, path)
    if path.suffix.lower() != suffix:
        fail(what, str(path), f"a {suffix} file name")
    if path.is_dir():
        fail(what, str(path), f"a {suffix} file, not a folder")
    if path.exists() and not os.access(path, os.W_OK):
        fail(what, str(path), f"a {suffix} file you may write")
    _writable_parent(what, path)
    return path


def check_in_file(what: str, path, suffixes: Iterable[str] | None = None, *, max_bytes: int = MAX_INPUT_BYTES) -> Path:
    """An existing, readable regular file (of one of ``suffixes``), at most ``max_bytes`` long."""
    path = check_path_text(what, path)
    suffixes = None if suffixes is None else tuple(suffixes)
    if suffixes is not None and path.suffix.lower() not in suffixes:
        fail(what, str(path), "a file named " + " or ".join(f"*{s}" for s in suffixes))
    try:
        os.stat(path)
    except OSError as e:
        if e.errno == errno.ELOOP:
            fail(what, str(path), "a file, not a loop of symbolic links")
        raise FileNotFoundError(errno.ENOENT, f"no such file: expected an existing {'/'.join(suffixes) if suffixes else ''} file".replace("  ", " "),
                                f"{what} {str(path)!r}") from None
    if not path.is_file():
        fail(what, str(path), "a file, not a folder")
    if not os.access(path, os.R_OK):
        fail(what, str(path), "a file you may read")
    size = path.stat().st_size
    if size > max_bytes:
        fail(what, str(path), f"a file of at most {max_bytes // 2**20} MiB (it has {size // 2**20} MiB)")
    return path


def check_no_nul(what: str, data: bytes) -> None:
    """Text files must not hold NUL bytes (a binary file given by mistake)."""
    k = data.find(b"\x00")
    if k >= 0:
        raise InputError(f"{what}: NUL byte at offset {k}: expected a text file")


def check_floats(what: str, text: str, n: int, *, max_abs: float) -> np.ndarray:
    """``n`` comma-separated finite numbers of magnitude at most ``max_abs``."""
    expected = f"{n} comma-separated finite numbers within [-{max_abs:g}, {max_abs:g}]"
    try:
        v = np.array([float(s) for s in str(text).split(",")], dtype=float)
    except ValueError:
        fail(what, text, expected)
    if v.shape != (n,) or not np.all(np.isfinite(v)) or np.any(np.abs(v) > max_abs):
        fail(what, text, expected)
    return v


# ---------------------------------------------------------------- typer option callbacks


def _flag(param) -> str:
    opts = getattr(param, "opts", None) or [getattr(param, "name", "value") or "value"]
    return max(opts, key=len) if opts[0].startswith("-") else str(getattr(param, "name", opts[0])).upper()


def _callback(check: Callable[[str, Any], Any]):
    import typer

    def callback(param: typer.CallbackParam, value):
        if value is None:
            return None
        if isinstance(value, list | tuple):
            return [check(_flag(param), v) for v in value]
        return check(_flag(param), value)

    return callback


def number(lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False, unit: str = ""):
    """Typer callback: a finite float within the interval."""
    return _callback(lambda what, v: check_number(what, v, lo, hi, lo_open=lo_open, hi_open=hi_open, unit=unit))


def count(lo: int, hi: int):
    """Typer callback: an int within ``[lo, hi]``."""
    return _callback(lambda what, v: check_count(what, v, lo, hi))


def seed(hi: int = MAX_SEED):
    """Typer callback: a seed within ``[0, hi]``."""
    return count(0, hi)


def one_of(values: Iterable):
    """Typer callback: one of ``values`` (numbers or text)."""
    values = tuple(values)

    def check(what, x):
        if x not in values:
            fail(what, x, "one of " + ", ".join(str(c) for c in values))
        return x

    return _callback(check)


def choice(values: Iterable[str]):
    """Typer callback: one of a few names, the expected form spelt ``a, b or c`` (``--truth 'x': expected torque-free or perturbed``)."""
    values = tuple(values)
    words = values[0] if len(values) == 1 else ", ".join(values[:-1]) + " or " + values[-1]

    def check(what, x):
        if x not in values:
            fail(what, x, words)
        return x

    return _callback(check)


def text(choices: Iterable[str] | None = None, max_len: int = MAX_TEXT):
    """Typer callback: printable text (one of ``choices`` if given)."""
    choices = None if choices is None else tuple(choices)
    return _callback(lambda what, v: check_text(what, v, choices=choices, max_len=max_len))


def out_dir():
    """Typer callback: an output folder in a writable place."""
    return _callback(check_out_dir)


def out_file(suffix: str):
    """Typer callback: an output file ``*<suffix>`` in a writable place."""
    return _callback(lambda what, v: check_out_file(what, v, suffix))


def in_file(suffixes: Iterable[str] | None = None, *, max_bytes: int = MAX_INPUT_BYTES):
    """Typer callback: an existing readable file (of one of ``suffixes``), bounded in size."""
    suffixes = None if suffixes is None else tuple(suffixes)
    return _callback(lambda what, v: check_in_file(what, v, suffixes, max_bytes=max_bytes))


def path_text():
    """Typer callback: a path without NUL bytes (existence is checked by the command)."""
    return _callback(check_path_text)
