"""The shared reader of world files: one clear FormatError naming file, line or element."""

from __future__ import annotations

from pathlib import Path

import pytest

from bayesmap.errors import FormatError
from bayesmap.sim.world_files import check_schema, read_document

SCHEMA = {
    "type": "object",
    "required": ["size"],
    "properties": {"size": {"type": "array", "items": {"type": "number"}}},
}


def test_a_good_document_is_read_and_passes(tmp_path: Path) -> None:
    path = tmp_path / "w.json"
    path.write_text('{"size": [1, 2.5]}', encoding="utf-8")
    document = read_document(path)
    assert document == {"size": [1, 2.5]}
    check_schema(document, SCHEMA, path)


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (b'{"size": [1,\n 2', ["w.json", "not JSON", "2"]),
        (b"\xff\xfe{}", ["w.json", "not UTF-8"]),
    ],
)
def test_unreadable_documents_name_the_file(tmp_path: Path, content: bytes, words: list[str]):
    path = tmp_path / "w.json"
    path.write_bytes(content)
    with pytest.raises(FormatError) as caught:
        read_document(path)
    message = str(caught.value)
    assert "\n" not in message
    for word in words:
        assert word in message


def test_a_missing_file_is_a_format_error(tmp_path: Path) -> None:
    with pytest.raises(FormatError, match="cannot read the world file"):
        read_document(tmp_path / "absent.json")


def test_a_schema_break_names_the_element(tmp_path: Path) -> None:
    with pytest.raises(FormatError) as caught:
        check_schema({"size": [1, "two"]}, SCHEMA, tmp_path / "w.json")
    assert "size[1]" in str(caught.value) and "w.json" in str(caught.value)
    with pytest.raises(FormatError, match="the document"):
        check_schema({}, SCHEMA, tmp_path / "w.json")
