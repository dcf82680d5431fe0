"""A fuzzing campaign over every reader: counts of outcomes into docs/reliability.md.

For each reader (:mod:`_targets`), ``--cases`` mutated files (random edits of its seeds)
and every poison applied ``--poison-rounds`` times are read in this process, each under
a wall-clock limit (SIGALRM) and with the address space capped (RLIMIT_AS), and sorted:

- result: the reader returned (fine for a mutation; a *silent accept* for a poison);
- clean error: a ``BayesmapError`` (fine);
- crash: any other exception; hang: over ``--time-limit`` seconds; memory blow-up:
  ``MemoryError`` under the cap.

The same ``--seed`` gives the same files. The table goes to the ``fuzz`` section of
docs/reliability.md, with the first crash messages if there are any.

Run from the repository root: ``python fuzz/campaign.py [--cases 5000] [--seed 12]``.
"""

from __future__ import annotations

import argparse
import collections
import logging
import resource
import signal
import sys
import tempfile
import time
import warnings
from pathlib import Path
from types import FrameType

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from benchmarks._report import machine, update_section  # noqa: E402

from _targets import Target, mutate, targets  # noqa: E402
from bayesmap.errors import BayesmapError  # noqa: E402

DOC = ROOT / "docs" / "reliability.md"
OUTCOMES = ("result", "clean error", "crash", "hang", "memory blow-up")


class _Hang(BaseException):
    """Raised by the alarm when one case runs past the time limit."""


def _alarm(signum: int, frame: FrameType | None) -> None:
    raise _Hang


def classify(target: Target, data: bytes, scratch: Path, time_limit: float) -> tuple[str, str]:
    """Outcome of reading ``data`` with ``target``, and a note for crashes."""
    signal.setitimer(signal.ITIMER_REAL, time_limit)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            target.read(data, scratch)
        return "result", ""
    except BayesmapError:
        return "clean error", ""
    except _Hang:
        return "hang", ""
    except MemoryError:
        return "memory blow-up", ""
    except Exception as error:  # noqa: BLE001 - counting what escapes is the point
        return "crash", f"{type(error).__name__}: {str(error)[:120]}"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)


def campaign(
    target: Target, cases: int, poison_rounds: int, seed: int, time_limit: float
) -> tuple[collections.Counter[str], collections.Counter[str], list[str], float]:
    """Counts for random mutations and for poisons, crash notes, and seconds taken."""
    rng = np.random.default_rng(seed)
    mutated: collections.Counter[str] = collections.Counter()
    poisoned: collections.Counter[str] = collections.Counter()
    notes: list[str] = []
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        scratch = Path(folder)
        for _ in range(cases):
            base = target.seeds[int(rng.integers(0, len(target.seeds)))]
            other = target.seeds[int(rng.integers(0, len(target.seeds)))]
            outcome, note = classify(target, mutate(base, rng, splice=other), scratch, time_limit)
            mutated[outcome] += 1
            if note:
                notes.append(note)
        for _ in range(poison_rounds):
            for poison in target.poisons:
                base = target.seeds[int(rng.integers(0, len(target.seeds)))]
                outcome, note = classify(target, poison(base, rng), scratch, time_limit)
                poisoned[outcome] += 1
                if note:
                    notes.append(note)
    return mutated, poisoned, notes, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=5000, help="mutated files per reader")
    parser.add_argument("--poison-rounds", type=int, default=40, help="rounds of every poison")
    parser.add_argument("--seed", type=int, default=12)
    parser.add_argument("--time-limit", type=float, default=5.0, help="seconds per file")
    parser.add_argument("--memory-gb", type=float, default=4.0, help="address-space cap")
    parser.add_argument("--only", nargs="*", help="readers to fuzz (default: all)")
    args = parser.parse_args()
    logging.getLogger("bayesmap").setLevel(logging.ERROR)  # skipped-row warnings
    cap = int(args.memory_gb * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    signal.signal(signal.SIGALRM, _alarm)
    rows = []
    crash_notes: list[str] = []
    for k, (name, target) in enumerate(targets().items()):
        if args.only and name not in args.only:
            continue
        mutated, poisoned, notes, seconds = campaign(
            target, args.cases, args.poison_rounds, args.seed + k, args.time_limit
        )
        print(f"{name}: {dict(mutated)} poisons {dict(poisoned)} in {seconds:.0f} s", flush=True)
        crash_notes += [f"{name}: {note}" for note in collections.Counter(notes)]
        n_poison = sum(poisoned.values())
        silent = poisoned["result"]
        rows.append(
            f"| {name} | {sum(mutated.values()) + n_poison} | "
            f"{mutated['result']} | {mutated['clean error'] + poisoned['clean error']} | "
            f"{mutated['crash'] + poisoned['crash']} | {mutated['hang'] + poisoned['hang']} | "
            f"{mutated['memory blow-up'] + poisoned['memory blow-up']} | "
            + (f"{silent} of {n_poison}" if n_poison else "no poisons")
            + f" | {seconds:.0f} |"
        )
    lines = [
        "## Fuzz counts per reader",
        "",
        f"`python fuzz/campaign.py --cases {args.cases} --poison-rounds {args.poison_rounds} "
        f"--seed {args.seed}` — {machine()} (a shared machine; the seconds are indicative). "
        f"Each reader got {args.cases} randomly mutated files (1-4 byte flips, token inserts, "
        "cuts, copies, truncations, splices of its seed files) and every poison (an edit that "
        f"makes the file invalid) {args.poison_rounds} times; limits per file: "
        f"{args.time_limit:g} s wall clock, {args.memory_gb:g} GB address space.",
        "",
        "| reader | cases | results | clean errors | crashes | hangs | memory blow-ups "
        "| silent accepts (of poisons) | seconds |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        *rows,
        "",
        "Crashes: " + ("; ".join(crash_notes[:10]) if crash_notes else "none."),
    ]
    update_section("fuzz", "\n".join(lines), doc=DOC)


if __name__ == "__main__":
    main()
