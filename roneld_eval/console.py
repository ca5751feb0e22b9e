"""The `roneld-eval` command (and `python -m roneld_eval`). A signal while the command line's
modules are still being imported, its first 0.1-0.3 s, ends it with the one line any interruption
gives and 128 + n, not Python's traceback nor a silent death (the command's own handling starts
once they are imported); once the command is over, signals are ignored until the process has
exited (signals.ignored_to_the_end)."""

from __future__ import annotations

import sys


def main() -> None:
    from .signals import ignored_to_the_end, interruption_name, interruptions_unwrapped, terminate_as_interrupt

    try:
        # SIGTERM and SIGHUP as Ctrl-C from the start, not only once the command's handling starts.
        with terminate_as_interrupt(), interruptions_unwrapped():  # an extension's initialisation cut short
            from .cli import main as command

            try:
                command()
            finally:  # the command is over (it exits): a signal now could only kill the exit without a word
                ignored_to_the_end()
    except KeyboardInterrupt as error:  # while importing, or the moment between the command's end and this
        ignored_to_the_end()
        reason, code = interruption_name(error)
        sys.stderr.write(f"{reason}\n")
        sys.exit(code)
