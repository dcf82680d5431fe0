"""Fixed-point (Q-format) inference, as on the rover's embedded computer (Post et al. 2016 §3.2).

A Q\\ *I*.\\ *F* number is a signed integer of ``I + F`` bits read as ``raw / 2**F``
(Q16.16: 32 bits, resolution 2⁻¹⁶ ≈ 1.5e-5, range ±32768). The queries run on integer
numpy arrays exactly as a C implementation on a 32-bit core with a 64-bit multiply would:

- CPT entries are rounded to the nearest ``raw`` (1.0 saturates to the largest value);
- a product is ``(a·b + 2^(F−1)) >> F`` in int64 (round half up; all values are ≥ 0);
- sums and maxima of raw values are exact; any value beyond the word raises
  :class:`~bayesmap.errors.ConfigError` (use more integer bits);
- the normalisation is the integer division ``((u << F) + S/2) // S``.

Each result carries a rigorous bound on its error against exact real arithmetic,
propagated entry by entry through the same contraction (a running error analysis):

- quantisation: ``|x̂ − x|`` of each CPT entry, exactly;
- product: ``|âb̂ − ab| ≤ (|â|+α)β + (|b̂|+β)α + αβ``, plus the exact rounding of the shift;
- sum: errors add; max: the largest error of the reduced entries;
- normalisation: ``|û_i/Ŝ − u_i/S| ≤ (δ_i + δ_S)/Ŝ`` with ``δ_S = Σ_i δ_i``, plus the
  rounding of the division.

The bound grows with the number of factors and shrinks with the probability of the
evidence Ŝ: evidence far in the tails makes fixed point useless, and the bound says so.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray, IntArray
from bayesmap.errors import ConfigError, InputError

_PATTERN = re.compile(r"^\s*[Qq](\d+)\.(\d+)\s*$")


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
        match = _PATTERN.match(str(text))
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

    def quantise(self, values: npt.ArrayLike) -> Fixed:
        """Round non-negative reals to raw values, with the exact rounding error."""
        x = np.asarray(values, dtype=np.float64)
        raw = np.minimum(np.rint(x * self.scale), self.max_raw).astype(np.int64)
        if np.any(x * self.scale > self.max_raw + 1):
            raise ConfigError(f"value {float(x.max())} does not fit in {self}")
        return Fixed(raw, np.abs(raw / self.scale - x))

    def to_float(self, raw: IntArray) -> FloatArray:
        """Real values of raw integers."""
        return np.asarray(raw / self.scale)


class Fixed(NamedTuple):
    """Raw fixed-point values and a bound on each one's absolute error (in real units)."""

    raw: IntArray
    error: FloatArray


@dataclass(frozen=True)
class FixedAlgebra:
    """Sum- or max-product on :class:`Fixed` operands (for :mod:`~bayesmap.bn.elimination`)."""

    q: QFormat
    reduce: str = "sum"

    def shape(self, operand: Fixed) -> tuple[int, ...]:
        """Shape of the raw array."""
        return tuple(operand.raw.shape)

    def rearrange(self, operand: Fixed, axes: Sequence[int], shape: Sequence[int]) -> Fixed:
        """Transpose and reshape both arrays."""
        return Fixed(
            operand.raw.transpose(axes).reshape(shape), operand.error.transpose(axes).reshape(shape)
        )

    def multiply(self, a: Fixed, b: Fixed) -> Fixed:
        """Rounded product ``(a·b + 2^(F−1)) >> F`` with its propagated error bound."""
        f = self.q.frac_bits
        exact = a.raw * b.raw
        raw = (exact + (1 << (f - 1))) >> f
        self._check(raw)
        rounding = np.abs(exact - (raw << f)) / float(1 << (2 * f))
        av, bv = self.q.to_float(a.raw), self.q.to_float(b.raw)
        error = (av + a.error) * b.error + (bv + b.error) * a.error + a.error * b.error + rounding
        return Fixed(raw, error)

    def eliminate(self, operand: Fixed, n_keep: int) -> tuple[Fixed, IntArray | None]:
        """Sum (exact) or max of the trailing axes."""
        raw = operand.raw.reshape(*operand.raw.shape[:n_keep], -1)
        error = operand.error.reshape(raw.shape)
        if self.reduce == "sum":
            total = raw.sum(axis=-1)
            self._check(total)
            return Fixed(total, error.sum(axis=-1)), None
        argmax = np.argmax(raw, axis=-1)
        best = np.take_along_axis(raw, argmax[..., np.newaxis], axis=-1)[..., 0]
        return Fixed(best, error.max(axis=-1)), argmax

    def _check(self, raw: IntArray) -> None:
        if raw.size and int(raw.max()) > self.q.max_raw:
            raise ConfigError(
                f"fixed-point overflow: an intermediate value reached "
                f"{int(raw.max()) / self.q.scale:.6g}, beyond the range of {self.q}; "
                "use a format with more integer bits"
            )


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
    """Divide by the sum over ``axes`` in integer arithmetic, with the error bound."""
    total = result.raw.sum(axis=axes, keepdims=True)
    if np.any(total <= 0):
        raise InputError(
            f"{what}: the probability of the evidence is zero or underflows {q} "
            f"(resolution {q.resolution:.3g}); use more fractional bits or float arithmetic"
        )
    raw = ((result.raw << q.frac_bits) + total // 2) // total
    s_hat = q.to_float(total)
    delta_s = result.error.sum(axis=axes, keepdims=True)
    exact_ratio = result.raw / total
    rounding = np.abs(q.to_float(raw) - exact_ratio)
    bound = (result.error + delta_s) / s_hat + rounding
    return FixedResult(q, raw, q.to_float(raw), np.asarray(bound))


def ratio(q: QFormat, numerator: Fixed, denominator: Fixed, what: str) -> FixedResult:
    """``numerator / denominator`` (with ``0 ≤ numerator ≤ denominator`` in exact arithmetic).

    Bound: ``|n̂/d̂ − n/d| ≤ (δ_n + δ_d)/d̂`` plus the rounding of the integer division.
    """
    if np.any(denominator.raw <= 0):
        raise InputError(
            f"{what}: the probability of the evidence is zero or underflows {q} "
            f"(resolution {q.resolution:.3g}); use more fractional bits or float arithmetic"
        )
    raw = ((numerator.raw << q.frac_bits) + denominator.raw // 2) // denominator.raw
    rounding = np.abs(q.to_float(raw) - numerator.raw / denominator.raw)
    bound = (numerator.error + denominator.error) / q.to_float(denominator.raw) + rounding
    return FixedResult(q, raw, q.to_float(raw), np.asarray(bound))
