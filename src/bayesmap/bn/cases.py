"""Evidence cases as tables: pandas DataFrames and CSV/Parquet files, streamed in chunks.

A table of cases has one column per observed variable (named like the variable) and one
row per case; a cell holds a state name — or a state index, in an integer column — and a
blank (empty cell, NaN, None) means *unobserved*. :func:`posterior_frame` answers one
table; :func:`run_batch` answers a table or a stream of tables chunk by chunk, so memory
stays bounded by the chunk size, and is the unit of work to hand to a Dask worker (one
partition of cases each). :func:`read_cases` and :func:`write_posteriors` stream files.

pandas, pyarrow and the file plumbing are imported on first use, so that
``import bayesmap.bn`` stays fast.
"""

from __future__ import annotations

import csv
import re
import warnings
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bayesmap._typing import IntArray, ProgressHook
from bayesmap.bn.suggest import unknown
from bayesmap.errors import FormatError, InputError

if TYPE_CHECKING:
    import pandas as pd

    from bayesmap.bn.model import BayesNet

CHUNK_ROWS = 1 << 16
"""Cases answered per chunk by default: ~10 MB of evidence and answers for alarm."""

SUFFIXES = (".csv", ".parquet")


def column_name(target: str, state: str) -> str:
    """The column of ``P(target = state | case)`` in an answer table: ``"target=state"``."""
    return f"{target}={state}"


def case_array(net: BayesNet, frame: pd.DataFrame) -> tuple[IntArray, list[str]]:
    """The ``(n_cases, n_columns)`` state-index array of a table of cases (−1 = blank).

    Raises
    ------
    InputError
        A column that names no variable, or a cell that names no state of its column's
        variable (the message gives the row label and suggests close names).
    """
    import pandas as pd

    columns = [str(c) for c in frame.columns]
    for c in columns:
        if c not in net:
            raise InputError(
                f"cases column {c!r} is not a variable of {net.name!r}; "
                + unknown("variable", c, net.variables)
            )
    table = np.full((len(frame), len(columns)), -1, dtype=np.int64)
    for j, name in enumerate(columns):
        values = frame.iloc[:, j]
        states = net.states(name)
        blank = values.isna().to_numpy(dtype=bool, copy=True)
        if pd.api.types.is_numeric_dtype(values.dtype) and not pd.api.types.is_bool_dtype(
            values.dtype
        ):
            numbers = values.to_numpy(dtype=np.float64, na_value=np.nan)
            wrong = ~blank & ((numbers != np.round(numbers)) | (numbers < 0))
            wrong |= ~blank & (numbers >= len(states))  # inf too
            codes = np.where(blank | wrong, -1, numbers).astype(np.int64)  # no inf cast
        else:
            text = values.astype("string").str.strip()
            blank |= (text == "").fillna(True).to_numpy(dtype=bool)
            codes = pd.Index(list(states)).get_indexer(text.fillna("")).astype(np.int64)
            wrong = ~blank & (codes < 0)
        if wrong.any():
            i = int(np.flatnonzero(wrong)[0])
            value = values.iloc[i]
            value = value.item() if isinstance(value, np.generic) else value
            raise InputError(
                f"{case_label(frame, i)}, column {name!r}: {value!r} is not a "
                f"state of {name!r}; " + unknown("state", value, states)
            )
        table[:, j] = np.where(blank, -1, codes)
    return table, columns


def case_label(frame: pd.DataFrame, i: int) -> str:
    """How messages name the ``i``-th row of a table of cases: by its label, ``cases line 7``
    for a CSV file (:func:`read_cases`), ``cases row 3`` for a table without a named index."""
    label = frame.index[i]
    label = label.item() if isinstance(label, np.generic) else label
    return f"cases {frame.index.name or 'row'} {label!r}"


def posterior_frame(net: BayesNet, frame: pd.DataFrame, targets: Sequence[str]) -> pd.DataFrame:
    """``P(target = state | case)`` for each row of ``frame``: one column per target state
    (named by :func:`column_name`), the rows labelled like ``frame``'s."""
    import pandas as pd

    table, columns = case_array(net, frame)
    answers: dict[str, Any] = {}
    every = net.posteriors_batch(table, columns=columns, targets=targets)
    for target in targets:
        values = every[target]
        for k, state in enumerate(net.states(target)):
            answers[column_name(target, state)] = values[:, k]
    return pd.DataFrame(answers, index=frame.index)


def run_batch(
    net: BayesNet,
    cases: pd.DataFrame | Iterable[pd.DataFrame],
    targets: Sequence[str],
    *,
    chunk_rows: int = CHUNK_ROWS,
    total: int | None = None,
    progress: ProgressHook | None = None,
) -> Iterator[pd.DataFrame]:
    """Answer cases chunk by chunk: yields one :func:`posterior_frame` per chunk.

    Parameters
    ----------
    net
        The network.
    cases
        One table (cut into chunks of ``chunk_rows``) or a stream of tables, e.g.
        :func:`read_cases` of a file.
    targets
        The queried variables.
    total
        Number of cases, for the progress hook (known for a single table).
    progress
        Called after each chunk with ``("cases", done, total)`` (total −1 if unknown).

    Raises
    ------
    InputError
        A malformed case, or evidence of probability zero; the message names the rows.
    """
    import pandas as pd

    for t in targets:
        net.variable(t)
    if chunk_rows < 1:
        raise InputError(f"chunk_rows must be at least 1, got {chunk_rows}")
    if isinstance(cases, pd.DataFrame):
        frame = cases
        total = len(frame)
        chunks: Iterable[pd.DataFrame] = (
            frame.iloc[i : i + chunk_rows] for i in range(0, len(frame), chunk_rows)
        )
    else:
        chunks = cases
    done = 0
    for chunk in chunks:
        try:
            answer = posterior_frame(net, chunk, targets)
        except InputError as error:
            message = str(error)
            case = re.match(r"batched evidence case (\d+): ", message)
            if case is not None:
                message = f"{case_label(chunk, int(case[1]))}: {message[case.end() :]}"
            raise InputError(message) from None
        done += len(chunk)
        if progress is not None:
            progress("cases", done, -1 if total is None else total)
        yield answer


def check_suffix(path: Path) -> str:
    """The suffix of a cases or answers file (``.csv`` or ``.parquet``), else InputError."""
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise InputError(
            f"{path}: cases and answers files are .csv or .parquet, not {suffix or 'no suffix'!r}"
        )
    return suffix


def count_cases(path: str | Path) -> int:
    """Number of cases in a CSV (data lines, by a fast line count) or Parquet file."""
    path = Path(path)
    if check_suffix(path) == ".parquet":
        import pyarrow.parquet as pq

        try:
            return int(pq.ParquetFile(path).metadata.num_rows)
        except (OSError, ValueError) as error:
            raise FormatError(f"{path}: not a readable Parquet file ({error})") from None
    lines = 0
    last = b"\n"
    try:
        with path.open("rb") as handle:
            while block := handle.read(1 << 20):
                lines += block.count(b"\n")
                last = block[-1:]
    except OSError as error:
        raise InputError(f"{path}: cannot read ({error.strerror})") from None
    lines += last != b"\n"
    return max(lines - 1, 0)


def read_cases(path: str | Path, *, chunk_rows: int = CHUNK_ROWS) -> Iterator[pd.DataFrame]:
    """Stream a CSV or Parquet file of cases as DataFrames of up to ``chunk_rows`` rows.

    CSV cells are read as text, exactly: ``"01"`` and ``"None"`` are state names, and only
    an empty cell (or an empty line, a case with nothing observed) is blank. A row may end
    in empty cells beyond the header's columns (a trailing comma), but not in values. CSV
    rows are labelled by their line in the file (the index is named ``"line"``; a cell
    quoted across lines shifts the count), Parquet rows by their 0-based row.
    """
    import pandas as pd

    path = Path(path)
    if check_suffix(path) == ".parquet":
        import pyarrow.parquet as pq

        try:
            source = pq.ParquetFile(path)
        except (OSError, ValueError) as error:
            raise FormatError(f"{path}: not a readable Parquet file ({error})") from None
        start = 0
        for batch in source.iter_batches(batch_size=chunk_rows):
            frame = batch.to_pandas()
            frame.index = pd.RangeIndex(start, start + len(frame))
            start += len(frame)
            yield frame
        return
    header = _csv_header(path)
    spare = "\x00beyond the header"
    line = 2
    try:
        reader = pd.read_csv(
            path,
            dtype=str,
            chunksize=chunk_rows,
            skipinitialspace=True,
            header=None,
            skiprows=1,
            names=[*header, spare],
            index_col=False,
            keep_default_na=False,
            skip_blank_lines=False,
            encoding="utf-8-sig",
        )
        while True:
            with warnings.catch_warnings():
                # a row with two or more values past the header: pandas would drop them
                warnings.simplefilter("error", pd.errors.ParserWarning)
                frame = next(reader, None)
            if frame is None:
                return
            frame.index = pd.RangeIndex(line, line + len(frame), name="line")
            line += len(frame)
            beyond = frame[spare].fillna("").str.strip() != ""
            if beyond.any():
                raise FormatError(
                    f"{path}: {case_label(frame, int(np.flatnonzero(beyond)[0]))} has "
                    f"more values than the header's {len(header)} columns"
                )
            yield frame.drop(columns=spare)
    except pd.errors.ParserWarning:
        raise FormatError(
            f"{path}: a row has more values than the header's {len(header)} columns"
        ) from None
    except (pd.errors.ParserError, UnicodeDecodeError) as error:
        detail = " ".join(str(error).split())
        raise FormatError(f"{path}: not a readable CSV table ({detail})") from None


def _csv_header(path: Path) -> list[str]:
    """The column names on a CSV file's first line; FormatError if none or repeated."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            first = next(csv.reader(handle, skipinitialspace=True), [])
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, csv.Error) as error:
        raise FormatError(f"{path}: not a readable CSV table ({error})") from None
    names = [name.strip() for name in first]
    if not any(names):
        raise FormatError(f"{path}: no header line naming the observed variables")
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise FormatError(f"{path}: column {repeated[0]!r} appears more than once")
    return names


def write_posteriors(
    path: str | Path, chunks: Iterable[pd.DataFrame], columns: Sequence[str]
) -> int:
    """Write answer chunks to a CSV or Parquet file, atomically; returns the rows written.

    ``columns`` are the answer columns (written as the header of an empty answer). The
    file appears only when every chunk is written (a failure leaves no partial file).
    """
    import pandas as pd

    from bayesmap._io import atomic_open

    path = Path(path)
    empty = pd.DataFrame({c: np.empty(0) for c in columns})
    rows = 0
    if check_suffix(path) == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        with atomic_open(path, "wb") as handle:
            writer: Any = None
            for chunk in chunks:
                table = pa.Table.from_pandas(chunk, preserve_index=False)
                if writer is None:
                    writer = pq.ParquetWriter(handle, table.schema)
                writer.write_table(table)
                rows += len(chunk)
            if writer is None:
                pq.write_table(pa.Table.from_pandas(empty, preserve_index=False), handle)
            else:
                writer.close()
        return rows
    with atomic_open(path, "w", newline="") as handle:
        header = True
        for chunk in chunks:
            chunk.to_csv(handle, header=header, index=False, float_format="%.17g")
            header = False
            rows += len(chunk)
        if header:
            empty.to_csv(handle, index=False)
    return rows
