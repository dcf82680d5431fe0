"""Fixed-point (Q-format) inference, as on the rover's embedded computer (Post et al. 2016 §3.2).

A Q\\ *I*.\\ *F* number is a signed integer of ``I + F`` bits read as ``raw / 2**F``
(Q16.16: 32 bits, resolution 2⁻¹⁶ ≈ 1.5e-5, range ±32768). CPT entries are stored in that
format (rounded to the nearest ``raw``; 1.0 saturates to the largest value when ``I = 1``) and
every answer is returned in it. In between, the queries run on integer numpy arrays as an
embedded C implementation with a 64-bit accumulator would, in **block floating point**:

- each intermediate factor is a block of integer mantissas sharing one integer exponent
  (``value = raw · 2**exp``; a batch keeps one exponent per case);
- a product multiplies the mantissas exactly in int64 and adds the exponents; a sum or
  maximum of mantissas in one block is exact;
- after every product and every elimination the block is renormalised by a power-of-two
  shift so that its largest entry fills the ``I + F − 1`` mantissa bits of the word: a
  right shift rounds half up (``(m + 2^(s−1)) >> s``, saturating at the word's largest
  value), a left shift is exact, and the shift is added to the exponent. Nothing
  underflows the format's resolution and nothing overflows its range, however many factors
  a question multiplies;
- the exponent cancels in the final normalisation, the integer division
  ``((u << F) + S/2) // S`` of mantissas of one block (or, for MAP, of two scalars, with
  the exponent difference applied as a shift).

Each result carries a rigorous bound on its error against exact real arithmetic,
propagated entry by entry through the same contraction (a running error analysis, kept in
units of each block's exponent so that it never underflows either):

- quantisation: ``|x̂ − x|`` of each CPT entry, exactly;
- product: ``|âb̂ − ab| ≤ âβ + b̂α + αβ`` (``α, β`` the operands' bounds), plus the exact
  rounding of the renormalising shift;
- sum: bounds add; max: the largest bound of the reduced entries;
- normalisation ``p̂_i = û_i/Ŝ``: ``|p̂_i − p_i| ≤ ((1 − p̂_i)δ_i + p̂_i(δ_S − δ_i)) / (Ŝ − δ_S)``
  with ``δ_S = Σ_j δ_j``, plus the rounding of the division; a ratio ``n̂/d̂`` of two
  scalars: ``(α_n + r̂·α_d) / (d̂ − α_d)`` plus rounding. A bound is never above
  ``max(p̂, 1 − p̂)`` (the answer is a probability), and gets ``2⁻⁵⁰`` added for the
  float64 evaluation of the bound itself.

The derivation is in ``docs/bn.md``. The bound grows with the number of factors and with
``1/P(e)``: evidence far in the tails makes fixed point useless, and the bound says so.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray, IntArray
from bayesmap.errors import ConfigError, InputError

_PATTERN = r"^\s*[Qq](\d+)\.(\d+)\s*$"
"""A Q-format's name; compiled on first use (and kept in :mod:`re`'s cache)."""
_SLACK = 2.0**-50
"""Added to every bound: the bound itself is evaluated in float64."""


@dataclass(frozen=True)
class QFormat:
    """A signed Q\\ *I*.\\ *F* fixed-point format of ``I + F ≤ 32`` bits.

    Parameters
    ----------
    int_bits
        Integer bits *I*, including the sign bit (≥ 1).
    frac_bits
        Fractional bits *F* (≥ 1).

    Examples
    --------
    >>> QFormat.parse("Q16.16").resolution
    1.52587890625e-05
    """

    int_bits: int = 16
    frac_bits: int = 16

    def __post_init__(self) -> None:
        if self.int_bits < 1 or self.frac_bits < 1 or self.int_bits + self.frac_bits > 32:
            raise ConfigError(
                f"fixed-point format Q{self.int_bits}.{self.frac_bits} is not supported: "
                "need at least 1 integer bit (the sign), 1 fractional bit and at most 32 "
                "bits in all (e.g. Q16.16, Q8.24, Q2.30)"
            )

    @classmethod
    def parse(cls, text: str | QFormat) -> QFormat:
        """Parse ``"Q16.16"``, ``"Q8.24"``, ... (or pass a :class:`QFormat` through)."""
        if isinstance(text, QFormat):
            return text
        match = re.match(_PATTERN, str(text))
        if match is None:
            raise ConfigError(
                f"cannot read fixed-point format {text!r}; write Q<integer bits>.<fraction "
                "bits>, e.g. Q16.16 or Q8.24"
            )
        return cls(int(match.group(1)), int(match.group(2)))

    def __str__(self) -> str:
        return f"Q{self.int_bits}.{self.frac_bits}"

    @property
    def scale(self) -> int:
        """``2**F``: the raw value of 1.0."""
        return 1 << self.frac_bits

    @property
    def resolution(self) -> float:
        """Smallest step ``2**-F``."""
        return 1.0 / self.scale

    @property
    def max_raw(self) -> int:
        """Largest raw value ``2**(I+F-1) - 1``."""
        return (1 << (self.int_bits + self.frac_bits - 1)) - 1

    @property
    def mantissa_bits(self) -> int:
        """Bits of an intermediate mantissa: the word without its sign, ``I + F − 1``."""
        return self.int_bits + self.frac_bits - 1

    def quantise(self, values: npt.ArrayLike, *, case_axis: bool = False) -> Fixed:
        """Round non-negative reals to raw values, with the exact rounding error.

        With ``case_axis``, axis 0 indexes evidence cases, each its own block.
        """
        x = np.asarray(values, dtype=np.float64)
        scaled = x * self.scale
        if np.any(scaled > self.max_raw + 1):
            raise ConfigError(f"value {float(x.max())} does not fit in {self}")
        raw = np.minimum(np.rint(scaled), self.max_raw).astype(np.int64)
        shape = [1] * x.ndim
        if case_axis:
            shape[0] = x.shape[0]
        exp = np.full(shape, -self.frac_bits, dtype=np.int64)
        return Fixed(raw, exp, np.abs(raw - scaled))

    def to_float(self, raw: IntArray) -> FloatArray:
        """Real values of raw integers."""
        return np.asarray(raw / self.scale)


class Fixed(NamedTuple):
    """A block-floating-point factor: ``raw · 2**exp``, with an error bound per entry.

    ``exp`` has the dimensions of ``raw``, each of size 1 (shared along that axis) or of
    ``raw``'s size (a batch's case axis); ``error`` bounds ``|raw·2**exp − exact|`` in units
    of ``2**exp``.
    """

    raw: IntArray
    exp: IntArray
    error: FloatArray

    def transpose(self, axes: Sequence[int]) -> Fixed:
        """Permute the axes of all three arrays."""
        return Fixed(self.raw.transpose(axes), self.exp.transpose(axes), self.error.transpose(axes))


@dataclass(frozen=True)
class FixedAlgebra:
    """Sum- or max-product on :class:`Fixed` blocks (for :mod:`~bayesmap.bn.elimination`)."""

    q: QFormat
    reduce: str = "sum"

    def shape(self, operand: Fixed) -> tuple[int, ...]:
        """Shape of the raw array."""
        return tuple(operand.raw.shape)

    def rearrange(self, operand: Fixed, axes: Sequence[int], shape: Sequence[int]) -> Fixed:
        """Transpose, then reshape to ``shape`` (which only inserts unit axes)."""
        moved = operand.transpose(axes)
        sizes, exp = moved.raw.shape, moved.exp
        exp_shape, j = [], 0
        for size in shape:
            if j < len(sizes) and size == sizes[j]:
                exp_shape.append(exp.shape[j])
                j += 1
            else:
                exp_shape.append(1)
        return Fixed(moved.raw.reshape(shape), exp.reshape(exp_shape), moved.error.reshape(shape))

    def multiply(self, a: Fixed, b: Fixed) -> Fixed:
        """Exact product of the mantissas, exponents added, then renormalised."""
        error = a.raw * b.error + b.raw * a.error + a.error * b.error
        return renormalise(self.q, Fixed(a.raw * b.raw, a.exp + b.exp, error))

    def eliminate(self, operand: Fixed, n_keep: int) -> tuple[Fixed, IntArray | None]:
        """Sum (exact) or max of the trailing axes, then renormalised."""
        raw = operand.raw.reshape(*operand.raw.shape[:n_keep], -1)
        error = operand.error.reshape(raw.shape)
        exp = operand.exp.reshape(operand.exp.shape[:n_keep])
        if self.reduce == "sum":
            return renormalise(self.q, Fixed(raw.sum(axis=-1), exp, error.sum(axis=-1))), None
        argmax = np.argmax(raw, axis=-1)
        best = np.take_along_axis(raw, argmax[..., np.newaxis], axis=-1)[..., 0]
        return renormalise(self.q, Fixed(best, exp, error.max(axis=-1))), argmax


def renormalise(q: QFormat, block: Fixed) -> Fixed:
    """Shift each block so its largest entry (or error) fills ``q.mantissa_bits`` bits.

    A right shift by ``s`` rounds half up, ``(m + 2^(s−1)) >> s``, and its exact rounding
    error is added to the bound; a left shift is exact.
    """
    raw, exp, error = block
    shared = tuple(k for k in range(raw.ndim) if exp.shape[k] == 1)
    size = np.maximum(raw.max(axis=shared, keepdims=True), error.max(axis=shared, keepdims=True))
    _, bits = np.frexp(size.astype(np.float64))  # ≥ the bit length of the integer part
    shift = np.where(size > 0, bits - q.mantissa_bits, 0).astype(np.int64)
    down = np.maximum(shift, 0)
    shifted = raw << np.minimum(np.maximum(-shift, 0), 62)  # only an all-zero block goes past 31
    rounded = np.minimum((shifted + ((np.int64(1) << down) >> 1)) >> down, q.max_raw)
    rounding = np.abs(shifted - (rounded << down)) / np.ldexp(1.0, down)
    return Fixed(rounded, exp + shift, np.ldexp(error, -shift) + rounding)


@dataclass(frozen=True)
class FixedResult:
    """A fixed-point answer.

    Attributes
    ----------
    q
        The format.
    raw
        Raw integers of the answer (probabilities times ``2**F``).
    values
        The same as reals.
    bound
        Guaranteed bound on ``|values − exact|``, entry by entry.
    """

    q: QFormat
    raw: IntArray
    values: FloatArray
    bound: FloatArray


def normalise(q: QFormat, result: Fixed, axes: tuple[int, ...], what: str) -> FixedResult:
    """Divide by the sum over ``axes`` (one block) in integer arithmetic, with the bound."""
    total = result.raw.sum(axis=axes, keepdims=True)
    if np.any(total <= 0):
        raise InputError(
            f"{what}: the probability of the evidence is zero or underflows {q} "
            f"(resolution {q.resolution:.3g}); use more fractional bits or float arithmetic"
        )
    raw = np.minimum(((result.raw << q.frac_bits) + total // 2) // total, q.max_raw)
    p_hat = result.raw / total
    delta = result.error
    delta_s = delta.sum(axis=axes, keepdims=True)
    spread = (1.0 - p_hat) * delta + p_hat * (delta_s - delta)
    with np.errstate(divide="ignore"):
        carried = np.where(total > delta_s, spread / np.maximum(total - delta_s, 1e-300), np.inf)
    values = q.to_float(raw)
    bound = _finish(values, carried + np.abs(values - p_hat))
    return FixedResult(q, raw, values, bound)


def ratio(q: QFormat, numerator: Fixed, denominator: Fixed, what: str) -> FixedResult:
    """``numerator / denominator`` of two scalars (``0 ≤ n ≤ d`` in exact arithmetic).

    The exponent difference becomes a shift of the integer division (Python integers, so
    it cannot overflow). Bound: ``|n̂/d̂ − n/d| ≤ (α_n + r̂·α_d)/(d̂ − α_d)``, ``r̂ = n̂/d̂``,
    plus the rounding of the division.
    """
    n, d = int(numerator.raw), int(denominator.raw)
    if d <= 0:
        raise InputError(
            f"{what}: the probability of the evidence is zero or underflows {q} "
            f"(resolution {q.resolution:.3g}); use more fractional bits or float arithmetic"
        )
    k = q.frac_bits + int(numerator.exp) - int(denominator.exp)
    if k >= 0:
        raw = ((n << k) + d // 2) // d
    else:
        raw = (n + ((d << -k) >> 1)) // (d << -k)
    raw = min(raw, q.max_raw)
    gap = int(numerator.exp) - int(denominator.exp)
    r_hat = math.ldexp(n / d, gap)
    rel_n = math.ldexp(float(numerator.error) / d, gap)
    rel_d = float(denominator.error) / d
    carried = (rel_n + r_hat * rel_d) / (1.0 - rel_d) if rel_d < 1.0 else math.inf
    value = raw / q.scale
    bound = _finish(np.asarray(value), np.asarray(carried + abs(value - r_hat)))
    return FixedResult(q, np.asarray(raw, dtype=np.int64), np.asarray(value), bound)


def _finish(values: FloatArray, bound: FloatArray) -> FloatArray:
    """Cap a probability's bound at ``max(v, 1 − v)`` and add the float64 slack."""
    return np.asarray(np.minimum(bound, np.maximum(values, 1.0 - values)) + _SLACK)


def constant(q: QFormat, values: npt.ArrayLike) -> FixedResult:
    """Known probabilities (e.g. of observed variables) in ``q``; the bound is the rounding."""
    x = np.asarray(values, dtype=np.float64)
    raw = np.minimum(np.rint(x * q.scale), q.max_raw).astype(np.int64)
    got = q.to_float(raw)
    return FixedResult(q, raw, got, np.abs(got - x) + _SLACK)
