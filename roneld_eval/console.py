"""The `roneld-eval` command (and `python -m roneld_eval`): Ctrl-C while the command line's modules
are still being imported, its first 0.1-0.3 s, ends it with the one line any interruption gives
and 130, not Python's traceback (the command's own handling starts once they are imported)."""

from __future__ import annotations

import sys


def main() -> None:
    from .signals import interruption_name, interruptions_unwrapped

    try:
        with interruptions_unwrapped():  # an extension module's initialisation cut by Ctrl-C
            from .cli import main as command
    except KeyboardInterrupt as error:
        reason, code = interruption_name(error)
        sys.stderr.write(f"{reason}\n")
        sys.exit(code)
    command()
