"""The ``lcnav`` command line.

Each area registers its commands here; the libraries never print. Bad input
raises a specific exception inside; :func:`main` turns it into one line on
stderr and exit status 2, with no traceback.
"""

from __future__ import annotations

import contextlib
import sys
import warnings

import typer

app = typer.Typer(
    name="lcnav",
    help="Light curves -> spin priors -> relative navigation around tumbling targets.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _root() -> None:
    """lcnav: light curves -> spin priors -> relative navigation around tumbling targets."""

# Each command adds one line here: `from studies.cli import X; X.register(app)`.
from studies.cli import simulate; simulate.register(app)  # noqa: E402,E702
from studies.cli import study; study.register(app)  # noqa: E402,E702
from studies.cli import inspect; inspect.register(app)  # noqa: E402,E702
from studies.cli import lightcurve; lightcurve.register(app)  # noqa: E402,E702
from studies.cli import run; run.register(app)  # noqa: E402,E702
from studies.cli import combina; combina.register(app)  # noqa: E402,E702
from studies.cli import perception; perception.register(app)  # noqa: E402,E702
from studies.cli import demo; demo.register(app)  # noqa: E402,E702

from studies.engine.sweep import SweepError  # noqa: E402

#: Exceptions that mean "the user's input is wrong": one line, exit 2. (OSError covers an unwritable
#: or full output folder, a name too long, a permission denied.)
USER_ERRORS = (ValueError, KeyError, OSError)


def one_line(message) -> str:
    """``message`` on one line: line breaks folded, control characters escaped, at most 600 characters."""
    text = " ".join(str(message).split())
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    return text if len(text) <= 600 else text[:597] + "..."


def _message(e: BaseException) -> str:
    if isinstance(e, KeyError) and e.args:
        return f"missing key {e.args[0]!r}" if not isinstance(e.args[0], str) or " " not in e.args[0] else e.args[0]
    if isinstance(e, OSError) and e.strerror and e.filename is not None:
        return f"{e.filename}: {e.strerror}"
    return str(e) or type(e).__name__


@contextlib.contextmanager
def _one_line_warnings():
    """Print each warning of the run as one line ``lcnav: warning: ...`` on stderr."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"lcnav: warning: {one_line(message)}", file=sys.stderr)

    from lightcurves.io import DuplicateTimesWarning

    with warnings.catch_warnings():
        warnings.showwarning = show
        warnings.simplefilter("always", DuplicateTimesWarning)  # every command that merges rows says so, not only the first
        yield


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``lcnav`` console script.

    Exit 0 on success, 2 with one line ``lcnav: error: ...`` for bad input
    (including a busy or unwritable output folder), 130 on Ctrl-C. An
    unexpected exception (a bug) still gives one line, with a hint, and exit 1.
    """
    try:
        with _one_line_warnings():
            app(args=argv, standalone_mode=False)
    except typer.Exit as e:
        return e.exit_code
    except (typer.Abort, KeyboardInterrupt):
        print("lcnav: aborted", file=sys.stderr)
        return 130
    except typer.exceptions.TyperException as e:  # usage errors from the (vendored) click layer
        message = e.format_message() if hasattr(e, "format_message") else str(e)
        code = int(getattr(e, "exit_code", 2))
        if message:
            print(f"lcnav: error: {one_line(message)}", file=sys.stderr)
        return code
    except USER_ERRORS as e:
        print(f"lcnav: error: {one_line(_message(e))}", file=sys.stderr)
        return 2
    except SweepError as e:  # some runs failed (their errors named); the others are stored for a re-run
        print(f"lcnav: error: {one_line(e)}", file=sys.stderr)
        return 1
    except MemoryError:
        print("lcnav: error: out of memory; expected smaller sizes (fewer samples, runs or pixels)", file=sys.stderr)
        return 1
    except Exception as e:  # the safety net: a bug, not bad input
        print(f"lcnav: error: internal error {type(e).__name__}: {one_line(e)} (a bug in lcnav; please report it with the command line)",
              file=sys.stderr)
        return 1
    return 0

