"""atheris harness: the ROS yaml reader.

Run: ``python fuzz/fuzz_ros_yaml.py -max_total_time=600`` (see docs/reliability.md).
"""

from _harness import main

if __name__ == "__main__":
    main("ROS yaml")
