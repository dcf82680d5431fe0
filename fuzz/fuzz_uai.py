"""atheris harness: the UAI reader.

Run: ``python fuzz/fuzz_uai.py -max_total_time=600`` (see docs/reliability.md).
"""

from _harness import main

if __name__ == "__main__":
    main("uai")
