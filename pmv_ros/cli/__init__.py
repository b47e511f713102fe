"""The ``pmv`` command line: one console script, one module per subcommand.

Each subcommand module defines ``add_parser(subparsers)``, which registers its
parser with ``func=run``; ``run(args) -> int`` returns the exit status.

What a command can expect to meet ends it with one line on stderr and exit
status 2 (:func:`one_line_failure`): a refused input or setting
(``ValueError``, which includes undecodable text and every reader's own
refusal), what the system refused (``OSError``: a file, a disk, a network
peer, a timeout), and a bound that did not hold (``MemoryError``,
``RecursionError``: the line says so and asks for a report). Anything else —
``TypeError``, ``KeyError``, ``AttributeError``, … — is a bug of ours: its
traceback is kept (status 1), so it is reported, never hidden behind a line.
A library's own exception for bad input is turned into a ``ValueError``
where that input is read, not here.
"""

from __future__ import annotations

import importlib
import os
import sys

from .common import OneLineParser, fail

#: Subcommand modules of this package, in the order ``pmv --help`` lists them.
SUBCOMMANDS = ("oblateness", "scenario", "analyze", "simulate", "campaign")


def build_parser() -> OneLineParser:
    """The ``pmv`` argument parser with every subcommand registered."""
    parser = OneLineParser(prog="pmv",
                           description="PMV infrared horizon sensor emulator: tools for people and scripts.")
    subparsers = parser.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    for name in SUBCOMMANDS:
        importlib.import_module(f"{__name__}.{name}").add_parser(subparsers)
    return parser


#: Exit status of a command whose output pipe was closed by its reader (128 + SIGPIPE, as a shell reports it).
EXIT_CLOSED_PIPE = 141


#: The failures a command expects and reports in one line (status 2); see the module docstring.
EXPECTED_FAILURES = (ValueError, OSError, MemoryError, RecursionError)

#: Exit status of a command stopped by Ctrl-C (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130


def one_line_failure(error: BaseException) -> str:
    """The one line that reports an expected failure (one of :data:`EXPECTED_FAILURES`)."""
    if isinstance(error, MemoryError):
        return ("out of memory: a bound of this command did not hold (please report the command line and the "
                "input's size)")
    if isinstance(error, RecursionError):
        return ("the input is nested too deeply for this process: a bound of this command did not hold (please "
                "report the command line)")
    if isinstance(error, OSError) and not isinstance(error, ValueError):
        reason = error.strerror or " ".join(str(error).split()) or type(error).__name__
        named = [name for name in (error.filename, error.filename2) if name is not None]
        return f"{' -> '.join(map(os.fsdecode, named))}: {reason}" if named else reason
    text = " ".join(str(error).split()) or type(error).__name__
    return text if len(text) <= MAX_LINE_CHARS else text[:MAX_LINE_CHARS - 1] + "…"


#: Longest error line printed, characters (a library's message can quote a whole input).
MAX_LINE_CHARS = 1000


def main(argv=None) -> int:
    """Entry point of the ``pmv`` console script.

    An expected failure is one line and status 2; Ctrl-C is one line and
    130. A reader that closes the output early (``pmv … --json | head``)
    ends the command quietly with status 141, as a killed-by-SIGPIPE program
    would.
    """
    try:
        args = build_parser().parse_args(argv)
        try:
            status = args.func(args)
        except BrokenPipeError:
            raise
        except EXPECTED_FAILURES as error:
            status = fail(f"pmv {args.command}", one_line_failure(error))
        except KeyboardInterrupt:
            print(f"pmv {args.command}: interrupted", file=sys.stderr)
            status = EXIT_INTERRUPTED
        if sys.stdout is not None:  # None: started with stdout closed (print writes nowhere)
            sys.stdout.flush()
        return status
    except BrokenPipeError:
        return _closed_pipe()


def _closed_pipe() -> int:
    """Point stdout at /dev/null (the interpreter's own flush at exit must not fail again); return 141."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass
    return EXIT_CLOSED_PIPE


if __name__ == "__main__":
    sys.exit(main())
