"""ReadLimits: positive integers, parents within numpy's dimension limit, clear messages."""

import pytest

from bayesmap.errors import ConfigError, FormatError
from bayesmap.limits import DEFAULT_LIMITS, NUMPY_MAX_PARENTS, ReadLimits, check_size


def test_impossible_limits_are_a_config_error() -> None:
    with pytest.raises(ConfigError, match="max_parents"):
        ReadLimits(max_parents=NUMPY_MAX_PARENTS + 1)
    for field in ("max_bytes", "max_table_entries", "max_network_entries", "max_cells"):
        with pytest.raises(ConfigError, match=field):
            ReadLimits(**{field: 0})
    with pytest.raises(ConfigError):
        ReadLimits(max_bytes=True)


def test_check_size_names_the_place_and_the_limit_to_raise() -> None:
    check_size("cells", DEFAULT_LIMITS.max_cells, DEFAULT_LIMITS.max_cells, "max_cells")
    with pytest.raises(FormatError) as caught:
        check_size("cells", 2**70, 10, "max_cells", path="m.npz", element="array 'p'")
    message = str(caught.value)
    assert message.startswith("m.npz, array 'p': cells: 1,180,591,620,717,411,303,424 exceeds")
    assert "ReadLimits.max_cells" in message
