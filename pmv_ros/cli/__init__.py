"""The ``pmv`` command line: one console script, one module per subcommand.

Each subcommand module defines ``add_parser(subparsers)``, which registers its
parser with ``func=run``; ``run(args) -> int`` returns the exit status. A
``ValueError`` raised for a bad value becomes a one-line error and exit 2.
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
    parser = OneLineParser(prog="pmv", description="PMV infrared horizon sensor emulator: tools for people and scripts.")
    subparsers = parser.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    for name in SUBCOMMANDS:
        importlib.import_module(f"{__name__}.{name}").add_parser(subparsers)
    return parser


#: Exit status of a command whose output pipe was closed by its reader (128 + SIGPIPE, as a shell reports it).
EXIT_CLOSED_PIPE = 141


def main(argv=None) -> int:
    """Entry point of the ``pmv`` console script.

    A reader that closes the output early (``pmv … --json | head``) ends the
    command quietly with status 141, as a killed-by-SIGPIPE program would.
    """
    try:
        args = build_parser().parse_args(argv)
        try:
            status = args.func(args)
        except ValueError as error:
            status = fail(f"pmv {args.command}", str(error))
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
