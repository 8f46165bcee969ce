#!/usr/bin/env python3
"""A/B timing of two builds on a machine whose speed drifts (the shared CI-sized guest: the same
binary's report varied from 29 to 42 s within an hour). Runs command A and command B in
alternation, ROUNDS times each, so that both see the same minutes of the host, and prints per
command the median and the best wall time, the median CPU time (user + system of the child)
and the largest peak resident memory of a run (never below the ~15 MiB of this script, which
the forked child starts from), then B's medians relative to A's.

    python3 benches/ab.py [--rounds N] [--setup CMD] -- A_COMMAND ... -- B_COMMAND ...

Each command is run through the shell; `{round}` in it is replaced by the round number (for
output directories). `--setup CMD` runs before every run (e.g. `rm -rf /tmp/out`), untimed.
Standard library only.

Example (the report of two builds):
    python3 benches/ab.py --rounds 5 --setup 'rm -rf /tmp/ab-out' -- \
        /tmp/old/detnoise report --darks data-synthetic/scmos-darks-64x64.fits --out /tmp/ab-out -- \
        target/release/detnoise report --darks data-synthetic/scmos-darks-64x64.fits --out /tmp/ab-out
"""

import argparse
import os
import statistics
import subprocess
import sys
import time


def run(command: str, setup: str | None) -> tuple[float, float, float]:
    """Wall seconds, CPU seconds and peak resident MiB of one run of `command`."""
    if setup:
        subprocess.run(setup, shell=True, check=True)
    start = time.perf_counter()
    child = subprocess.Popen(
        command, shell=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    # wait4 gives this child's own usage (with the processes it waited for), peak included.
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        sys.exit(f"failed (exit {child.returncode}): {command}")
    cpu = usage.ru_utime + usage.ru_stime
    return wall, cpu, usage.ru_maxrss / 1024  # KiB on Linux


def split_commands(rest: list[str]) -> tuple[str, str]:
    """The two commands after `--` separators."""
    if rest and rest[0] == "--":
        rest = rest[1:]
    if "--" not in rest:
        sys.exit("give two commands separated by --")
    cut = rest.index("--")
    a, b = rest[:cut], rest[cut + 1 :]
    if not a or not b:
        sys.exit("both commands must be non-empty")
    return " ".join(a), " ".join(b)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5, help="runs of each command (default 5)")
    parser.add_argument("--setup", help="shell command run before every run, untimed")
    args, rest = parser.parse_known_args()
    if args.rounds < 1:
        sys.exit("--rounds must be at least 1")
    commands = split_commands(rest)
    results: list[list[tuple[float, float, float]]] = [[], []]
    for r in range(args.rounds):
        for i, command in enumerate(commands):
            results[i].append(run(command.replace("{round}", str(r)), args.setup))
    medians = []
    for name, command, runs in zip("AB", commands, results):
        walls = [w for w, _, _ in runs]
        cpus = [c for _, c, _ in runs]
        peak = max(m for _, _, m in runs)
        medians.append((statistics.median(walls), statistics.median(cpus)))
        print(f"{name}: {command}")
        print(
            f"   wall median {statistics.median(walls):.3f} s, best {min(walls):.3f} s; "
            f"CPU median {statistics.median(cpus):.3f} s; peak {peak:.1f} MiB"
        )
    (wa, ca), (wb, cb) = medians
    print(f"B / A: wall {wb / wa:.3f}, CPU {cb / ca:.3f} ({args.rounds} alternated rounds)")


if __name__ == "__main__":
    main()
