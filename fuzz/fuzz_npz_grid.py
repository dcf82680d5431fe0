"""atheris harness: the npz grid reader.

Run: ``python fuzz/fuzz_npz_grid.py -max_total_time=600`` (see docs/reliability.md).
"""

from _harness import main

if __name__ == "__main__":
    main("npz grid")
