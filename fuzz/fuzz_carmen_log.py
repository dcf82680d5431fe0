"""atheris harness: the CARMEN log reader.

Run: ``python fuzz/fuzz_carmen_log.py -max_total_time=600`` (see docs/reliability.md).
"""

from _harness import main

if __name__ == "__main__":
    main("CARMEN log")
