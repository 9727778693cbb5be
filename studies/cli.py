"""The ``lcnav`` command line.

Each area registers its commands here; the libraries never print. Bad input
raises a specific exception inside; :func:`main` turns it into one line on
stderr and exit status 2, with no traceback.
"""

from __future__ import annotations

import sys

import click
import typer

app = typer.Typer(
    name="lcnav",
    help="Light curves -> spin priors -> relative navigation around tumbling targets.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

# Each area adds one line here: `from studies import X; X.register(app)`.
from studies import lightcurve_cmd; lightcurve_cmd.register(app)  # noqa: E402, E702
from studies import perception_cmd; perception_cmd.register(app)  # noqa: E402, E702

#: Exceptions that mean "the user's input is wrong": one line, exit 2.
USER_ERRORS = (ValueError, KeyError, FileNotFoundError, FileExistsError, NotADirectoryError, IsADirectoryError)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``lcnav`` console script."""
    try:
        app(args=argv, standalone_mode=False)
    except click.exceptions.Exit as e:
        return e.exit_code
    except click.exceptions.Abort:
        print("lcnav: aborted", file=sys.stderr)
        return 130
    except click.ClickException as e:
        print(f"lcnav: {e.format_message()}", file=sys.stderr)
        return e.exit_code
    except USER_ERRORS as e:
        msg = e.args[0] if isinstance(e, KeyError) and e.args else e
        print(f"lcnav: error: {msg}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
