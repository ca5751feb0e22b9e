"""The `roneld-eval` command (and `python -m roneld_eval`): Ctrl-C while the command line's modules
are still being imported, its first 0.1-0.3 s, ends it with the one line any interruption gives
and 130, not Python's traceback (the command's own handling starts once they are imported)."""

from __future__ import annotations

import sys


def main() -> None:
    try:
        from .cli import main as command
    except Exception as error:  # an extension module's initialisation cut by Ctrl-C: an error it caused
        from .signals import interruption_within

        if interruption_within(error) is None:
            raise
        _interrupted()
    except KeyboardInterrupt:
        _interrupted()
    command()


def _interrupted() -> None:
    sys.stderr.write("interrupted\n")
    sys.exit(130)
