"""Signal a command at random moments of its last second, many times, and count what went wrong.

    python scripts/signal_loop.py --tries 500 --out /tmp/loop/out -- \
        roneld-eval score openlane --labels set/labels --pred-root set/predictions

The command is run once to learn its usual duration (the median of three runs after a first),
then TRIES times, each sent SIGINT, SIGTERM and SIGHUP in turn at a moment drawn uniformly from
its last --window seconds (and 50 ms past its end; keep --window below the usual duration less
some 0.1 s: a signal before Python runs the tool's code ends any program unhandled). Every try
must end cleanly: finished (exit 0, nothing on stderr but what a finished run says), or one line
on stderr besides the notes a finished run prints too, and exit 128 + n; never killed by a signal
(no line: SIGSEGV, SIGABRT, or the signal itself), never a traceback, and nothing left in OUT but
the complete results (the old ones or the new: the same files, byte for byte, as the command
writes them every time): no lock, staging, trash or journal (`run`'s resume cache, kept on
purpose when it is interrupted, aside).
--tty gives the command a terminal for stderr (its progress bar, and tqdm's monitor thread);
--group sends the signal to the process group, as Ctrl-C in a terminal does.
Prints each bad try as it happens and a tally at the end; exit status 1 if any try was bad.
"""

from __future__ import annotations

import argparse
import collections
import os
import random
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
LEFTOVERS = (".roneld-lock", ".staging-", ".trash-", ".roneld-commit")
KEPT_ON_PURPOSE = ".roneld-cache"  # run's finished clips, for --resume


def snapshot(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*"))
            if p.is_file() and not str(p.relative_to(out)).startswith(KEPT_ON_PURPOSE)} if out.is_dir() else {}


def start(command: list[str], tty: bool) -> tuple[subprocess.Popen, list[bytes], threading.Thread | None]:
    """The command, its stderr collected into a list (read from a terminal with --tty)."""
    env = {**os.environ, "PYTHONFAULTHANDLER": "1"}  # a crash says where
    if not tty:
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                                   start_new_session=True)
        return process, [], None
    leader, follower = os.openpty()
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=follower, env=env, start_new_session=True)
    os.close(follower)
    chunks: list[bytes] = []

    def read() -> None:
        while True:
            try:
                data = os.read(leader, 65536)
            except OSError:
                break
            if not data:
                break
            chunks.append(data)
        os.close(leader)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    return process, chunks, reader


def run(command: list[str], tty: bool, group: bool, delay: float | None = None,
        number: int = 0) -> tuple[int, str, float]:
    """(exit status, stderr, seconds) of one run, signalled `delay` s after its start."""
    began = time.monotonic()
    process, chunks, reader = start(command, tty)
    if delay is not None:
        time.sleep(max(0.0, delay - (time.monotonic() - began)))
        try:
            (os.killpg if group else os.kill)(process.pid, number)
        except ProcessLookupError:
            pass
    _, errors = process.communicate(timeout=300)
    if reader is not None:
        reader.join(10)
        errors = b"".join(chunks)
    return process.returncode, errors.decode("utf-8", "replace"), time.monotonic() - began


def said_lines(errors: str) -> list[str]:
    """What stderr says, a progress bar's redraws left out (each ends at a carriage return)."""
    lines = []
    for line in errors.replace("\r\n", "\n").split("\n"):
        last = line.split("\r")[-1].strip()
        if last and not last.startswith(("scoring:", "generating:", "evaluating:", "shards:")):
            lines.append(last)
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tries", type=int, default=500)
    parser.add_argument("--out", type=Path, required=True, help="the command's --out (appended to it)")
    parser.add_argument("--window", type=float, default=1.0, help="seconds before the usual end")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--tty", action="store_true")
    parser.add_argument("--group", action="store_true")
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = (args.command[1:] if args.command[:1] == ["--"] else list(args.command)) + ["--out", str(args.out)]
    shutil.rmtree(args.out, ignore_errors=True)
    code, errors, _ = run(command, args.tty, args.group)
    if code != 0:
        sys.exit(f"the command fails unsignalled ({code}): {errors[-500:]}")
    complete, finished_says = snapshot(args.out), said_lines(errors)
    usual = sorted(run(command, args.tty, args.group)[2] for _ in range(3))[1]
    print(f"usual duration {usual:.2f} s; {args.tries} tries in its last {args.window:g} s", flush=True)
    rng = random.Random(args.seed)
    tally: collections.Counter[str] = collections.Counter()
    for attempt in range(args.tries):
        number = SIGNALS[attempt % len(SIGNALS)]
        delay = rng.uniform(max(0.0, usual - args.window), usual + 0.05)
        code, errors, _ = run(command, args.tty, args.group, delay, number)
        lines = said_lines(errors)
        left = sorted(p.name for p in args.out.iterdir() if p.name.startswith(LEFTOVERS)) if args.out.is_dir() else []
        state = snapshot(args.out)
        problems = []
        if code < 0:
            problems.append(f"killed by {signal.Signals(-code).name}")
        elif code == 0:
            if lines != finished_says:
                problems.append("finished, but said more")
        elif code != 128 + number or len([line for line in lines if line not in finished_says]) != 1:
            problems.append(f"exit {code} with {len(lines)} lines")
        if "Traceback" in errors or "Fatal Python error" in errors:
            problems.append("a traceback")
        if left:
            problems.append(f"left {left}")
        if {k: v for k, v in state.items() if not k.startswith(LEFTOVERS)} != complete:
            problems.append("results not complete")
        outcome = "finished" if code == 0 else "one line" if code > 0 else "killed"
        tally[f"{outcome}{' BAD' if problems else ''}"] += 1
        if problems:
            print(f"try {attempt}: {signal.Signals(number).name} at {delay:.3f} s: {', '.join(problems)}\n"
                  f"  stderr: {errors[-4000:]!r}", flush=True)
            shutil.rmtree(args.out, ignore_errors=True)
            run(command, args.tty, args.group)  # the complete results again, for the next try
    print(dict(tally), flush=True)
    return 1 if any(key.endswith("BAD") for key in tally) else 0


if __name__ == "__main__":
    sys.exit(main())
