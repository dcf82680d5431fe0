"""atheris harness: the xmlbif reader.

Run: ``python fuzz/fuzz_xmlbif.py -max_total_time=600`` (see docs/reliability.md).
"""

from _harness import main

if __name__ == "__main__":
    main("xmlbif")
