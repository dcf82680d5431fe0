import pytest

from bayesmap.errors import BayesmapError, ConfigError, FormatError, InputError, ModelError


@pytest.mark.parametrize("kind", [ModelError, ConfigError, InputError, FormatError])
def test_every_error_is_a_bayesmap_error_and_a_value_error(kind):
    error = kind("bad")
    assert isinstance(error, BayesmapError)
    assert isinstance(error, ValueError)


def test_format_error_names_file_line_and_element():
    error = FormatError(
        "probabilities do not sum to 1", path="asia.bif", line=12, element="probability ( dysp )"
    )
    text = str(error)
    assert text.startswith("asia.bif, line 12, probability ( dysp ): ")
    assert error.line == 12 and error.path == "asia.bif"


def test_format_error_without_location_is_just_the_message():
    assert str(FormatError("empty file")) == "empty file"
