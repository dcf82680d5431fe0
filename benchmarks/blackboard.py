"""Benchmark: the 400-pose ``normal`` run of the whiskered table mapper (Fox & Prescott 2011).

Runs the blackboard experiment's ``normal`` condition (world ``whisker-tables-v1``, 400
poses, one :class:`~bayesmap.blackboard.TableMapper` step per pose) ``--repeats`` times
with the same seed and prints the per-pose median and 95th percentile of the mapper step,
the whole run's wall time (simulation + mapping, figures excluded) beside precision and
recall, so speed is never bought with accuracy. Targets: median < 50 ms per pose, whole
run < 30 s. Medians over repeats. Run from the repository root as
``python benchmarks/blackboard.py`` (or ``python -m benchmarks.blackboard``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap.experiments import blackboard  # noqa: E402

KEYS = ("per_pose_ms_median", "per_pose_ms_p95", "wall_s", "precision", "recall", "gospa_mean")


def measure(repeats: int, seed: int) -> list[dict[str, float]]:
    """Metrics of ``repeats`` runs of the 400-pose ``normal`` condition."""
    runs = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            config = blackboard.Config(seed=seed, conditions=("normal",))
            blackboard.run(config, Path(tmp))
            runs.append(json.loads((Path(tmp) / "normal" / "metrics.json").read_text()))
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=blackboard.Config().seed)
    args = parser.parse_args()
    runs = measure(args.repeats, args.seed)
    median = {k: statistics.median(r[k] for r in runs) for k in KEYS}
    target = median["per_pose_ms_median"] < 50 and median["wall_s"] < 30
    rows = [
        "| poses | per-pose median [ms] | per-pose p95 [ms] | whole run [s] | precision | recall "
        "| GOSPA mean [m] | targets met |",
        "|---|---|---|---|---|---|---|---|",
        f"| {runs[0]['poses']} | {median['per_pose_ms_median']:.1f} "
        f"| {median['per_pose_ms_p95']:.1f} "
        f"| {median['wall_s']:.1f} | {median['precision']:.3f} | {median['recall']:.3f} "
        f"| {median['gospa_mean']:.3f} | {'yes' if target else 'no'} |",
    ]
    markdown = "\n".join(
        [
            "## Blackboard table mapper (Fox & Prescott 2011), 400-pose `normal` run",
            "",
            f"Machine: {machine()}. Median of {args.repeats} runs, seed {args.seed}, world "
            f"`{runs[0]['scenario']}`. Per-pose times are the `TableMapper.step` of one pose "
            "(Algorithm 1, 40 temperatures); the whole run adds the whisker simulation. "
            "Targets: median < 50 ms per pose, whole run < 30 s. Precision and recall as in "
            "docs/blackboard-results.md (the same seed gives the same numbers every repeat).",
            "",
            *rows,
        ]
    )
    print("\n".join(rows))
    update_section("blackboard", markdown)


if __name__ == "__main__":
    main()
