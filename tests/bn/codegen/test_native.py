"""The generated code on the robot's instruction set: Cortex-M4 builds and emulated ARM runs."""

from __future__ import annotations

import os
import shutil
import subprocess

import numpy as np
import pytest
from tests.bn.codegen.conftest import bnlearn, engine_answer, needs_cc, pattern, random_question
from tests.bn.helpers import random_net

from bayesmap.bn.codegen import SoftNetwork, generate
from bayesmap.bn.codegen.native import DriverQuestion, object_size, run_driver

CORTEX_M4 = ("arm-none-eabi-gcc", "-Os", "-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=soft")
ARM_LINUX = ("arm-linux-gnueabihf-gcc", "-O1", "-static")

needs_m4 = pytest.mark.skipif(
    shutil.which("arm-none-eabi-gcc") is None,
    reason="no arm-none-eabi-gcc (Debian package gcc-arm-none-eabi)",
)
needs_arm = pytest.mark.skipif(
    shutil.which("arm-linux-gnueabihf-gcc") is None or shutil.which("qemu-arm") is None,
    reason="no arm-linux-gnueabihf-gcc and qemu-arm (gcc-arm-linux-gnueabihf, qemu-user)",
)


def _questions(net, code, rng, n):
    scale = code.arith.q.scale
    soft_net = SoftNetwork.build(net, code.soft)
    asked, expected = [], []
    while len(asked) < n:
        question = random_question(net, code, rng, scale)
        raw = {v: np.rint(x * scale).astype(np.int64) for v, x in question.soft.items()}
        asked.append(DriverQuestion(question.target, question.slots, raw, {}))
        expected.append(engine_answer(soft_net, code, question, str(code.arith.q)))
    return asked, expected


@needs_arm
@pytest.mark.parametrize(
    ("arith", "source"),
    [
        ("q16.16", "asia"),
        ("q8.24", "asia"),
        pytest.param("q8.24", "random", marks=pytest.mark.slow),
        pytest.param("q16.16", "random", marks=pytest.mark.slow),
    ],
)
def test_emulated_arm_matches_the_engine_bit_for_bit(tmp_path, arith, source):
    rng = np.random.default_rng(3)
    net = bnlearn("asia") if source == "asia" else random_net(21, n_vars=9, max_card=4)
    targets, evidence, soft = pattern(net, rng, n_evidence=4, n_soft=1)
    code = generate(net, targets, evidence, arith, soft=soft, name="onarm")
    asked, expected = _questions(net, code, rng, 40)
    result = run_driver(code, asked, tmp_path, build=ARM_LINUX, emulator=("qemu-arm",))
    assert result.status == [0] * len(asked)
    for got, want in zip(result.answers, expected, strict=True):
        np.testing.assert_array_equal(got.astype(np.int64), want)


@needs_cc
def test_the_driver_on_this_machine_agrees_with_ctypes(tmp_path):
    rng = np.random.default_rng(4)
    net = random_net(8, n_vars=8)
    targets, evidence, soft = pattern(net, rng, n_evidence=3, n_soft=1)
    code = generate(net, targets, evidence, "q8.24", soft=soft, name="here")
    asked, expected = _questions(net, code, rng, 30)
    result = run_driver(code, asked, tmp_path, build=("cc", "-O0"), repeat=2)
    for got, want in zip(result.answers, expected, strict=True):
        np.testing.assert_array_equal(got.astype(np.int64), want)
    assert result.ns_per_question > 0


@needs_m4
@pytest.mark.parametrize("arith", ["q16.16", "float"])
def test_cortex_m4_build_needs_no_libm_and_reports_its_memory(tmp_path, arith):
    net = bnlearn("asia")
    code = generate(net, ["lung", "bronc"], ["xray", "dysp", "smoke"], arith, soft=["tub"])
    flags = (
        CORTEX_M4
        if arith != "float"
        else (*CORTEX_M4[:-1], "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16")
    )
    size = object_size(code, tmp_path, build=flags, tools="arm-none-eabi-")
    assert size.code > 0 and size.const > 0 and size.ram > 0
    # only the compiler's own helpers (64-bit division on a 32-bit core) may be needed
    assert all(name.startswith("__aeabi_") for name in size.undefined), size.undefined


def _m32_compiles() -> bool:
    if shutil.which("gcc") is None:
        return False
    probe = subprocess.run(
        ["gcc", "-m32", "-ffreestanding", "-x", "c", "-c", "-", "-o", os.devnull],
        input="#include <stdint.h>\nint32_t f(void) { return 0; }\n",
        capture_output=True,
        text=True,
        check=False,
    )
    return probe.returncode == 0


@pytest.mark.skipif(not _m32_compiles(), reason="gcc cannot compile for -m32 here")
@pytest.mark.parametrize("arith", ["q8.24", "float"])
def test_the_code_builds_for_32_bit_x86(tmp_path, arith):
    """Compile only (-ffreestanding: no 32-bit libc is needed to build it; running it here
    would need Debian's gcc-multilib, which cannot be installed beside the ARM compilers)."""
    net = random_net(4, n_vars=8, max_card=4)
    code = generate(net, ["X7", "X6"], ["X0", "X3", "X5"], arith, soft=["X2"])
    size = object_size(code, tmp_path, build=("gcc", "-m32", "-ffreestanding", "-O1"))
    assert size.code > 0 and size.ram > 0
