"""Build generated C into a shared library and call it from Python (through ctypes).

For trying generated code on the development machine: the tests compare it with the
engine, the benchmark times it, and the rover's explorer can run its decision network
through it. On the robot, the same two files are compiled into the firmware instead.
"""

from __future__ import annotations

import ctypes
import shutil
import subprocess
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from bayesmap import _io
from bayesmap._typing import FloatArray
from bayesmap.bn.codegen import CSources
from bayesmap.bn.codegen.emit import identifier
from bayesmap.bn.fixed_point import QFormat
from bayesmap.bn.model import BayesNet
from bayesmap.errors import ConfigError, InputError

STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")
"""The warnings the generated code is held to."""

MAX_QUESTIONS = 512
"""Most questions one run of :func:`driver` reads."""

_ERRORS = {1: "an evidence state index is out of range", 2: "the evidence has probability zero"}


def compiler() -> str | None:
    """Path of the system C compiler (``cc``, then ``gcc``), or ``None``."""
    return shutil.which("cc") or shutil.which("gcc")


class NativeNetwork:
    """Generated code compiled into a shared library, called through ctypes.

    Parameters
    ----------
    code
        The generated sources.
    directory
        Where to write and build them (default: a fresh temporary directory).
    flags
        Extra compiler flags (``-O2`` by default).

    Raises
    ------
    ConfigError
        No C compiler, or the code does not compile (the compiler's message is included).
    """

    def __init__(
        self,
        code: CSources,
        directory: str | Path | None = None,
        flags: Sequence[str] = ("-O2",),
    ) -> None:
        cc = compiler()
        if cc is None:
            raise ConfigError("no C compiler (cc or gcc) on PATH to build the generated code")
        folder = Path(directory) if directory is not None else Path(tempfile.mkdtemp())
        _, c_file = code.write(folder)
        library = folder / f"lib{code.prefix}.so"
        command = [cc, *STRICT_FLAGS, *flags, "-shared", "-fPIC", str(c_file), "-o", str(library)]
        done = subprocess.run(command, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise ConfigError(f"{' '.join(command)} failed:\n{done.stderr.strip()}")
        self.code = code
        self.library = library
        self._lib = ctypes.CDLL(str(library))
        self._fixed = code.arith.q is not None
        self._ctype = {
            "float": ctypes.c_float,
            "double": ctypes.c_double,
        }.get(code.arith.name, ctypes.c_int32)
        self._dtype = np.dtype(self._ctype)
        self._functions = {}
        for target in code.targets:
            function = getattr(self._lib, f"{code.prefix}_posterior_{identifier(target)}")
            function.restype = ctypes.c_int
            function.argtypes = [ctypes.c_void_p] * 4
            self._functions[target] = function

    @property
    def q(self) -> QFormat | None:
        """The Q format of a fixed-point build, else ``None``."""
        return self.code.arith.q

    def posterior(
        self,
        target: str,
        evidence: npt.ArrayLike,
        soft: Mapping[str, npt.ArrayLike] | None = None,
        data: Mapping[str, npt.ArrayLike] | None = None,
    ) -> FloatArray | npt.NDArray[np.int32]:
        """Call the generated function of ``target``.

        ``evidence``: one state index per evidence slot, −1 for not observed. ``soft`` and
        ``data``: arrays by variable name, in the C number type (raw integers for fixed
        point); a missing soft vector is ``NULL`` (no soft evidence). Returns the answer in
        that number type (raw integers for fixed point).

        Raises
        ------
        InputError
            The C code reported a state out of range or evidence of probability zero.
        """
        code = self.code
        ev = np.ascontiguousarray(np.asarray(evidence, dtype=np.intc).reshape(-1))
        if ev.size != len(code.evidence):
            raise InputError(f"expected {len(code.evidence)} evidence slots, got {ev.size}")
        keep: list[np.ndarray] = [ev]
        soft_ptrs = self._pointers(code.soft, soft or {}, keep, optional=True)
        data_ptrs = self._pointers(code.data, data or {}, keep, optional=False)
        out = np.zeros(code.states[target], dtype=self._dtype)
        status = self._functions[target](
            ev.ctypes.data if ev.size else None, soft_ptrs, data_ptrs, out.ctypes.data
        )
        if status != 0:
            raise InputError(
                f"generated {code.prefix}_posterior_{identifier(target)}: "
                + _ERRORS.get(status, f"error {status}")
            )
        return out

    def ask(
        self,
        net: BayesNet,
        target: str,
        evidence: Mapping[str, str | int],
        soft: Mapping[str, npt.ArrayLike] | None = None,
    ) -> FloatArray:
        """``P(target | evidence, soft)`` as floats, the data nodes' tables asked of ``net``.

        The counterpart of :meth:`BayesNet.posterior` (``posterior_fixed`` in fixed point):
        evidence by name (variables not given are not observed), soft likelihoods in [0, 1],
        and each data node's source called with the evidence as the engine calls it (in
        fixed point its table is quantised as the engine quantises it).
        """
        code, q = self.code, self.q
        compiled = net._engine.compiled
        slots = [
            compiled.state(compiled.id(v), evidence[v]) if v in evidence else -1
            for v in code.evidence
        ]
        names = compiled.evidence_names(
            {compiled.id(v): compiled.state(compiled.id(v), s) for v, s in evidence.items()}
        )
        data = {v: self._number(compiled.table(compiled.id(v), names)) for v in code.data}
        likelihoods = {
            v: self._number(np.asarray(x, dtype=np.float64)) for v, x in (soft or {}).items()
        }
        answer = self.posterior(target, slots, likelihoods, data)
        return (
            q.to_float(answer.astype(np.int64))
            if q is not None
            else np.asarray(answer, dtype=np.float64)
        )

    def _number(self, values: FloatArray) -> npt.NDArray[Any]:
        """Reals in the C number type (fixed point: the engine's quantisation)."""
        q = self.q
        return q.quantise(values).raw if q is not None else np.asarray(values, dtype=self._dtype)

    def _pointers(
        self,
        names: Sequence[str],
        given: Mapping[str, npt.ArrayLike],
        keep: list[np.ndarray],
        *,
        optional: bool,
    ) -> ctypes.Array[ctypes.c_void_p] | None:
        if not names:
            return None
        pointers = (ctypes.c_void_p * len(names))()
        for k, name in enumerate(names):
            if name not in given:
                if not optional:
                    raise InputError(f"the table of data node {name!r} is needed")
                continue
            array = np.ascontiguousarray(np.asarray(given[name], dtype=self._dtype).reshape(-1))
            keep.append(array)
            pointers[k] = array.ctypes.data
        return pointers


def driver(code: CSources) -> str:
    """C99 ``main`` that answers questions read from stdin with the generated code.

    Input: ``n repeat``, then per question the target slot, the evidence slots, per soft
    slot a flag (0: ``NULL``) and, if 1, the likelihood vector, and every data table. Output:
    per question the status and the answer; last, ``ns_per_question`` (``clock()`` over
    ``repeat`` runs of all questions). Used to run the code on emulated ARM and to time it.
    """
    p = code.prefix
    fmt = {"float": ("%f", "%.9g"), "double": ("%lf", "%.17g")}.get(code.arith.name)
    read, write = fmt if fmt is not None else ("%ld", "%ld")
    cast = "(long)" if fmt is None else "(double)" if code.arith.name == "float" else ""
    cards = [code.states[t] for t in code.targets]
    soft = [code.states[v] for v in code.soft]
    data = [code.data_sizes[v] for v in code.data]
    store = "long" if fmt is None else code.arith.name
    lines = [
        f'#include "{p}.h"',
        "#include <stdio.h>",
        "#include <stdlib.h>",
        "#include <time.h>",
        "",
        f"#define MAX_QUESTIONS {MAX_QUESTIONS}",
        "",
        "static int scan(const char *format, void *into)",
        "{",
        "    if (scanf(format, into) != 1) {",
        '        fprintf(stderr, "bad input\\n");',
        "        exit(2);",
        "    }",
        "    return 0;",
        "}",
        "",
        f"static const int soft_card[] = {{{', '.join(map(str, soft or [0]))}}};",
        f"static const int data_size[] = {{{', '.join(map(str, data or [0]))}}};",
        f"static const int states[] = {{{', '.join(map(str, cards))}}};",
        "",
        "int main(void)",
        "{",
        "    long n, repeat, q, r;",
        "    int k, j;",
        "    static int target[MAX_QUESTIONS];",
        f"    static int evidence[MAX_QUESTIONS][{max(len(code.evidence), 1)}];",
        f"    static {p}_value soft_values[MAX_QUESTIONS][{max(len(soft), 1)}][{max([*soft, 1])}];",
        f"    static int soft_given[MAX_QUESTIONS][{max(len(soft), 1)}];",
        f"    static {p}_value data_values[MAX_QUESTIONS][{max(len(data), 1)}][{max([*data, 1])}];",
        f"    static {p}_value out[MAX_QUESTIONS][{max(cards)}];",
        "    static int status[MAX_QUESTIONS];",
        f"    const {p}_value *soft_ptr[{max(len(soft), 1)}];",
        f"    const {p}_value *data_ptr[{max(len(data), 1)}];",
        f"    {store} value;",
        "    clock_t start;",
        "    double seconds;",
        '    scan("%ld", &n);',
        '    scan("%ld", &repeat);',
        "    if (n > MAX_QUESTIONS) return 2;",
        "    for (q = 0; q < n; ++q) {",
        '        scan("%d", &target[q]);',
        f'        for (k = 0; k < {len(code.evidence)}; ++k) scan("%d", &evidence[q][k]);',
        f"        for (k = 0; k < {len(soft)}; ++k) {{",
        '            scan("%d", &soft_given[q][k]);',
        "            if (soft_given[q][k]) {",
        "                for (j = 0; j < soft_card[k]; ++j) {",
        f'                    scan("{read}", &value);',
        f"                    soft_values[q][k][j] = ({p}_value)value;",
        "                }",
        "            }",
        "        }",
        f"        for (k = 0; k < {len(data)}; ++k) {{",
        "            for (j = 0; j < data_size[k]; ++j) {",
        f'                scan("{read}", &value);',
        f"                data_values[q][k][j] = ({p}_value)value;",
        "            }",
        "        }",
        "    }",
        "    start = clock();",
        "    for (r = 0; r < repeat; ++r) {",
        "        for (q = 0; q < n; ++q) {",
        f"            for (k = 0; k < {len(soft)}; ++k) {{",
        "                soft_ptr[k] = soft_given[q][k] ? soft_values[q][k] : NULL;",
        "            }",
        f"            for (k = 0; k < {len(data)}; ++k) data_ptr[k] = data_values[q][k];",
        f"            status[q] = {p}_posterior(target[q], evidence[q], soft_ptr, data_ptr,",
        "                out[q]);",
        "        }",
        "    }",
        "    seconds = (double)(clock() - start) / CLOCKS_PER_SEC;",
        "    for (q = 0; q < n; ++q) {",
        '        printf("%d", status[q]);',
        "        for (j = 0; j < states[target[q]]; ++j) {",
        f'            printf(" {write}", {cast}out[q][j]);',
        "        }",
        '        printf("\\n");',
        "    }",
        '    printf("ns_per_question %.1f\\n", 1e9 * seconds / (double)(n * repeat));',
        "    return 0;",
        "}",
        "",
    ]
    return "\n".join(lines)


@dataclass(frozen=True)
class DriverQuestion:
    """One question for :func:`run_driver`, numbers already in the C type (raw in Q)."""

    target: str
    evidence: Sequence[int]
    soft: Mapping[str, npt.ArrayLike]
    data: Mapping[str, npt.ArrayLike]


@dataclass(frozen=True)
class DriverResult:
    """Statuses and answers of :func:`run_driver`, and the time per question in C."""

    status: list[int]
    answers: list[FloatArray]
    ns_per_question: float


def run_driver(
    code: CSources,
    questions: Sequence[DriverQuestion],
    directory: str | Path,
    *,
    build: Sequence[str] = ("cc", "-O2"),
    emulator: Sequence[str] = (),
    repeat: int = 1,
) -> DriverResult:
    """Build :func:`driver` with ``build`` (a compiler command, e.g. a cross compiler) and
    run the questions through it (under ``emulator``, e.g. ``qemu-arm``), ``repeat`` times.

    Raises
    ------
    ConfigError
        The build fails, or more than :data:`MAX_QUESTIONS` questions.
    """
    if len(questions) > MAX_QUESTIONS:
        raise ConfigError(f"at most {MAX_QUESTIONS} questions per driver run")
    folder = Path(directory)
    _, c_file = code.write(folder)
    main = _io.write_text(folder / f"{code.prefix}_driver.c", driver(code))
    program = folder / f"{code.prefix}_driver"
    command = [*build, *STRICT_FLAGS, str(c_file), str(main), "-o", str(program)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise ConfigError(f"{' '.join(command)} failed:\n{done.stderr.strip()}")
    fixed = code.arith.q is not None
    words = [str(len(questions)), str(repeat)]
    for question in questions:
        words.append(str(code.targets.index(question.target)))
        words += [str(int(s)) for s in question.evidence]
        for v in code.soft:
            if v in question.soft:
                words.append("1")
                words += _numbers(question.soft[v], fixed)
            else:
                words.append("0")
        for v in code.data:
            words += _numbers(question.data[v], fixed)
    ran = subprocess.run(
        [*emulator, str(program)],
        input=" ".join(words),
        capture_output=True,
        text=True,
        check=False,
    )
    if ran.returncode != 0:
        raise ConfigError(f"the driver failed ({ran.returncode}): {ran.stderr.strip()}")
    lines = ran.stdout.strip().splitlines()
    status, answers = [], []
    for line in lines[:-1]:
        fields = line.split()
        status.append(int(fields[0]))
        answers.append(np.array([float(x) for x in fields[1:]]))
    return DriverResult(status, answers, float(lines[-1].split()[1]))


def _numbers(values: npt.ArrayLike, fixed: bool) -> list[str]:
    flat = np.asarray(values).reshape(-1)
    return [str(int(x)) for x in flat] if fixed else [repr(float(x)) for x in flat]


@dataclass(frozen=True)
class ObjectSize:
    """Bytes of a compiled object: code, constant data and RAM (static work arrays)."""

    code: int
    const: int
    ram: int
    undefined: tuple[str, ...]


def object_size(
    code: CSources,
    directory: str | Path,
    *,
    build: Sequence[str] = ("cc", "-O2"),
    tools: str = "",
) -> ObjectSize:
    """Compile the generated source alone (``-c``) and measure it with ``{tools}size -A``.

    ``code`` counts ``.text``, ``const`` ``.rodata*``, ``ram`` ``.data`` and ``.bss``;
    ``undefined`` lists the symbols it needs from libraries (``{tools}nm -u``), e.g. the
    compiler's 64-bit division helpers on a 32-bit core.
    """
    folder = Path(directory)
    _, c_file = code.write(folder)
    obj = folder / f"{code.prefix}.o"
    command = [*build, *STRICT_FLAGS, "-c", str(c_file), "-o", str(obj)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise ConfigError(f"{' '.join(command)} failed:\n{done.stderr.strip()}")
    listing = subprocess.run(
        [f"{tools}size", "-A", str(obj)], capture_output=True, text=True, check=True
    ).stdout
    sizes = {"code": 0, "const": 0, "ram": 0}
    for line in listing.splitlines():
        fields = line.split()
        if len(fields) < 2 or not fields[1].isdigit():
            continue
        section, size = fields[0], int(fields[1])
        if section.startswith(".text"):
            sizes["code"] += size
        elif section.startswith(".rodata"):
            sizes["const"] += size
        elif section.startswith((".data", ".bss")):
            sizes["ram"] += size
    names = subprocess.run(
        [f"{tools}nm", "-u", str(obj)], capture_output=True, text=True, check=True
    ).stdout
    undefined = tuple(line.split()[-1] for line in names.splitlines() if line.strip())
    return ObjectSize(sizes["code"], sizes["const"], sizes["ram"], undefined)
