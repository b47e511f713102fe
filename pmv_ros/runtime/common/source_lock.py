"""Which publisher an input listens to — one home, no ROS: :class:`SourceLock`, one per input stream.

A topic may have several publishers (a second attitude stack, a flood, a
restarted node); a node uses the first one heard and drops the others'
messages, never interleaving two sources. Jazzy's rclpy gives no
publisher GID, so a source is told by its sequence numbers and stamps
(the rule is in :class:`SourceLock`'s docstring). The nodes keep one lock per
input (:mod:`.input_sources`); the ``/clock`` check keeps one for ``/clock``
(:class:`~.validation.ClockCheck`).

Times are seconds (float) on the clock the caller gives.
"""

from __future__ import annotations

import math
from typing import Callable

#: Silence after which a locked source is given up by default, s (the default of ``input.source_timeout_s``): a
#: restarted node is followed again a second after its old self fell silent, while a scheduler hiccup (tens to
#: hundreds of ms) does not give a source up.
DEFAULT_TIMEOUT_S = 1.0

#: Largest step in a source's sequence numbers still taken as the same source (the default of
#: ``SourceLock(max_sequence_gap=…)``): ten seconds of the fastest input (a 100 Hz sensor) lost by a busy
#: subscriber still continue the source's track. (An intruder's track is followed across any step.)
MAX_SEQUENCE_GAP = 1000

#: Sources a lock remembers at once (the default of ``SourceLock(max_tracks=…)``): the locked one and seven
#: others; memory stays bounded however many publishers come and go (the least recently heard other is forgotten).
MAX_TRACKS = 8

#: The weight of one message in a track's running figures — its stamp interval, its stamp jitter and its numbering
#: rate, each an exponential average (new = (1 − w)·old + w·this message's): ≈ the last five messages, so a source's
#: cadence is learnt within its first messages and a change of rate followed within a few, while one late or lost
#: message moves the figure by a fifth of its own deviation.
TRACK_SMOOTHING = 0.2
_TRACK_KEEP = 1.0 - TRACK_SMOOTHING  # 0.8 exactly in binary floating point

#: How many source timeouts a silent locked source keeps its lock while the graph shows another publisher
#: beside the one that would take over (:class:`SourceLock`): a flood lasting this long while the real source
#: is starved or drowned takes over; at the default timeout of 1 s that is 10 s.
CROWDED_TIMEOUT_FACTOR = 10.0


class SourceLock:
    """Keep one publisher per input stream: the first heard; drop the others' messages, never interleave.

    Rule (how the source is chosen and kept):

    * A message's source is the publisher's GID when the middleware gives it
      (``publisher_gid`` in rclpy's message info, rclpy ≥ Kilted). Jazzy's rclpy
      gives only the publisher's own sequence number (each publisher numbers
      its messages 1, 2, 3, …), so there a source is a *track* of sequence
      numbers: a message continues the track whose last number is below its
      own by at most ``max_sequence_gap``. Where several could take it, the
      step that track's numbering rate explains wins first (its rate × the
      time since it was last heard, rounded, at least one: a full queue or
      best effort loses messages, so a real sample two numbers on after two
      periods is as good as one number on — :meth:`_Track.excess_step`);
      then, where steps are all explained (a faster publisher's count has
      caught up with the locked one's), the track the message fits best in
      time: the step nearest its rate's, and the stamp nearest its expected
      one (last stamp + step × its stamp interval) measured in that track's
      own stamp jitter (:meth:`_Track.misfit`). A single publisher is
      therefore always one track, whatever its stamps do (its clock jumps are
      the stamp checks' business). Two publishers numbering in lockstep are
      told apart by their stamps only: where those coincide too, only a GID
      can separate them.
    * The first source heard is locked. Its messages pass; every other
      source's are OTHER_SOURCE, counted, and the number of sources heard
      within ``timeout_s`` is what :attr:`sources_heard` reports.
    * The lock moves only when the locked source has been silent (by arrival
      time, on the clock the caller gives) for ``timeout_s`` — it stopped, or was restarted (a restarted
      publisher numbers from 1 again: a new track); the next source heard is
      then locked (counted in :attr:`lock_changes`) — unless it is a known
      *intruder*: a source refused while the locked one was still talking
      (heard between two of its messages) never inherits the lock. A flood
      that outlasts a real source's stall (a starved process on a busy
      machine falls silent for a second) cannot become the source; a
      restarted publisher, which is heard only after the old one stopped, can.
      An intruder's numbering is followed across any gap (a flood that a busy
      subscriber thins by thousands stays the same intruder). And where the
      caller can ask the graph (``crowded``: more than one publisher of the
      input there now), a source first heard during the stall — a flood that
      began while the real one was starved, or whose messages pushed the real
      one's out of the subscriber's queue — still waits
      :data:`CROWDED_TIMEOUT_FACTOR` timeouts: the silent source is still in
      the graph, so it may be starved, not gone. A restarted publisher's old
      self leaves the graph (at once on a clean exit; after the middleware's
      lease on kill -9), and the new one is locked after ``timeout_s``.
    * Once any other source has spoken while the locked one was alive (heard
      between two of its messages: a restarted publisher, heard only after its
      old self stopped, is not one), the
      stream is *contested* for good: a neighbour that publishes each message
      from a fresh publisher (discovery churn) is a new track every time and
      never an intruder by its track, so the memory is the stream's. A
      contested lock moves only after :data:`CROWDED_TIMEOUT_FACTOR` timeouts
      of silence and only while the graph shows no publisher but the one
      taking over (the locked source has left the graph, not merely fallen
      silent); until then the stream says its ERROR and uses nothing else.
    * A message with neither GID nor sequence number (an in-process call)
      counts as the locked source.

    Memory: at most ``max_tracks`` tracks (the least recently heard other
    source is forgotten first).

    Args:
        timeout_s: silence after which the locked source is given up, s (arrival clock).
        max_sequence_gap: largest jump in a source's sequence numbers still taken as the same source.
        max_tracks: sources remembered at once.
        crowded: whether the graph shows more than one publisher of the input now (asked only when the lock
            would move); None: not known, the lock moves after ``timeout_s``.
    """

    def __init__(self, timeout_s: float = DEFAULT_TIMEOUT_S, *, max_sequence_gap: int = MAX_SEQUENCE_GAP,
                 max_tracks: int = MAX_TRACKS, crowded: Callable[[], bool] | None = None) -> None:
        if not (math.isfinite(timeout_s) and timeout_s > 0.0):
            raise ValueError(f"timeout_s = {timeout_s} must be a positive number of seconds")
        if max_tracks < 2 or max_sequence_gap < 1:
            raise ValueError("max_tracks must be ≥ 2 and max_sequence_gap ≥ 1")
        self.timeout_s = float(timeout_s)
        self.max_sequence_gap = int(max_sequence_gap)
        self.max_tracks = int(max_tracks)
        self.crowded = crowded
        self._tracks: list[_Track] = []
        self._locked: _Track | None = None
        self.lock_changes = 0
        self.other_source_messages = 0
        self.contested = False  # another source spoke while the locked one was alive (kept for the stream's life)

    def admit(self, arrival_s: float, *, gid=None, sequence: int | None = None,
              stamp_s: float = math.nan) -> bool:
        """Whether a message that arrived at ``arrival_s`` (s, the node clock) is from the locked source."""
        if gid is None and sequence is None:
            return True
        track = self._track_for(gid, sequence, stamp_s, arrival_s)
        locked = self._locked
        if locked is None or (locked is not track and not track.intruder and self._given_up(locked, arrival_s)):
            if locked is not None:
                self.lock_changes += 1
            self._locked = locked = track
        track.hear(sequence, stamp_s, arrival_s)
        if track is locked:
            for other in self._tracks:  # refused since its previous message: they spoke while it was alive
                if other.refused and other is not track:
                    other.intruder = self.contested = True
            return True
        track.refused = True
        self.other_source_messages += 1
        return False

    def _given_up(self, locked: "_Track", arrival_s: float) -> bool:
        """Whether the silent locked source may be given up to a message arriving at ``arrival_s``.

        Silent for the timeout (or the clock went back by more: a restarted simulation). While the graph shows
        another publisher beside the new one, only after CROWDED_TIMEOUT_FACTOR timeouts. Once the stream is
        *contested* — some other source spoke while the locked one was alive — only after that longer silence
        *and* with the graph showing no publisher but the one taking over: a neighbour whose publishers are
        short-lived is a new track every time, so it is remembered by the stream, not by its track.
        """
        silence = abs(arrival_s - locked.arrival_s)
        if silence <= self.timeout_s:
            return False
        long_silence = silence > CROWDED_TIMEOUT_FACTOR * self.timeout_s
        crowded = self.crowded is not None and self.crowded()
        if self.contested:
            return long_silence and not crowded
        return long_silence or not crowded

    def sources_heard(self, now_s: float) -> int:
        """Sources heard within ``timeout_s`` before ``now_s`` (arrival clock)."""
        return sum(1 for track in self._tracks if abs(now_s - track.arrival_s) <= self.timeout_s)

    def _track_for(self, gid, sequence, stamp_s, arrival_s) -> "_Track":
        tracks = self._tracks
        if gid is not None:
            key = bytes(gid)
            for track in tracks:
                if track.gid == key:
                    return track
            return self._new_track(_Track(gid=key))
        # An intruder's numbering is followed across any loss: a flood whose messages a busy subscriber drops by
        # the thousand must not come back as a new source, one no stall has yet shown up.
        candidates = [track for track in tracks if track.gid is None and track.sequence is not None
                      and 0 < sequence - track.sequence <= (math.inf if track.intruder else self.max_sequence_gap)]
        if len(candidates) == 1:  # one source could take it (the usual case): nothing to weigh
            return candidates[0]
        best, best_key = None, None
        for track in candidates:
            gap = sequence - track.sequence
            # The step its source's rate explains first (messages get lost: a step of 2 after 0.2 s of a
            # 10 Hz source is as good as 1); where two sources could both take it (their counts met), the
            # one this message fits best in time.
            key = (track.excess_step(gap, arrival_s), track.misfit(gap, stamp_s, arrival_s), gap,
                   track is not self._locked)
            if best_key is None or key < best_key:
                best, best_key = track, key
        return best if best is not None else self._new_track(_Track())

    def _new_track(self, track: "_Track") -> "_Track":
        if len(self._tracks) >= self.max_tracks:
            others = [t for t in self._tracks if t is not self._locked]
            self._tracks.remove(min(others, key=lambda t: t.arrival_s))
        self._tracks.append(track)
        return track


class _Track:
    """What a :class:`SourceLock` remembers of one source."""

    __slots__ = ("gid", "sequence", "stamp_s", "interval_s", "arrival_s", "sequence_rate_hz", "stamp_jitter_s",
                 "refused", "intruder")

    #: Stamp jitter below which a source's stamps count as exact (a double holds ~1e-7 s at 2e9 s), s.
    STAMP_JITTER_FLOOR_S = 1e-5

    def __init__(self, gid: bytes | None = None) -> None:
        self.gid = gid
        self.sequence = None
        self.stamp_s = math.nan
        self.interval_s = math.nan
        self.arrival_s = -math.inf
        self.sequence_rate_hz = math.nan  # numbers per second of arrival time, smoothed
        self.stamp_jitter_s = math.nan  # how far its stamps fall from one interval on, smoothed
        self.refused = False  # a message of it was refused (it is not the locked source)
        self.intruder = False  # refused while the locked source was still talking: never given the lock

    def misfit(self, gap: int, stamp_s: float, arrival_s: float) -> float:
        """How badly a message ``gap`` numbers on, stamped ``stamp_s``, fits this source (0: perfectly).

        Two terms, each in units of this source's own regularity: how far ``gap``
        is from the numbers its rate says it used since it was last heard (1
        while the rate is unknown), and how far the stamp is from ``gap``
        intervals on (messages lost in between still took their numbers and
        their stamps), in units of its usual stamp jitter. A sensor stamping
        on a fixed grid has almost no jitter, so a neighbour's stamp that is
        off its grid by milliseconds misfits it badly, even when the two
        counts have met.
        """
        expected = self.sequence_rate_hz * (arrival_s - self.arrival_s)
        timing = abs(gap - expected) if math.isfinite(expected) else 1.0
        miss = abs(stamp_s - self.expected_stamp_s(gap, arrival_s))
        if not math.isfinite(miss):  # its stamps are bad: numbers only
            return timing
        jitter = self.stamp_jitter_s if math.isfinite(self.stamp_jitter_s) else 0.0
        return timing + miss / (jitter + self.STAMP_JITTER_FLOOR_S)

    def expected_stamp_s(self, gap: int, arrival_s: float) -> float:
        """The stamp this source's message ``gap`` numbers on should carry: ``gap`` intervals on (or,
        before the interval is known, as much as the arrival time moved on)."""
        step = gap * self.interval_s if math.isfinite(self.interval_s) else arrival_s - self.arrival_s
        return self.stamp_s + step

    def excess_step(self, gap: int, arrival_s: float) -> int:
        """How many numbers more than this source would have used (its rate × the time since it was last
        heard, rounded; at least one) a message ``gap`` numbers on skips: 0 where lost messages explain
        the gap."""
        expected = self.sequence_rate_hz * (arrival_s - self.arrival_s)
        used = math.floor(expected + 0.5) if math.isfinite(expected) else 1
        return max(0, gap - max(1, used))

    def hear(self, sequence, stamp_s: float, arrival_s: float) -> None:
        gap = sequence - self.sequence if sequence is not None and self.sequence is not None else 1
        gap = gap if gap >= 1 else 1
        if math.isfinite(stamp_s) and stamp_s > 0.0:  # a bad stamp says nothing about the cadence
            miss = abs(stamp_s - self.expected_stamp_s(gap, arrival_s))
            if math.isfinite(miss) and math.isfinite(self.interval_s):
                known = math.isfinite(self.stamp_jitter_s)
                self.stamp_jitter_s = _TRACK_KEEP * self.stamp_jitter_s + TRACK_SMOOTHING * miss if known else miss
            if math.isfinite(self.stamp_s) and stamp_s > self.stamp_s:
                step = (stamp_s - self.stamp_s) / gap
                self.interval_s = (step if not math.isfinite(self.interval_s)
                                   else _TRACK_KEEP * self.interval_s + TRACK_SMOOTHING * step)
            self.stamp_s = stamp_s
        if sequence is not None:
            elapsed_s = arrival_s - self.arrival_s
            if self.sequence is not None and sequence > self.sequence and 0.0 < elapsed_s < math.inf:
                rate = (sequence - self.sequence) / elapsed_s
                known = math.isfinite(self.sequence_rate_hz)
                self.sequence_rate_hz = (_TRACK_KEEP * self.sequence_rate_hz + TRACK_SMOOTHING * rate if known
                                         else rate)
            self.sequence = sequence
        self.arrival_s = arrival_s
