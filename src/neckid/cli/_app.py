"""The command line's application object, its one error policy, and the helpers the commands share."""

from __future__ import annotations

import functools
import logging
import os
import signal
import sys
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from typing import Any, TypeVar

import typer
import typer.rich_utils as typer_rich_utils
from rich.console import Console, ConsoleDimensions
from rich.table import Table

from neckid._version import __version__
from neckid.utils.interrupt import signal_name, stop_signals

app = typer.Typer(
    name="neckid",
    help=(
        "Identify dynamic models of a tendon-driven soft robotic neck from input/output logs. "
        "Angles are in degrees, motor positions in rad and velocities in rad/s at the gearbox "
        "output, time in seconds, unless a log's own units say otherwise."
    ),
    no_args_is_help=True,
    add_completion=False,
    # Markdown joins the lines of a docstring paragraph, so help text reflows to the terminal.
    rich_markup_mode="markdown",
)


class _Stdout:
    """The current ``sys.stdout``; its reader going away ends the output, not the command.

    After ``neckid ... | head -1`` closes the pipe, what is left to print is dropped, files are
    still written and the exit status is that of the command (a ``BrokenPipeError`` would have
    made a saved model look like a failure).
    """

    closed = False

    def write(self, text: str) -> int:
        if not _Stdout.closed:
            try:
                return sys.stdout.write(text)
            except BrokenPipeError:
                self._reader_gone()
        return len(text)

    def flush(self) -> None:
        if not _Stdout.closed:
            try:
                sys.stdout.flush()
            except BrokenPipeError:
                self._reader_gone()

    @staticmethod
    def _reader_gone() -> None:
        _Stdout.closed = True
        # The interpreter's last flush at exit would fail again: point fd 1 at /dev/null (not
        # possible for a test runner's buffer, which has no file descriptor).
        with suppress(Exception):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
            os.close(devnull)

    def __getattr__(self, name: str) -> Any:
        return getattr(sys.stdout, name)


#: The width of standard output when it is not a terminal (a pipe, a file, a CI log) and
#: ``COLUMNS`` is not set: a pipe has no width, so a table is printed at its natural width and
#: no name or number in it is cut; a line of text is not wrapped.
PIPED_WIDTH = 10_000

#: The width of ``--help`` when standard output is not a terminal (and neither ``COLUMNS`` nor
#: typer's ``TERMINAL_WIDTH`` is set): wide enough that every option's example is whole
#: (tests/test_cli_output.py reads every command's help for a cut word).
PIPED_HELP_WIDTH = 120


def _is_terminal(stream: Any) -> bool:
    """Whether ``stream`` is a terminal (its ``isatty``; a closed or odd stream is not one)."""
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty is not None and isatty())
    except ValueError:  # closed
        return False


class _OutputConsole(Console):
    """Standard output's console: the terminal's width, or :data:`PIPED_WIDTH` when piped.

    Rich gives a console that is not a terminal 80 columns (or the width of whatever terminal
    the other standard streams reach), and a table wider than that cuts its cells with an
    ellipsis: test logs ``spring_20…`` and ``spring_10…`` could not be told apart. ``COLUMNS``,
    when set, still wins; the tables then wrap the names that identify their rows
    (``overflow="fold"``), never cut them.
    """

    @property
    def size(self) -> ConsoleDimensions:
        """The console's width and height (see the class)."""
        size = super().size
        if self._width is None and "COLUMNS" not in os.environ and not _is_terminal(self.file):
            return ConsoleDimensions(PIPED_WIDTH, size.height)
        return size

    @size.setter
    def size(self, new_size: tuple[int, int]) -> None:
        Console.size.fset(self, new_size)  # type: ignore[attr-defined]


console = _OutputConsole(file=_Stdout())  # type: ignore[arg-type]
error_console = Console(stderr=True)

_typer_help_console = typer_rich_utils._get_rich_console


def _help_console(stderr: bool = False) -> Console:
    """The console of ``--help`` (typer's), :data:`PIPED_HELP_WIDTH` wide when not a terminal."""
    shown = _typer_help_console(stderr)
    explicit = typer_rich_utils.MAX_WIDTH is not None or "COLUMNS" in os.environ
    if not explicit and not _is_terminal(shown.file):
        shown.width = PIPED_HELP_WIDTH
    return shown


typer_rich_utils._get_rich_console = _help_console


def _usage_error_line(error: Exception) -> None:
    """A usage error in one line: the command, what is wrong as click says it, the help.

    A missing argument, an unknown option, a value an option refuses (the argument and the
    value): typer's five-line box, replaced; the exit status stays 2.
    """
    from rich.markup import escape

    if type(error).__name__ == "NoArgsIsHelpError":
        return  # the help is printed instead
    context = getattr(error, "ctx", None)
    text = " ".join(str(getattr(error, "format_message", error.__str__)()).split())
    where = f"{context.command_path}: " if context is not None else ""
    hint = f" (see {context.command_path} --help)" if context is not None else ""
    error_console.print(
        f"[red]error:[/red] {escape(where + text + hint)}", highlight=False, soft_wrap=True
    )


typer_rich_utils.rich_format_error = _usage_error_line  # type: ignore[assignment]

#: Set by ``--debug``: unexpected errors show their traceback.
_STATE = {"debug": False}

Command = TypeVar("Command", bound=Callable[..., Any])

#: Errors that come from what the user gave (a file, a column, a value): one line, exit status 2.
_USER_ERRORS: tuple[type[BaseException], ...] = (
    ValueError,
    KeyError,
    TypeError,
    OSError,
)


def _version_callback(value: bool) -> None:
    if value:
        console.print(f"neckid {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: bool = typer.Option(
        False,
        "--version",
        callback=_version_callback,
        is_eager=True,
        help="Print the version and exit.",
    ),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log progress messages."),
    debug: bool = typer.Option(
        False, "--debug", help="Show the full traceback of an unexpected error."
    ),
) -> None:
    """Identify dynamic models of a tendon-driven soft robotic neck from input/output logs."""
    _STATE["debug"] = debug
    logging.basicConfig(
        level=logging.INFO if verbose else logging.WARNING, format="%(name)s: %(message)s"
    )


def _split(text: str | None) -> list[str] | None:
    if text is None:
        return None
    return [p.strip() for p in text.split(",") if p.strip()]


def _fail(message: str) -> None:
    from rich.markup import escape

    error_console.print(f"[red]error:[/red] {escape(message)}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=2)


def _message(exc: BaseException) -> str:
    from neckid.utils.files import disk_full_message

    if isinstance(exc, KeyError) and exc.args:
        return str(exc.args[0])
    full = disk_full_message(exc) if isinstance(exc, OSError) else None
    if full is not None:
        return full
    if isinstance(exc, OSError) and exc.strerror and exc.filename:
        return f"{exc.filename}: {exc.strerror}"
    return str(exc) or type(exc).__name__


def _fail_if_missing_extra(exc: ImportError) -> None:
    """A missing optional dependency (pyarrow, h5py, ...) is the environment: say what to install."""
    from neckid.utils.extras import missing_extra_message

    message = missing_extra_message(exc)
    if message is not None:
        _fail(message)


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: Any = None,
    line: str | None = None,
) -> None:
    """Print a library warning as one line (no file path): what the user can act on."""
    from rich.markup import escape

    text = str(message).splitlines()[0] if str(message) else category.__name__
    error_console.print(
        f"[yellow]warning:[/yellow] {escape(text)}", highlight=False, soft_wrap=True
    )


def handled(command: Command) -> Command:
    """Run a command with the one error policy of the command line.

    What the user gave wrong (:data:`_USER_ERRORS`) prints one ``error:`` line and exits with
    status 2; Ctrl-C, SIGTERM and SIGHUP stop the command at its next safe point
    (:mod:`neckid.utils.interrupt`: never inside a compiled kernel or its compilation, and a
    Ctrl-C that a library swallowed is raised again) and say so in one line, naming what was
    written before the stop (usually nothing: an output is put in place only once it is whole,
    and never after a stop signal), with status 128 + the signal: 130, 143, 129; anything else
    prints one line with the error's type and the hint to rerun with ``--debug`` (status 1), or
    the traceback with ``--debug``. A closed standard output (``| head``) is not an error. Long
    work inside shows its progress (:mod:`neckid.utils.progress`). The outputs the command
    claimed (:func:`neckid.utils.files.check_output_file`) are released when it ends.
    """

    @functools.wraps(command)
    def run(*args: Any, **kwargs: Any) -> Any:
        from rich.markup import escape

        from neckid.models.base import ExtrapolationWarning
        from neckid.utils.files import recording_outputs, release_outputs
        from neckid.utils.progress import default_reporter, reporting

        _Stdout.closed = False
        # The stop signals' handler covers the clean-up too: a second Ctrl-C does not cut it.
        with stop_signals(), recording_outputs() as written:
            try:
                # Long fits and selections report progress: a bar in a terminal, lines otherwise.
                with warnings.catch_warnings(), reporting(default_reporter()):
                    # The commands report extrapolation themselves; other warnings get one line
                    # each, once, without the library's file path.
                    warnings.simplefilter("ignore", ExtrapolationWarning)
                    warnings.showwarning = _show_warning
                    return command(*args, **kwargs)
            except (typer.Exit, typer.Abort):
                raise
            except KeyboardInterrupt as exc:
                signum = getattr(exc, "signum", int(signal.SIGINT))
                what = (
                    "written whole before the stop: "
                    + ", ".join(escape(w) for w in written)
                    + "; nothing else was written"
                    if written
                    else "no output was written and an existing one is unchanged"
                )
                error_console.print(
                    f"[yellow]interrupted[/yellow] ({signal_name(signum)}): stopped before the"
                    f" end; {what}",
                    highlight=False,
                    soft_wrap=True,
                )
                raise typer.Exit(code=128 + signum) from None
            except BrokenPipeError:
                _Stdout._reader_gone()  # the reader of the output went away: nothing more to say
                raise typer.Exit(code=128 + int(getattr(signal, "SIGPIPE", 13))) from None
            except _USER_ERRORS as exc:
                _fail(_message(exc))
            except Exception as exc:
                if isinstance(exc, ImportError):
                    _fail_if_missing_extra(exc)
                if _STATE["debug"]:
                    raise
                error_console.print(
                    f"[red]unexpected error[/red] ({type(exc).__name__}): {escape(_message(exc))};"
                    " rerun with `neckid --debug ...` for the traceback and report it",
                    highlight=False,
                    soft_wrap=True,
                )
                raise typer.Exit(code=1) from None
            finally:
                release_outputs()

    return run  # type: ignore[return-value]


FORCE_HELP = "Overwrite an existing output."


def _model_channels(model: Any) -> tuple[list[str], list[str]]:
    """The channels to read from a log for ``model``: its inputs but its conditions, its outputs."""
    conditions = set(model._condition_names())
    return [n for n in model.input_names_ if n not in conditions], list(model.output_names_)


def _method_name(name: str) -> str:
    """The registry name of a method; an old spelling prints a deprecation line and maps over."""
    from neckid.registry import DEPRECATED_NAMES, get_method

    if name in DEPRECATED_NAMES:
        console.print(
            f"[yellow]deprecated:[/yellow] method name {name!r} will be removed in the next"
            f" release; use {DEPRECATED_NAMES[name]!r}"
        )
        return DEPRECATED_NAMES[name]
    return get_method(name).name


def _metrics_table(title: str, rows: list[dict[str, Any]]) -> Table:
    from rich.markup import escape

    # Headers such as "RMSE [deg]" are text, not rich markup. The columns of names (method,
    # log, output) tell the rows apart: left-aligned, and wrapped rather than cut when the
    # console is narrower than the table (numbers too: a cut number reads as another one).
    table = Table(title=escape(title))
    for key in rows[0]:
        names = not any(isinstance(row.get(key), int | float) for row in rows)
        table.add_column(escape(key), justify="left" if names else "right", overflow="fold")
    for row in rows:
        table.add_row(
            *(f"{v:.3f}" if isinstance(v, float) else escape(str(v)) for v in row.values())
        )
    return table


LOG_HELP = (
    "Log: CSV with a header row (or .parquet / .mat), a headerless soft-neck log with --layout"
    " softneck, or a ROS 2 bag with --layout rosbag."
)
INPUTS_HELP = "Comma-separated input channel names (e.g. velocity_command)."
OUTPUTS_HELP = "Comma-separated output channel names (e.g. inclination, in degrees)."
TIME_HELP = "Name of the time column (seconds). Ignored when --ts is given."
TS_HELP = "Sampling period in seconds, for a log without a time column."
SEP_HELP = "Column separator of a CSV log, e.g. ';' or '\\t' (tab)."
LAYOUT_HELP = (
    "'csv' (a header row names the columns) or 'softneck' (the UC3M bench's headerless logs;"
    " 3 columns: time, inclination_filtered, motor_position; 6 columns add inclination,"
    " velocity_command, motor_velocity; 7 columns add control_filtered) or 'rosbag' (a ROS 2"
    " bag folder or file, with --channel)."
)
CHANNEL_HELP = (
    "With --layout rosbag: NAME=TOPIC:FIELD:KIND[:UNIT] for each channel of the bag, e.g."
    " inclination=/imu/tilt:vector.x:output:deg (repeat the option)."
)
MAP_HELP = (
    "MODEL_CHANNEL=LOG_CHANNEL: read a model channel from a log column of another name, e.g."
    " inclination=inclination_filtered (repeat the option for several). The log's conditions"
    " (file name, sidecar, --condition) are kept."
)


CONDITION_HELP = (
    "NAME=VALUE: a condition of the experiment, a number with an optional unit or a label, e.g."
    " payload=0.4kg or controller=ada (repeat the option). Overrides the log's sidecar"
    " <stem>.conditions.json and what a soft-neck file name says."
)


def _sep(text: str) -> str:
    """The separator the user typed; a backslash and a t (as a shell passes it) means a tab."""
    return "\t" if text == "\\t" else text


# Options shared by the commands that read a log (one definition, reused as defaults).
TIME_OPTION = typer.Option("time", "--time", help=TIME_HELP)


def _check_ts_option(value: float | None) -> float | None:
    """``--ts``: a positive finite number of seconds, at most 1e6 (refused by the option)."""
    if value is None:
        return None
    from neckid.utils.checks import check_ts

    try:
        return check_ts(value)
    except (TypeError, ValueError) as exc:
        raise typer.BadParameter(str(exc)) from None


TS_OPTION = typer.Option(None, "--ts", help=TS_HELP, callback=_check_ts_option)
LAYOUT_OPTION = typer.Option("csv", "--layout", help=LAYOUT_HELP)
SEP_OPTION = typer.Option(",", "--sep", help=SEP_HELP)
CHANNEL_OPTION = typer.Option(None, "--channel", help=CHANNEL_HELP)
MAP_OPTION = typer.Option(None, "--map", help=MAP_HELP)
FORCE_OPTION = typer.Option(False, "--force", help=FORCE_HELP)
CONDITION_OPTION = typer.Option(None, "--condition", help=CONDITION_HELP)
TILT_OPTION = typer.Option(
    False,
    "--tilt",
    help="3-D neck: read the inclination and orientation outputs [deg] and use the wrap-free"
    " tilt vector tilt_x, tilt_y [deg] in their place (with --map, the model's names: e.g."
    " --map inclination=inclination_sensor).",
)

# Preprocessing steps of identify: stored in the model, applied again to every new log by
# validate, simulate and info --model (neckid.data.preprocess; channel names after --map).
RELATIVE_OPTION = typer.Option(
    None,
    "--relative",
    metavar="CHANNEL",
    help="Use the channel minus its value at the log's first sample, e.g. --relative"
    " motor_position (the motor displacement); repeat for several. Stored in the model.",
)
OFFSET_OPTION = typer.Option(
    None,
    "--offset",
    metavar="CHANNEL:START:STOP",
    help="Subtract the channel's mean over a rest window [s from the first sample], e.g."
    " inclination:0:2 (repeat the option). Stored in the model.",
)
LOWPASS_OPTION = typer.Option(
    None,
    "--lowpass",
    metavar="CHANNEL:CUTOFF",
    help="First-order low-pass (Tustin) of the channel at CUTOFF rad/s, started at rest, e.g."
    " inclination:1 (the bench's filtered inclination); repeat the option. Stored in the model.",
)
RESAMPLE_OPTION = typer.Option(
    None,
    "--resample",
    metavar="TS",
    help="Resample every channel to TS seconds (linear interpolation), after the other steps."
    " Stored in the model.",
)
RESTAMP_OPTION = typer.Option(
    False,
    "--restamp",
    help="Repeated time stamps: keep the first row of each instead of refusing the log."
    " Stored in the model.",
)


SCHEDULER_HELP = (
    "Address of a Dask scheduler, e.g. tcp://10.0.0.5:8786: the candidates' fits run on its"
    " workers (needs pip install neckid[dask]); the results are those of a local run."
)
SCHEDULER_OPTION = typer.Option(None, "--scheduler", help=SCHEDULER_HELP, show_default=False)


@contextmanager
def _on_scheduler(address: str | None) -> Iterator[None]:
    """Run the sweeps inside on the Dask cluster at ``address``; nothing changes for None.

    Connects a ``distributed.Client(address)`` (the connect timeout is Dask's own setting,
    ``distributed.comm.timeouts.connect``, 30 s by default) and sets
    ``joblib.parallel_config(backend="dask")``, so that every joblib sweep inside runs on the
    cluster's workers. A missing extra or an unreachable scheduler is one ``error:`` line.
    """
    if address is None:
        yield
        return
    from joblib import parallel_config

    from neckid.utils.parallel import DASK_INSTALL_HINT

    try:
        from distributed import Client
    except ImportError:
        _fail(
            f"--scheduler needs the distributed package, which is not installed: {DASK_INSTALL_HINT}"
        )
    try:
        client = Client(address)
    except (OSError, ValueError, TimeoutError) as exc:
        _fail(f"--scheduler: cannot connect to the Dask scheduler at {address!r}: {_message(exc)}")
    logging.getLogger(__name__).info("sweeps run on the Dask scheduler at %s", address)
    with client, parallel_config(backend="dask"):
        yield
