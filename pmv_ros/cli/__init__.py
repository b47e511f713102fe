"""The ``pmv`` command line: one console script, one module per subcommand.

Each subcommand module defines ``add_parser(subparsers)``, which registers its
parser with ``func=run``; ``run(args) -> int`` returns the exit status. A
``ValueError`` raised for a bad value becomes a one-line error and exit 2.
"""

from __future__ import annotations

import importlib
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


def main(argv=None) -> int:
    """Entry point of the ``pmv`` console script."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ValueError as error:
        return fail(f"pmv {args.command}", str(error))


if __name__ == "__main__":
    sys.exit(main())
