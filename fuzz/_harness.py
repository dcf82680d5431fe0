"""The atheris (libFuzzer) driver behind every ``fuzz/fuzz_*.py`` harness.

``main(name)`` instruments bayesmap, then feeds libFuzzer's inputs to the reader
``name`` of :mod:`_targets`. A :class:`~bayesmap.errors.BayesmapError` is a correct
answer to a bad file; any other exception, a time-out (``-timeout``, 5 s by default here)
or running out of memory (``-rss_limit_mb``, 2048 MB by default) is a finding that libFuzzer
saves as ``crash-*``/``timeout-*``/``oom-*``. Without a corpus folder on the command line
the reader's seed files are used.
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import atheris

with atheris.instrument_imports(include=["bayesmap"]):
    from _targets import targets
    from bayesmap.errors import BayesmapError


def main(name: str) -> None:
    """Fuzz the reader ``name`` until libFuzzer stops (``-runs=N``, ``-max_total_time=S``)."""
    target = targets()[name]
    scratch = Path(tempfile.mkdtemp(prefix=f"bayesmap-fuzz-{name.replace(' ', '-')}-"))
    argv = list(sys.argv)
    if not any(Path(arg).is_dir() for arg in argv[1:] if not arg.startswith("-")):
        corpus = scratch / "corpus"
        corpus.mkdir()
        for k, seed in enumerate(target.seeds):
            (corpus / f"seed-{k}").write_bytes(seed)
        argv.append(str(corpus))
    if not any(arg.startswith("-timeout=") for arg in argv):
        argv.append("-timeout=5")
    warnings.simplefilter("ignore")

    def test_one_input(data: bytes) -> None:
        try:
            target.read(data, scratch)
        except BayesmapError:
            pass

    atheris.Setup(argv, test_one_input)
    atheris.Fuzz()
