"""atheris harness: the GeNIe XDSL reader.

Run: ``python fuzz/fuzz_xdsl.py -max_total_time=600`` (see docs/reliability.md).
"""

from _harness import main

if __name__ == "__main__":
    main("xdsl")
