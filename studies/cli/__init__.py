"""The ``lcnav`` command line.

Each area's module registers its commands (:data:`COMMANDS`); a module is
imported only when its command runs, so ``lcnav --help`` answers without the
numerical stack. The libraries never print. Bad input raises a specific
exception inside; :func:`main` turns it into one line
``lcnav: error: <value or file>: expected <form>`` on stderr and exit status 2,
with no traceback (exit statuses: see :func:`main`).
"""

from __future__ import annotations

import contextlib
import importlib
import re
import sys
import warnings

import typer
from typer import _click

from studies.engine import interrupt

#: The commands: name -> (module whose ``register(app)`` adds it, the one-line summary ``lcnav --help`` lists).
#: A module is imported only when its command runs (or its own --help is asked for), so ``lcnav --help``, ``--version``
#: and a misspelt command answer without importing pandas, rerun, numba, Mitsuba or the studies. Each summary is the
#: first line of the command's docstring (tests/studies/test_interrupts_and_faults.py checks that they agree).
COMMANDS = {
    "simulate": ("studies.cli.simulate", "Integrate servicer and target of a scenario; write truth.parquet and truth.rrd."),
    "study": ("studies.cli.study", "Run a study: sweep its runs (resumable), write runs.parquet, summary.parquet/.csv/.md."),
    "inspect": ("studies.cli.inspect", "List what a recording holds (entities, time range, counts) and the run's metrics; optionally export series."),
    "run": ("studies.cli.run", "Run a filter on a scenario; write metrics.json, states.parquet and run.rrd."),
    "combina": ("studies.cli.combina", "CoMBiNa relative navigation (Maestrini et al. §VI): writes metrics.json, states.parquet, combina.rrd."),
    "demo": ("studies.cli.demo", "The main job: light curve -> spin prior -> EKF/UKF on SC3 with and without it; tables, figures, recordings."),
    "lightcurve": ("studies.cli.lightcurve", "Synthetic light curves and spin priors."),
    "perception": ("studies.cli.perception", "Stereo frames, point clouds and BCPD pose measurements."),
}


#: The options of the command being run, once parsed (for the seed in an internal error's line).
_params: dict = {}


def _plain_flags(params: list) -> list:
    """``params`` with every flag shown as a flag: typer's rich help would print ``--quick <bool>``, as if it took a value."""
    for p in params:
        if getattr(p, "is_flag", False):
            p.metavar = ""
    return params


def _remembering(cmd: _click.Command) -> _click.Command:
    """``cmd`` (and its subcommands) with callbacks that record their parsed options in :data:`_params`, flags shown plainly."""
    for sub in getattr(cmd, "commands", {}).values():
        _remembering(sub)
    get_params = cmd.get_params
    cmd.get_params = lambda ctx: _plain_flags(get_params(ctx))
    callback = cmd.callback
    if callback is not None:
        def remember(*args, **kwargs):
            _params.update(kwargs)
            return callback(*args, **kwargs)
        cmd.callback = remember
    return cmd


def load_command(name: str) -> _click.Command:
    """The click command ``name`` of :data:`COMMANDS`, built by importing its module."""
    holder = typer.Typer()
    holder.callback()(lambda: None)  # a callback makes it a group even with one command
    importlib.import_module(COMMANDS[name][0]).register(holder)
    return _remembering(typer.main.get_command(holder).commands[name])


class LazyGroup(typer.core.TyperGroup):
    """The root group: commands listed from :data:`COMMANDS`, each imported on first use."""

    _listing = False

    def list_commands(self, ctx) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx, cmd_name: str):
        if cmd_name not in COMMANDS:
            return None
        if self._listing and cmd_name not in self.commands:  # the help listing needs the name and summary only
            return typer.core.TyperCommand(cmd_name, help=COMMANDS[cmd_name][1])
        if cmd_name not in self.commands:
            self.commands[cmd_name] = load_command(cmd_name)
        return self.commands[cmd_name]

    def resolve_command(self, ctx, args):
        if args and args[0] not in COMMANDS and not args[0].startswith("-"):
            raise _click.exceptions.UsageError(f"{args[0]!r}: expected a command: {', '.join(COMMANDS)}", ctx)
        return super().resolve_command(ctx, args)

    def get_params(self, ctx) -> list:
        return _plain_flags(super().get_params(ctx))

    def format_help(self, ctx, formatter) -> None:
        self._listing = True
        try:
            super().format_help(ctx, formatter)
        finally:
            self._listing = False


app = typer.Typer(
    name="lcnav",
    cls=LazyGroup,
    help="Light curves -> spin priors -> relative navigation around tumbling targets.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def version() -> str:
    """lcnav's installed version (``unknown`` when run from a source tree that is not installed)."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as package_version

    try:
        return package_version("lcnav")
    except PackageNotFoundError:
        return "unknown"


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"lcnav {version()}")
        raise typer.Exit(0)


@app.callback()
def _root(
    show_version: bool = typer.Option(False, "--version", help="Print lcnav's version and exit.", is_eager=True, callback=_print_version),
) -> None:
    """lcnav: light curves -> spin priors -> relative navigation around tumbling targets."""


#: Exceptions that mean "the user's input is wrong": one line, exit 2. (OSError covers an unwritable
#: or full output folder, a name too long, a permission denied.) numpy's LinAlgError is a ValueError but
#: a numerical failure, not bad input: see :func:`_is_numerical`.
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

    with warnings.catch_warnings():
        warnings.showwarning = show
        # lcnav's own warnings (e.g. lightcurves.io.DuplicateTimesWarning: rows merged) each time, not once per process;
        # matched by module, not by class, so that no command pays for importing the class's module
        warnings.filterwarnings("always", category=UserWarning, module=r"(lightcurves|studies|estimators|perception)(\.|$)")
        yield


def _usage_message(e) -> str:
    """A usage error of the click layer in the form ``<value>: expected <form>``."""
    names, ctx = [], getattr(e, "ctx", None)
    while ctx is not None and ctx.parent is not None:  # the root's name is the program's (python -m studies.cli): say lcnav
        names.insert(0, ctx.info_name)
        ctx = ctx.parent
    where = f"`{' '.join(['lcnav', *names, '--help'])}`"
    if isinstance(e, _click.exceptions.NoSuchOption):
        maybe = f" (did you mean {' or '.join(sorted(e.possibilities))}?)" if e.possibilities else ""
        return f"{e.option_name}: expected one of the options listed by {where}{maybe}"
    if isinstance(e, _click.exceptions.MissingParameter):
        hint = e.param.get_error_hint().strip("'") if e.param is not None else "a parameter"
        return f"{hint}: missing: expected it given ({getattr(e.param, 'help', None) or 'see ' + where})"
    if isinstance(e, _click.exceptions.BadOptionUsage):
        return f"{e.option_name}: no value: expected {e.option_name} VALUE (see {where})"
    message = e.format_message() if hasattr(e, "format_message") else str(e)
    unknown = re.match(r"No such command '(.*)'\.\s*(.*)$", message)
    if unknown:
        return f"{unknown[1]!r}: expected a command listed by {where}{f' ({unknown[2]})' if unknown[2] else ''}"
    return message if ": expected" in message else f"{message.rstrip('.')}: expected the usage of {where}"


def _is_numerical(e: BaseException) -> bool:
    """numpy's LinAlgError (a ValueError): a numerical failure inside lcnav, not bad input (the other arithmetic errors are no ValueErrors)."""
    np = sys.modules.get("numpy")  # not imported: the error cannot be numpy's
    return np is not None and isinstance(e, np.linalg.LinAlgError)


def _error(text: str) -> None:
    """Print ``lcnav: error: TEXT``, unless Ctrl-C came first: then the error is its echo (a KeyboardInterrupt that a C
    extension turned into a SystemError, a failed Dask run) and :func:`main` says ``lcnav: aborted`` instead."""
    if not interrupt.interrupted():
        print(f"lcnav: error: {text}", file=sys.stderr)


def _internal(e: BaseException) -> int:
    seed = _params.get("seed")  # the command's --seed (given or default); None for a command without one
    _error(f"internal error {type(e).__name__}: {one_line(e)}{'' if seed is None else f' (seed {seed})'} "
           "(a bug in lcnav; please report it with the command line)")
    return 1


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``lcnav`` console script.

    Exit status: 0 on success; 2 with one line ``lcnav: error: <value or file>: expected <form>`` for bad
    input, a busy or unwritable output folder, or a full disk (nothing is written); 1 when some runs of a study
    failed (named) or, with "internal error" and the run's seed, for a bug or a numerical failure; 130 with
    one line ``lcnav: aborted`` on Ctrl-C (SIGINT), nothing left that looks finished. Called without ``argv``
    (the console script), an interrupted command ends the process at once (:func:`studies.engine.interrupt.exit_now`).
    """
    args = sys.argv[1:] if argv is None else [str(a) for a in argv]
    _params.clear()
    with interrupt.handling():
        try:
            code = _dispatch(args)
        except KeyboardInterrupt:
            code = interrupt.EXIT_ABORTED
        if interrupt.interrupted():  # also when a library swallowed the KeyboardInterrupt on the way out
            if argv is None:  # this process is the lcnav command itself (not a caller in Python): end it here
                interrupt.exit_now()
            return interrupt.report()
    return code


def _dispatch(args: list[str]) -> int:
    try:
        with _one_line_warnings():
            if app(args=args, standalone_mode=False) == interrupt.EXIT_ABORTED:  # typer's answer to a KeyboardInterrupt
                raise KeyboardInterrupt
    except typer.Exit as e:
        return e.exit_code
    except typer.Abort:
        raise KeyboardInterrupt from None
    except typer.exceptions.TyperException as e:  # usage errors from the (vendored) click layer
        code = int(getattr(e, "exit_code", 2))
        if e.format_message() if hasattr(e, "format_message") else str(e):
            _error(one_line(_usage_message(e)))
        return code
    except USER_ERRORS as e:
        if _is_numerical(e):
            return _internal(e)
        _error(one_line(_message(e)))
        return 2
    except MemoryError:
        _error("out of memory: expected smaller sizes (fewer samples, runs or pixels)")
        return 1
    except Exception as e:  # a study's failed runs (SweepError, named), or the safety net: a bug, not bad input
        if type(e).__name__ == "SweepError":  # some runs failed (their errors named); the others are stored for a re-run
            _error(one_line(e))
            return 1
        return _internal(e)
    return 0
