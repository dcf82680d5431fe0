"""The specular-reading filter of the ICINCO 2007 fragment as one stateful object.

:class:`SpecularFilter` takes rings one at a time (:meth:`~SpecularFilter.process`) or a
batch of consecutive rings (:meth:`~SpecularFilter.process_many`, same verdicts) and runs
the switchable stages Acceptability → Agreeability → Trait Verification, recording every
rejection with its stage and reason. Its accumulated state (the local view ``L``, the recent
echo points, the path length, the rejection log) lives in attributes ending in ``_`` (DESIGN
convention 6).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from enum import IntEnum
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.errors import ConfigError, InputError
from bayesmap.sonar.bottom_up import acceptability, agreeability
from bayesmap.sonar.geometry import SonarGeometry
from bayesmap.sonar.traits import fit_traits, point_segment_distance
from bayesmap.sonar.verification import (
    ConeHits,
    TVReason,
    certainty,
    coincide,
    cone_hits,
    equivalent,
    extend_segments,
    reconcile,
)

__all__ = ["Rejection", "RingVerdict", "SpecularFilter", "Stage"]


class Stage(IntEnum):
    """The stage that discarded a reading (``ACCEPTED``: none did)."""

    ACCEPTED = 0
    ACCEPTABILITY = 1
    AGREEABILITY = 2
    TRAIT_VERIFICATION = 3
    MAP_VERDICT = 4
    """After the pass, by the map of the whole log (:mod:`bayesmap.sonar.map_verdict`)."""
    TOO_CLOSE = 5
    """Below the ring's min range (0, a negative code, REP 117's −inf): never mapped
    (:func:`bayesmap.sonar.pipeline.map_log`)."""


_STAGE_REASONS = {
    Stage.ACCEPTABILITY: "obstacle reading outside the bounds from both neighbours",
    Stage.AGREEABILITY: "free-space reading and neither neighbour reports free space",
}
_TV_REASONS = {
    TVReason.UNSUPPORTED_FLAGGED: "flagged and no equivalent trait in L",
    TVReason.UNSUPPORTED_UNCERTAIN: "certainty below threshold and no equivalent trait in L",
    TVReason.CONTRADICTS_L: "claims free space through a trait of L",
    TVReason.FLAGGED_UNCERTAIN: "coincides with L but flagged and below the certainty threshold",
}
_TV_CODE = int(Stage.TRAIT_VERIFICATION) - 1
"""Rejection code of Trait Verification's reason ``TVReason`` ``v``: ``v + _TV_CODE``."""
_REJECTIONS: dict[int, tuple[Stage, str]] = {
    **{int(stage): (stage, reason) for stage, reason in _STAGE_REASONS.items()},
    **{int(v) + _TV_CODE: (Stage.TRAIT_VERIFICATION, text) for v, text in _TV_REASONS.items()},
}
"""What each code of ``SpecularFilter.rejection_codes_`` means: (stage, reason)."""
_BLOCKS_MERGED = 256
"""The rejection log's latest blocks (one per call) are merged into one this many at a time."""
_COUNTED = {
    name: [code for code, (stage, _) in _REJECTIONS.items() if stage.name.lower() == name]
    for name in ("acceptability", "agreeability", "trait_verification")
}


@dataclass(frozen=True)
class Rejection:
    """One discarded reading: ring number, transducer, stage and reason."""

    ring: int
    sensor: int
    stage: Stage
    reason: str


class RingVerdict(NamedTuple):
    """The filter's decision on one ring.

    Attributes
    ----------
    accepted
        ``(n,)`` readings to pass to the map.
    flagged
        ``(n,)`` readings flagged as possibly erroneous by Acceptability/Agreeability.
    stage
        ``(n,)`` :class:`Stage` that discarded each reading.
    free_limit
        ``(n,)`` distance [m] from each transducer beyond which its reading's cone should
        write no free space (``inf``: no limit). Set with ``keep_supported_echoes`` for an
        echo kept on a trait of ``L`` while a nearer trait of ``L`` crosses its cone: the
        free space stops in front of that trait instead of carving through it.
    """

    accepted: BoolArray
    flagged: BoolArray
    stage: IntArray
    free_limit: FloatArray


class SpecularFilter:
    """Reject specular sonar readings before they reach the map (ICINCO 2007, p. 494).

    Parameters
    ----------
    geometry
        The ring (angles, cone width, max range, sigma).
    acceptability, agreeability, trait_verification
        Which stages run.
    critical_angle
        Largest incidence off a wall's normal that still echoes [rad] (Acceptability bounds).
    k_sigma
        The sensor's "natural error range" in standard deviations.
    tilts
        Wall orientations sampled by Acceptability.
    window
        Rings whose accepted echo points, with the current ones, form ``V``.
    split_tolerance, min_points, max_gap
        Split-and-merge parameters [m], [points], [m].
    certainty_threshold
        Readings behind ``V`` traits below this certainty need support from ``L``.
    match_angle, match_offset
        Trait equivalence tolerances [rad], [m].
    perceptual_length
        One perceptual length [m] (default: the max range); ``L`` keeps the traits seen
        over the last four of them along the path, and holds "enough state" once the
        robot has travelled four.
    extension
        How far ``L``'s traits are extended at both ends towards the robot [m].
    margin
        How far before a reading's range an ``L`` trait must cross its axis to contradict it [m].
    min_length, min_spacing
        Trait hygiene: shortest trait [m], and the spacing [m] below which echo points count
        as one (a standing robot repeats its echoes).
    footprint
        Radius of the robot [m]: a trait of ``L`` that comes this close to a pose is not a
        wall (the robot stood there) and is removed, and no such trait enters ``L``.
    pass_limit
        A trait of ``L`` that this many echo readings (from different rings, not flagged by
        the bottom-up stages) see through, more than ``margin`` beyond it, is removed.
    no_echo_spread
        A no-echo reading contradicts ``L`` when a trait crosses its axis or the rays this far
        [rad] either side of it within the max range (0: the axis only; ``None``: the
        cone's edges, half the beam width).
    keep_supported_echoes
        An echo whose range agrees with ``L`` is not contradicted by another trait in front
        of it; its free space stops before that trait (``RingVerdict.free_limit``). Off in
        the bare filter; the default pipeline turns it on with ``static_span`` 0.5 m
        (docs/sonar.md, *Support / contradiction*).
    static_span
        With ``keep_supported_echoes``, only a trait of ``L`` that looks like static
        structure keeps an echo that agrees with it, and stops a kept echo's free space: one
        re-seen over at least this much path [m] since it entered ``L``, i.e. seen from
        several robot positions, so not a person who walked through (0: every trait).
    l_in_case_a
        Let ``L`` (its traits within the max range) speak in case A too: a contradicted
        no-echo reading is discarded, flagged or not (its cone crosses a trait of ``L``
        that its axis does not meet head-on: a wall too oblique to echo), and with
        ``keep_supported_echoes`` a kept echo's free space stops before a static trait in
        front, as in case B. The fragment's case A discards only flagged or uncertain
        readings and ignores ``L`` otherwise.

    Attributes
    ----------
    rings_
        Rings processed.
    path_
        Distance travelled [m].
    l_segments_, l_first_, l_seen_, l_passes_
        ``L``: ``(k, 4)`` traits [m], the path positions [m] where each was first and last
        seen, and how many rings' echoes have passed through it.
    rejection_codes_
        ``(rings_, n)`` ``int8``: why the filter discarded each reading of each ring so far
        (0: kept; 1 Acceptability; 2 Agreeability; 3–6 Trait Verification, its
        ``TVReason`` plus 2). One byte a reading, the compact form of ``rejections_``.
    rejections_
        Every rejection, in order, as :class:`Rejection` records (built from
        ``rejection_codes_`` when asked for).
    counts_
        Rejections per stage name.
    """

    def __init__(
        self,
        geometry: SonarGeometry,
        *,
        acceptability: bool = True,
        agreeability: bool = True,
        trait_verification: bool = True,
        critical_angle: float = math.radians(15.0),
        k_sigma: float = 3.0,
        tilts: int = 9,
        window: int = 5,
        split_tolerance: float = 0.1,
        min_points: int = 3,
        max_gap: float = 1.0,
        certainty_threshold: float = 0.5,
        match_angle: float = math.radians(10.0),
        match_offset: float = 0.2,
        perceptual_length: float | None = None,
        extension: float = 1.0,
        margin: float = 0.3,
        min_length: float = 0.3,
        min_spacing: float = 0.05,
        footprint: float = 0.25,
        pass_limit: int = 3,
        no_echo_spread: float | None = 0.0,
        keep_supported_echoes: bool = False,
        static_span: float = 0.0,
        l_in_case_a: bool = False,
    ) -> None:
        if not 0.0 < critical_angle < math.pi / 2:
            raise ConfigError(f"critical_angle must be in (0, pi/2) rad, got {critical_angle}")
        if not 0.0 <= certainty_threshold <= 1.0:
            raise ConfigError(f"certainty_threshold must be in [0, 1], got {certainty_threshold}")
        limits = {  # name: (value, smallest allowed, whether the smallest is allowed)
            "k_sigma": (k_sigma, 0.0, False),
            "tilts": (tilts, 2, True),
            "window": (window, 1, True),
            "min_points": (min_points, 2, True),
            "split_tolerance": (split_tolerance, 0.0, False),
            "max_gap": (max_gap, 0.0, False),
            "match_angle": (match_angle, 0.0, False),
            "match_offset": (match_offset, 0.0, False),
            "extension": (extension, 0.0, True),
            "margin": (margin, 0.0, True),
            "min_length": (min_length, 0.0, True),
            "min_spacing": (min_spacing, 0.0, True),
            "footprint": (footprint, 0.0, True),
            "pass_limit": (pass_limit, 1, True),
            "no_echo_spread": (
                geometry.beam_width / 2.0 if no_echo_spread is None else no_echo_spread,
                0.0,
                True,
            ),
            "static_span": (static_span, 0.0, True),
        }
        for name, (value, low, closed) in limits.items():
            if not (value >= low if closed else value > low):
                raise ConfigError(
                    f"SpecularFilter {name} must be {'>=' if closed else '>'} {low}, got {value!r}"
                )
        self.geometry = geometry
        self.stages = {
            Stage.ACCEPTABILITY: acceptability,
            Stage.AGREEABILITY: agreeability,
            Stage.TRAIT_VERIFICATION: trait_verification,
        }
        self.critical_angle = critical_angle
        self.k_sigma = k_sigma
        self.tilts = tilts
        self.window = window
        self.split_tolerance = split_tolerance
        self.min_points = min_points
        self.max_gap = max_gap
        self.certainty_threshold = certainty_threshold
        self.match_angle = match_angle
        self.match_offset = match_offset
        self.perceptual_length = (
            geometry.max_range if perceptual_length is None else perceptual_length
        )
        if not self.perceptual_length > 0:
            raise ConfigError(f"perceptual_length must be positive metres, got {perceptual_length}")
        self.extension = extension
        self.margin = margin
        self.min_length = min_length
        self.min_spacing = min_spacing
        self.footprint = footprint
        self.pass_limit = pass_limit
        self.no_echo_spread = (
            geometry.beam_width / 2.0 if no_echo_spread is None else float(no_echo_spread)
        )
        self.keep_supported_echoes = keep_supported_echoes
        self.static_span = static_span
        self.l_in_case_a = l_in_case_a
        self.left, self.right = geometry.neighbours()
        self.rings_ = 0
        self.path_ = 0.0
        self.last_pose_: FloatArray | None = None
        self.points_: deque[FloatArray] = deque(maxlen=window - 1)
        self.l_segments_: FloatArray = np.zeros((0, 4))
        self.l_first_: FloatArray = np.zeros(0)
        self.l_seen_: FloatArray = np.zeros(0)
        self.l_passes_: IntArray = np.zeros(0, dtype=np.int64)
        self._rejection_blocks: list[npt.NDArray[np.int8]] = []  # merged, then the latest
        self._merged = 0
        self.counts_: dict[str, int] = dict.fromkeys(_COUNTED, 0)

    @property
    def rejection_codes_(self) -> npt.NDArray[np.int8]:
        """``(rings_, n)`` rejection code of every reading so far (see the class)."""
        if not self._rejection_blocks:
            return np.zeros((0, self.geometry.n), dtype=np.int8)
        if len(self._rejection_blocks) > 1:
            self._rejection_blocks = [np.concatenate(self._rejection_blocks)]
            self._merged = 1
        return self._rejection_blocks[0]

    @property
    def rejections_(self) -> list[Rejection]:
        """Every rejection so far, in order of ring and transducer."""
        codes = self.rejection_codes_
        rings, sensors = codes.nonzero()
        return [
            Rejection(ring, sensor, *_REJECTIONS[code])
            for ring, sensor, code in zip(
                rings.tolist(), sensors.tolist(), codes[rings, sensors].tolist(), strict=True
            )
        ]

    @property
    def enough_state(self) -> bool:
        """Whether ``L`` spans four perceptual lengths of path (the fragment's case B)."""
        return self.path_ >= 4.0 * self.perceptual_length

    def process(self, pose: npt.ArrayLike, ranges: npt.ArrayLike) -> RingVerdict:
        """Judge one ring of ``ranges`` [m] taken at ``pose`` ``(x, y, heading)``.

        Returns
        -------
        :class:`RingVerdict`; the rejections are also logged (``rejection_codes_``).
        """
        p, r = self.geometry.one_ring(pose, ranges)
        verdict = self.process_many(p[None], r[None])
        return RingVerdict(*(field[0] for field in verdict))

    def process_many(self, poses: npt.ArrayLike, ranges: npt.ArrayLike) -> RingVerdict:
        """Judge ``m`` consecutive rings: ``ranges`` ``(m, n)`` [m] taken at ``poses`` ``(m, 3)``.

        The same verdicts as :meth:`process` ring by ring. What does not depend on ``L`` and
        ``V`` (the transducers' positions, Acceptability and Agreeability, which compare a
        reading only with its neighbours in the same ring) is computed for all rings at once;
        Trait Verification then runs ring by ring, in order, since each ring's verdict
        changes ``L`` and ``V`` for the next.

        Returns
        -------
        :class:`RingVerdict` with ``(m, n)`` arrays; the rejections are also logged
        (``rejection_codes_``).
        """
        geometry = self.geometry
        n = geometry.n
        p = np.asarray(poses, dtype=np.float64)
        r = np.asarray(ranges, dtype=np.float64)
        if r.ndim != 2 or r.shape[1] != n or len(r) != len(p):
            raise InputError(f"a ring has {n} readings, got {len(p)} poses and ranges {r.shape}")
        if np.any(np.isnan(r)) or np.any(r < 0):
            bad = int(np.flatnonzero(np.any(np.isnan(r) | (r < 0), axis=1))[0])
            raise InputError(
                f"sonar ranges must be non-negative metres (inf = no echo), got {r[bad]}"
            )
        centres, axis = geometry.sensors_many(p)
        r = np.minimum(r, geometry.max_range)
        echo = geometry.echo(r)
        m = len(p)
        stage = np.full((m, n), Stage.ACCEPTED, dtype=np.int64)
        flagged = np.zeros((m, n), dtype=bool)
        # The rings side by side as one long reading set whose neighbours stay in their ring.
        ring_start = (n * np.arange(m))[:, None]
        left = np.where(self.left >= 0, self.left + ring_start, -1).ravel()
        right = np.where(self.right >= 0, self.right + ring_start, -1).ravel()
        if self.stages[Stage.ACCEPTABILITY]:
            verdict = acceptability(
                r.ravel(),
                echo.ravel(),
                centres.reshape(-1, 2),
                axis.ravel(),
                left,
                right,
                sigma=geometry.sigma,
                half_width=geometry.beam_width / 2.0,
                critical_angle=self.critical_angle,
                k=self.k_sigma,
                tilts=self.tilts,
            )
            stage[verdict.discard.reshape(m, n)] = Stage.ACCEPTABILITY
            flagged |= verdict.flag.reshape(m, n)
        if self.stages[Stage.AGREEABILITY]:
            verdict = agreeability(echo.ravel(), left, right)
            stage[verdict.discard.reshape(m, n) & (stage == Stage.ACCEPTED)] = Stage.AGREEABILITY
            flagged |= verdict.flag.reshape(m, n)
        # Every reading's echo point (used for the echoes only), for all rings at once.
        points = centres + r[..., None] * np.stack([np.cos(axis), np.sin(axis)], axis=-1)
        free_limit = np.full((m, n), np.inf)
        codes = np.zeros((m, n), dtype=np.int8)
        for i in range(m):
            self._finish_ring(
                p[i],
                r[i],
                echo[i],
                centres[i],
                axis[i],
                points[i],
                flagged[i],
                stage[i],
                free_limit[i],
                codes[i],
            )
        self._rejection_blocks.append(codes)
        if len(self._rejection_blocks) - self._merged >= _BLOCKS_MERGED:
            # Ring by ring, a block each would cost more in headers than in codes.
            latest = np.concatenate(self._rejection_blocks[self._merged :])
            self._rejection_blocks[self._merged :] = [latest]
            self._merged += 1
        tally = np.bincount(codes.ravel(), minlength=len(_REJECTIONS) + 1)
        for name, which in _COUNTED.items():
            self.counts_[name] += int(tally[which].sum())
        return RingVerdict(
            accepted=stage == Stage.ACCEPTED, flagged=flagged, stage=stage, free_limit=free_limit
        )

    def _finish_ring(
        self,
        pose: FloatArray,
        r: FloatArray,
        echo: BoolArray,
        centres: FloatArray,
        axis: FloatArray,
        points: FloatArray,
        flagged: BoolArray,
        stage: IntArray,
        free_limit: FloatArray,
        codes: npt.NDArray[np.int8],
    ) -> None:
        """Trait Verification of one ring (``stage``, ``free_limit`` updated in place) and
        the bookkeeping.

        ``points``: the ``(n, 2)`` echo point of every reading [m]; ``codes``: the ring's
        row of the rejection log, written in place (see ``rejection_codes_``).
        """
        if self.last_pose_ is not None:
            self.path_ += float(
                np.hypot(pose[0] - self.last_pose_[0], pose[1] - self.last_pose_[1])
            )
        self.last_pose_ = pose
        # A bottom-up rejection is logged with its stage, else Trait Verification's reason.
        codes[:] = stage
        if self.stages[Stage.TRAIT_VERIFICATION]:
            tv = self._trait_verification(
                pose, r, echo, centres, axis, points, flagged, stage == Stage.ACCEPTED, free_limit
            )
            stage[tv != TVReason.KEPT] = Stage.TRAIT_VERIFICATION
            codes[:] = np.where((codes == 0) & (tv != TVReason.KEPT), tv + _TV_CODE, codes)
        self._remember(points[echo & (stage == Stage.ACCEPTED)])
        self.rings_ += 1

    def _trait_verification(
        self,
        pose: FloatArray,
        r: FloatArray,
        echo: BoolArray,
        centres: FloatArray,
        axis: FloatArray,
        ring_points: FloatArray,
        flagged: BoolArray,
        candidate: BoolArray,
        free_limit: FloatArray,
    ) -> IntArray:
        """Trait Verification of one ring: fit ``V``, clean ``L``, reconcile, grow ``L``.

        Sets ``free_limit`` (in place) for the echoes kept despite a trait in front.
        """
        geometry = self.geometry
        current = (echo & candidate).nonzero()[0]
        points_now = ring_points[current]
        past = list(self.points_)
        points = np.concatenate([points_now, *past]) if past else points_now
        dx, dy = points[:, 0] - pose[0], points[:, 1] - pose[1]
        order = np.argsort(np.arctan2(dy, dx), kind="stable")
        traits = fit_traits(
            points[order],
            tolerance=self.split_tolerance,
            min_points=self.min_points,
            max_gap=self.max_gap,
            min_length=self.min_length,
            min_spacing=self.min_spacing,
        )
        # Where each current echo point went in the bearing order.
        rank = np.empty(len(points), dtype=np.int64)
        rank[order] = np.arange(len(points))
        mine = rank[: len(current)]
        labels = np.full(geometry.n, -1, dtype=np.int64)
        residual = np.full(geometry.n, np.nan)
        labels[current] = traits.labels[mine]
        residual[current] = traits.residuals[mine]
        certainties = certainty(
            residual, r, sigma=geometry.sigma, half_width=geometry.beam_width / 2
        )
        half = geometry.beam_width / 2.0
        judged_by_l = self.enough_state or self.l_in_case_a
        l_extended = np.zeros((0, 4))
        hits: ConeHits | None = None
        static: BoolArray | None = None
        # From the robot to each trait of L and of V (for the footprint test below).
        k = len(self.l_segments_)
        distance = point_segment_distance(
            pose[:2], np.concatenate([self.l_segments_, traits.segments])
        )[0]
        distance, v_distance = distance[:k], distance[k:].tolist()
        if k:
            # Beams cross only traits within their range of the robot (plus the ring's size).
            near = (distance <= geometry.max_range + geometry.reach).nonzero()[0]
            if self.enough_state:
                # Only traits that some beam, echo point or trait of V can reach matter; the
                # rest are left out of the (per-trait) tests, which gives the same verdicts.
                spread = float(np.hypot(dx, dy).max()) if len(points) else 0.0
                limit = max(spread, geometry.max_range + geometry.reach)
                limit += self.extension + self.match_offset + self.margin
            else:
                limit = geometry.max_range
            window = (distance <= limit).nonzero()[0]
            extended = extend_segments(self.l_segments_[window], self.extension)
            was_static = self._static()[window] if self.keep_supported_echoes else None
            # One ray pass for the ring: trait hygiene tests L's traits near the robot, the
            # verdicts (and free-space stops) the extended traits that hygiene leaves. The
            # side rays: the no-echo spread, else the cone's edges when stops may be due.
            side = self.no_echo_spread
            if side <= 0.0 and self.keep_supported_echoes and judged_by_l:
                side = half
            rays = cone_hits(
                centres, axis, np.concatenate([self.l_segments_[near], extended]), side
            )
            keep = self._clean_l(distance, near, r, echo, ~flagged & candidate, rays)
            kept = keep[window]
            if kept.any():
                columns = len(near) + kept.nonzero()[0]
                l_extended = extended[kept]
                hits = ConeHits(
                    rays.axis[:, columns],
                    rays.edges[:, columns],
                    rays.cross[:, columns],
                    rays.length[columns],
                    rays.spread,
                )
                if was_static is not None:
                    static = was_static[kept]
            elif was_static is not None:
                static = np.zeros(0, dtype=bool)
        elif self.keep_supported_echoes:
            static = np.zeros(0, dtype=bool)
        stops = self.keep_supported_echoes and judged_by_l and static is not None and static.any()
        reason = reconcile(
            candidate=candidate,
            echo=echo,
            flagged=flagged,
            ranges=r,
            centres=centres,
            axis=axis,
            labels=labels,
            certainties=certainties,
            v_segments=traits.segments,
            l_segments=l_extended,
            enough_state=self.enough_state,
            max_range=geometry.max_range,
            certainty_threshold=self.certainty_threshold,
            match_angle=self.match_angle,
            match_offset=self.match_offset,
            margin=self.margin,
            no_echo_spread=self.no_echo_spread,
            critical_angle=self.critical_angle,
            keep_supported_echoes=self.keep_supported_echoes,
            anchors=static,
            contradict_in_case_a=self.l_in_case_a,
            hits=hits,
            echo_points=ring_points,
        )
        if stops and hits is not None and static is not None:
            if hits.spread != half:
                hits = cone_hits(centres, axis, l_extended, half)
            self._stop_free_space(r, echo, candidate & (reason == 0), hits, static, free_limit)
        # A trait of V enters L when every current reading on it was kept.
        good: set[int] = set()
        bad: set[int] = set()
        for label, judged, verdict in zip(
            labels.tolist(), candidate.tolist(), reason.tolist(), strict=True
        ):
            if label >= 0 and judged:
                (bad if verdict else good).add(label)
        # ... and is not a trait the robot stands on.
        fresh = [j for j in sorted(good - bad) if v_distance[j] > self.footprint]
        self._grow_l(traits.segments[fresh])
        return reason

    def _stop_free_space(
        self,
        r: FloatArray,
        echo: BoolArray,
        kept: BoolArray,
        hits: ConeHits,
        static: BoolArray,
        free_limit: FloatArray,
    ) -> None:
        """Stop the free space of kept echoes at a static trait of ``L`` across their cone.

        An echo kept on a trait of ``L`` (``keep_supported_echoes``) may have another trait
        of ``L`` in front of it, crossing its axis or an edge of its cone more than
        ``margin`` before its range: the cone's free space then ends ``match_offset`` before
        the nearest such crossing, so the echo cannot carve through a known wall. ``hits``:
        the cone (spread: half the beam width) against ``L``; ``static``: its traits that count.
        """
        k = np.flatnonzero(kept & echo)
        if len(k) == 0:
            return
        nearest = np.minimum(
            hits.axis[k][:, static].min(axis=1), hits.edges[k][:, static].min(axis=1)
        )
        front = nearest < r[k] - self.margin
        free_limit[k[front]] = np.maximum(nearest[front] - self.match_offset, 0.0)

    def _static(self) -> BoolArray:
        """Which traits of ``L`` look like static structure: re-seen over ``static_span`` of
        path since they entered ``L``."""
        return np.asarray(self.l_seen_ - self.l_first_ >= self.static_span)

    def _clean_l(
        self,
        distance: FloatArray,
        near: IntArray,
        r: FloatArray,
        echo: BoolArray,
        trusted: BoolArray,
        rays: ConeHits,
    ) -> BoolArray:
        """Trait hygiene: drop traits of ``L`` the robot stands on or readings see through.

        A trusted reading (not flagged by the bottom-up stages) sees through a trait when its
        echo lies more than ``margin`` beyond the trait on its axis, or, with no echo, when
        its axis meets the trait head-on (within the critical angle of its normal) inside
        the max range: a wall there would have echoed.

        ``distance``: from the robot to each trait of ``L`` [m]; ``near``: the traits a beam
        can reach, whose crossings with the ring's beams are the first ``len(near)`` columns
        of ``rays``. Returns which traits of ``L`` (as it was) are left in it.
        """
        keep = distance > self.footprint
        k = trusted.nonzero()[0]
        if len(k) and len(near):
            reach = np.where(echo[k], r[k], self.geometry.max_range) - self.margin
            seen = rays.axis[k, : len(near)] < reach[:, None]
            quiet = ~echo[k]
            if quiet.any():
                columns = slice(0, len(near))
                seen[quiet] &= rays.head_on(k[quiet], self.critical_angle, columns)
            self.l_passes_[near] += seen.any(axis=0)
            keep &= self.l_passes_ < self.pass_limit
        if not keep.all():
            self._keep_l(keep)
        return keep

    def _grow_l(self, segments: FloatArray) -> None:
        """Merge ``V`` traits into ``L`` (extending equivalent ones) and forget old traits.

        The traits go in one by one, each matched against ``L`` as the ones before it left
        it: the matches with ``L`` as it was are found for all of them at once, and only the
        traits of ``L`` extended or added since are tested again.
        """
        if len(segments):
            before = equivalent(
                segments,
                self.l_segments_,
                match_angle=self.match_angle,
                match_offset=self.match_offset,
            ).tolist()
            known = len(self.l_segments_)
            # The traits of L extended or added in this call, by index, as they are now.
            changed: dict[int, list[float]] = {}
            for row, segment in zip(before, segments.tolist(), strict=True):
                for j, line in changed.items():
                    row[j] = coincide(segment, line, self.match_angle, self.match_offset)
                if True in row:
                    j = row.index(True)
                    ax, ay, bx, by = changed[j] if j in changed else self.l_segments_[j].tolist()
                    sx0, sy0, sx1, sy1 = segment
                    norm = max(math.hypot(bx - ax, by - ay), 1e-12)
                    ux, uy = (bx - ax) / norm, (by - ay) / norm
                    t = (
                        0.0,
                        (bx - ax) * ux + (by - ay) * uy,
                        (sx0 - ax) * ux + (sy0 - ay) * uy,
                        (sx1 - ax) * ux + (sy1 - ay) * uy,
                    )
                    low, high = min(t), max(t)
                    changed[j] = [ax + low * ux, ay + low * uy, ax + high * ux, ay + high * uy]
                    if j < known:  # (a trait added just now was seen here anyway)
                        self.l_seen_[j] = self.path_
                else:
                    changed[len(row)] = segment
                    for other in before:
                        other.append(False)
            grown = [changed[j] for j in range(known, len(before[0]))]
            for j, line in changed.items():
                if j < known:
                    self.l_segments_[j] = line
            if grown:
                self.l_segments_ = np.vstack([self.l_segments_, grown])
                self.l_first_ = np.append(self.l_first_, [self.path_] * len(grown))
                self.l_seen_ = np.append(self.l_seen_, [self.path_] * len(grown))
                self.l_passes_ = np.append(self.l_passes_, np.zeros(len(grown), dtype=np.int64))
        keep = self.l_seen_ >= self.path_ - 4.0 * self.perceptual_length
        if not keep.all():
            self._keep_l(keep)

    def _keep_l(self, keep: BoolArray) -> None:
        """Keep only the traits of ``L`` marked in ``keep``."""
        self.l_segments_ = self.l_segments_[keep]
        self.l_first_ = self.l_first_[keep]
        self.l_seen_ = self.l_seen_[keep]
        self.l_passes_ = self.l_passes_[keep]

    def _remember(self, points: FloatArray) -> None:
        self.points_.appendleft(points)
