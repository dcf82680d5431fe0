"""Hostile network files: limits before allocation, non-regular inputs, a strict grammar."""

from __future__ import annotations

import gzip
import os
import threading

import pytest

from bayesmap.bn import io
from bayesmap.bn.io import bif, xbn, xdsl, xmlbif
from bayesmap.bn.io import net as hugin
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits

MODULES = {"bif": bif, "xmlbif": xmlbif, "xbn": xbn, "net": hugin, "xdsl": xdsl}


def _small_net() -> BayesNet:
    net = BayesNet("n")
    net.add_variable("a", ["x", "y"], cpt=[0.25, 0.75])
    net.add_variable("b", ["u", "v"], parents=["a"], cpt=[[0.5, 0.125], [0.5, 0.875]])
    return net


def _many_parents_bif(n_parents: int) -> str:
    parts = ["network big {}\n"]
    for k in range(n_parents + 1):
        parts.append(f"variable p{k} {{ type discrete [ 2 ] {{ a, b }}; }}\n")
    for k in range(n_parents):
        parts.append(f"probability ( p{k} ) {{ table 0.5, 0.5; }}\n")
    parents = ", ".join(f"p{k}" for k in range(n_parents))
    parts.append(f"probability ( p{n_parents} | {parents} ) {{ default 0.5, 0.5; }}\n")
    return "".join(parts)


def _many_parents_xmlbif(n_parents: int) -> str:
    variables = "".join(
        f"<VARIABLE TYPE='nature'><NAME>p{k}</NAME><OUTCOME>a</OUTCOME><OUTCOME>b</OUTCOME>"
        "</VARIABLE>"
        for k in range(n_parents + 1)
    )
    roots = "".join(
        f"<DEFINITION><FOR>p{k}</FOR><TABLE>0.5 0.5</TABLE></DEFINITION>" for k in range(n_parents)
    )
    given = "".join(f"<GIVEN>p{k}</GIVEN>" for k in range(n_parents))
    child = f"<DEFINITION><FOR>p{n_parents}</FOR>{given}<TABLE>0.5 0.5</TABLE></DEFINITION>"
    return f"<BIF VERSION='0.3'><NETWORK><NAME>big</NAME>{variables}{roots}{child}</NETWORK></BIF>"


@pytest.mark.parametrize("n_parents", [33, 63, 64, 200])
@pytest.mark.parametrize("maker", [_many_parents_bif, _many_parents_xmlbif])
def test_too_many_parents_is_a_clear_error_not_an_overflow(maker, n_parents: int) -> None:
    fmt = "bif" if maker is _many_parents_bif else "xmlbif"
    with pytest.raises(FormatError, match="max_parents") as caught:
        io.loads(maker(n_parents), fmt)
    assert f"{n_parents}" in str(caught.value)


def test_a_small_file_declaring_a_huge_table_is_refused_before_allocation() -> None:
    # 24 parents of 4 states: a 2 x 4**24 table (2.8e14 entries) from a 2 kB file.
    text = _many_parents_bif(24).replace("[ 2 ] { a, b }", "[ 4 ] { a, b, c, d }")
    text = text.replace("table 0.5, 0.5;", "table 0.25, 0.25, 0.25, 0.25;")
    text = text.replace("default 0.5, 0.5;", "default 0.25, 0.25, 0.25, 0.25;")
    with pytest.raises(FormatError, match="max_table_entries"):
        bif.loads(text, path="huge.bif")


def test_the_tables_of_a_network_share_one_budget() -> None:
    text = bif.dumps(_small_net())
    limits = ReadLimits(max_network_entries=5)
    with pytest.raises(FormatError, match="all tables of the network.*max_network_entries"):
        bif.loads(text, limits=limits)
    assert len(bif.loads(text, limits=ReadLimits(max_network_entries=6))) == 2


@pytest.mark.parametrize("fmt", sorted(MODULES))
def test_limits_are_configurable(fmt: str) -> None:
    text = MODULES[fmt].dumps(_small_net())
    with pytest.raises(FormatError, match="entries in the table of 'b'.*max_table_entries"):
        MODULES[fmt].loads(text, limits=ReadLimits(max_table_entries=3))
    assert len(MODULES[fmt].loads(text, limits=ReadLimits(max_table_entries=4))) == 2


def test_a_gzip_bomb_is_stopped_at_the_byte_limit(tmp_path) -> None:
    path = tmp_path / "bomb.bif.gz"
    path.write_bytes(gzip.compress(b" " * 5_000_000))
    with pytest.raises(FormatError, match="after gunzipping.*max_bytes") as caught:
        io.read(path, limits=ReadLimits(max_bytes=100_000))
    assert caught.value.path == str(path)


def test_files_larger_than_the_limit_are_refused_unread(tmp_path) -> None:
    path = tmp_path / "n.bif"
    io.write(_small_net(), path)
    with pytest.raises(FormatError, match="bytes in the file"):
        io.read(path, limits=ReadLimits(max_bytes=10))


def test_truncated_and_concatenated_gzip(tmp_path) -> None:
    text = bif.dumps(_small_net()).encode()
    whole = gzip.compress(text)
    (tmp_path / "cut.bif.gz").write_bytes(whole[: len(whole) // 2])
    with pytest.raises(FormatError, match="ends early"):
        io.read(tmp_path / "cut.bif.gz")
    half = len(text) // 2
    (tmp_path / "two.bif.gz").write_bytes(gzip.compress(text[:half]) + gzip.compress(text[half:]))
    assert len(io.read(tmp_path / "two.bif.gz")) == 2


def test_only_regular_files_are_opened(tmp_path) -> None:
    fifo = tmp_path / "pipe.bif"
    os.mkfifo(fifo)
    outcome: list[BaseException] = []

    def read_fifo() -> None:
        try:
            io.read(fifo)
        except BaseException as error:  # noqa: BLE001 - handed to the test thread
            outcome.append(error)

    reader = threading.Thread(target=read_fifo, daemon=True)
    reader.start()
    reader.join(10)
    assert not reader.is_alive(), "reading a FIFO blocked"
    assert isinstance(outcome[0], FormatError) and "regular file" in str(outcome[0])
    with pytest.raises(FormatError, match="regular file"):
        io.read("/dev/zero", format="bif")
    (tmp_path / "dir.bif").mkdir()
    with pytest.raises(FormatError, match="regular file"):
        io.read(tmp_path / "dir.bif")


NOT_NUMBERS = ["1_0", "Infinity", "inf", "nan", "NaN", "\u0661", "0x1", "1e999", "\uff11"]


@pytest.mark.parametrize("fmt", sorted(MODULES))
@pytest.mark.parametrize("token", NOT_NUMBERS)
def test_only_ascii_decimal_finite_numbers_are_probabilities(fmt: str, token: str) -> None:
    text = MODULES[fmt].dumps(_small_net()).replace("0.125", token)
    with pytest.raises(FormatError, match="not a number|too large"):
        MODULES[fmt].loads(text, path="f")


def test_a_nan_bif_row_is_not_replaced_by_the_default() -> None:
    text = """network n {}
variable a { type discrete [ 2 ] { x, y }; }
variable b { type discrete [ 2 ] { u, v }; }
probability ( a ) { table 0.5, 0.5; }
probability ( b | a ) { (x) nan, 5.0; default 0.5, 0.5; }
"""
    with pytest.raises(FormatError, match="'nan' is not a number"):
        bif.loads(text)


def test_a_duplicate_xbn_row_is_refused_whatever_the_first_held() -> None:
    text = xbn.dumps(_small_net())
    first = '<DPI INDEXES="0">0.5 0.5</DPI>'
    assert first in text
    with pytest.raises(FormatError, match="'nan' is not a number"):
        xbn.loads(text.replace(first, first.replace("0.5 0.5", "nan nan") + first))
    with pytest.raises(FormatError, match="given twice"):
        xbn.loads(text.replace(first, first + first))


def test_a_duplicate_bif_row_is_refused() -> None:
    text = bif.dumps(_small_net())
    row = "  (x) 0.5, 0.5;\n"
    assert row in text
    with pytest.raises(FormatError, match="already given"):
        bif.loads(text.replace(row, row + row))


@pytest.mark.parametrize(
    ("fmt", "old", "new"),
    [
        ("xmlbif", "<OUTCOME>x</OUTCOME>", "<OUTCOME></OUTCOME>"),
        ("xmlbif", "<OUTCOME>y</OUTCOME>", "<OUTCOME>  </OUTCOME>"),
        ("xbn", "<STATENAME>x</STATENAME>", "<STATENAME></STATENAME>"),
        ("bif", "{ x, y }", '{ "", y }'),
        ("net", '("x" "y")', '("" "y")'),
        ("xdsl", '<state id="x"/>', '<state id=""/>'),
    ],
)
def test_empty_names_are_refused(fmt: str, old: str, new: str) -> None:
    text = MODULES[fmt].dumps(_small_net())
    assert old in text
    with pytest.raises(FormatError, match="empty name"):
        MODULES[fmt].loads(text.replace(old, new))


@pytest.mark.parametrize("fmt", ["xmlbif", "xbn"])
def test_xml_entities_are_refused(fmt: str) -> None:
    text = MODULES[fmt].dumps(_small_net())
    body = text.split("?>", 1)[1]
    root = body.lstrip().split()[0][1:]
    declared = f'<!DOCTYPE {root} [<!ENTITY e "x">]>' + body.replace(">x<", ">&e;<", 1)
    with pytest.raises(FormatError, match="declares entities"):
        MODULES[fmt].loads(declared)
    external = f'<!DOCTYPE {root} SYSTEM "file:///etc/passwd">' + body.replace(">x<", ">&e;<", 1)
    with pytest.raises(FormatError, match="entity"):
        MODULES[fmt].loads(external)
    plain = f"<!DOCTYPE {root} [<!ELEMENT {root} ANY>]>" + body
    assert len(MODULES[fmt].loads(plain)) == 2  # a DTD without entities is fine


@pytest.mark.parametrize(
    ("text", "message", "line"),
    [
        ("network n {}\n/* never closed\nvariable a {}", "unterminated comment", 2),
        ('network n {}\nvariable "a { type discrete [ 1 ] { x }; }', "unterminated quoted", 2),
        ("network n {}\n" + "/* " * 60_000, "unterminated comment", 2),
        ("network n {}\nvariable a " + "x" * 40_000, "without '{'", 2),
    ],
    ids=["comment", "quote", "many-comments", "long-token"],
)
def test_bif_scanning_errors_name_their_line(text: str, message: str, line: int) -> None:
    with pytest.raises(FormatError, match=message) as caught:
        bif.loads(text, path="f.bif")
    assert caught.value.line == line


def test_bif_comments_and_quoted_slashes_still_read() -> None:
    text = bif.dumps(_small_net())
    text = text.replace("network n {", '// a comment "with a quote\nnetwork n { /* block\n*/')
    text = text.replace("variable a {", 'variable a { property note = "a // b /* c" ;')
    net = bif.loads(text)
    assert net.variable("a").properties["note"] == "a // b /* c"
