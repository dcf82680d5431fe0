"""Load and write times of network files: bayesmap vs pgmpy's BIFReader vs pyAgrum's loadBN.

Every bnlearn file shipped with pgmpy 1.1 (``pgmpy/utils/example_models/*.bif.gz``) is
unpacked to a temporary ``.bif`` and loaded from disk by each library: the median of
``--repeats`` runs (pgmpy: one run for files where its first run takes over 3 s). Then
bayesmap writes each network as BIF, XMLBIF, XBN, Hugin NET (where its names are NET
names), GeNIe XDSL (where they are SMILE identifiers) and UAI, and reads all but the BIF
back, and pyAgrum loads the same NET file.
The table goes to the ``bn_io`` section of docs/benchmarks.md.

Run from the repository root: ``python benchmarks/bn_io.py [--repeats 5]``.
"""

from __future__ import annotations

import argparse
import gzip
import logging
import statistics
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import pgmpy  # noqa: E402
import pyagrum as gum  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402
from pgmpy.readwrite import BIFReader  # noqa: E402

from bayesmap.bn import io  # noqa: E402
from bayesmap.errors import FormatError  # noqa: E402

EXAMPLES = Path(pgmpy.__file__).parent / "utils" / "example_models"
PGMPY_SINGLE_RUN = 3.0


def _time(function: Callable[[], object], repeats: int) -> float:
    runs = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        runs.append(time.perf_counter() - start)
    return statistics.median(runs)


def _pgmpy(path: Path) -> object:
    return BIFReader(str(path)).get_model()


def _pyagrum(path: Path, repeats: int) -> float | None:
    try:
        return _time(lambda: gum.loadBN(str(path)), repeats)
    except Exception:  # noqa: BLE001 - pyAgrum's own error types: record the failure
        return None


FILES = (".bif", ".xml", ".xbn", ".net", ".xdsl", ".uai")
"""The formats each network is written in; all but BIF are read back."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    logging.disable(logging.WARNING)
    warnings.simplefilter("ignore")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for source in sorted(EXAMPLES.glob("*.bif.gz")):
            name = source.name.removesuffix(".bif.gz")
            path = Path(tmp) / f"{name}.bif"
            path.write_bytes(gzip.decompress(source.read_bytes()))
            ours = _time(lambda p=path: io.read(p), args.repeats)
            start = time.perf_counter()
            _pgmpy(path)
            first = time.perf_counter() - start
            theirs = first
            if first < PGMPY_SINGLE_RUN:
                theirs = statistics.median(
                    [first, _time(lambda p=path: _pgmpy(p), args.repeats - 1)]
                )
            agrum = _pyagrum(path, args.repeats)
            net = io.read(path)
            writes: dict[str, float | None] = {}
            for suffix in FILES:
                try:
                    writes[suffix] = _time(
                        lambda s=suffix, n=net: io.write(n, Path(tmp) / f"out{s}"), 3
                    )
                except FormatError:  # a name NET or XDSL cannot hold
                    writes[suffix] = None
            reads: dict[str, float | None] = {
                s: _time(lambda s=s: io.read(Path(tmp) / f"out{s}"), 3) if writes[s] else None
                for s in FILES[1:]
            }
            reads["pyAgrum .net"] = _pyagrum(Path(tmp) / "out.net", 3) if writes[".net"] else None
            row = (name, len(net), ours, theirs, agrum, writes, reads)
            rows.append(row)
            print(
                f"{name:12s} {len(net):5d} vars  bayesmap {ours * 1e3:8.1f} ms  "
                f"pgmpy {theirs * 1e3:9.1f} ms "
                f"({theirs / ours:6.1f}x)  pyAgrum "
                + (f"{agrum * 1e3:7.1f} ms" if agrum is not None else "  fails")
                + "  write bif/xml/xbn/net/xdsl/uai "
                + "/".join(_ms(w) for w in writes.values())
                + " ms  read xml/xbn/net/xdsl/uai, pyAgrum net "
                + "/".join(_ms(r) for r in reads.values())
                + " ms",
                flush=True,
            )
    update_section("bn_io", _markdown(rows, args.repeats))


def _ms(seconds: float | None) -> str:
    return "–" if seconds is None else f"{seconds * 1e3:.1f}"


def _markdown(rows: list[tuple], repeats: int) -> str:
    speedups = [row[3] / row[2] for row in rows]
    worst = min(speedups)
    lines = [
        "## Network files (`benchmarks/bn_io.py`)",
        "",
        f"Machine: {machine()}. Load of each bnlearn file from an unpacked `.bif` on disk, "
        f"median of {repeats} runs (pgmpy 1.1 `BIFReader(path).get_model()`: one run when it "
        f"takes over {PGMPY_SINGLE_RUN:.0f} s); pyAgrum {gum.__version__} `loadBN`; then bayesmap "
        "writes the network in each format and reads all but its BIF file back, "
        "and pyAgrum loads the NET file (medians of 3; – where the names are not NET or SMILE "
        "names). "
        "Other jobs shared the two cores, so absolute times are noisy; the ratios are what "
        "matter.",
        "",
        "| network | variables | bayesmap load [ms] | pgmpy load [ms] | speed-up vs pgmpy "
        "| pyAgrum load [ms] | write BIF / XMLBIF / XBN / NET / XDSL / UAI [ms] "
        "| load XMLBIF / XBN / NET / XDSL / UAI [ms] | pyAgrum load NET [ms] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, size, ours, theirs, agrum, writes, reads in rows:
        agrum_text = f"{agrum * 1e3:.1f}" if agrum is not None else "cannot read"
        write_text = " / ".join(_ms(w) for w in writes.values())
        read_text = " / ".join(_ms(reads[s]) for s in FILES[1:])
        lines.append(
            f"| {name} | {size} | {ours * 1e3:.1f} | {theirs * 1e3:.0f} | {theirs / ours:.0f}x "
            f"| {agrum_text} | {write_text} | {read_text} | {_ms(reads['pyAgrum .net'])} |"
        )
    verdict = "holds" if worst >= 10 else "does NOT hold"
    lines += [
        "",
        f"Target (load every file at least 10x faster than pgmpy): **{verdict}** — the smallest "
        f"speed-up is {worst:.0f}x, the median {statistics.median(speedups):.0f}x.",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    main()
