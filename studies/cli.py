"""The ``lcnav`` command line.

Each area registers its commands here; the libraries never print. Bad input
raises a specific exception inside; :func:`main` turns it into one line on
stderr and exit status 2, with no traceback.
"""

from __future__ import annotations

import sys

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

# Each area adds one line here: `from studies import X; X.register(app)`.
from studies import simulate_cmd; simulate_cmd.register(app)  # noqa: E402,E702
from studies import study_cmd; study_cmd.register(app)  # noqa: E402,E702
from studies import inspect_cmd; inspect_cmd.register(app)  # noqa: E402,E702
from studies import lightcurve_cmd; lightcurve_cmd.register(app)  # noqa: E402, E702
from studies import run_cmd; run_cmd.register(app)  # noqa: E402,E702
from studies import combina_cmd; combina_cmd.register(app)  # noqa: E402,E702
from studies import perception_cmd; perception_cmd.register(app)  # noqa: E402, E702
from studies import demo; demo.register(app)  # noqa: E402,E702

#: Exceptions that mean "the user's input is wrong": one line, exit 2.
USER_ERRORS = (ValueError, KeyError, FileNotFoundError, FileExistsError, NotADirectoryError, IsADirectoryError)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``lcnav`` console script."""
    try:
        app(args=argv, standalone_mode=False)
    except typer.Exit as e:
        return e.exit_code
    except typer.Abort:
        print("lcnav: aborted", file=sys.stderr)
        return 130
    except typer.exceptions.TyperException as e:  # usage errors from the (vendored) click layer
        message = e.format_message() if hasattr(e, "format_message") else str(e)
        if message:
            print(f"lcnav: {message}", file=sys.stderr)
        return int(getattr(e, "exit_code", 2))
    except USER_ERRORS as e:
        msg = e.args[0] if isinstance(e, KeyError) and e.args else e
        print(f"lcnav: error: {msg}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
