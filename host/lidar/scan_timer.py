"""When each LiDAR revolution was measured, on MCU time (:class:`ScanTimer`): the stamp and
duration of each /scan."""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

import numpy as np

from jackson.protocol.rplidar import A1M8_SCAN_PERIOD_S

SCAN_PERIOD_S = A1M8_SCAN_PERIOD_S  # [s] the A1M8's turn (protocol/rplidar.py)
SCAN_TIMER_WINDOW = 200  # revolutions the LiDAR's sample period is fitted over (about 27 s)
SCAN_TIMER_MIN = 30  # revolutions before the fitted period replaces the A1M8's nominal one: the
# frames' 50 ms quantisation then errs by about 0.2 % of it
SCAN_TIMER_SLEW_S = 0.003  # [s] a revolution's end moves at most this far from back to back
SCAN_TIMER_DRIFT_S = 0.0002  # [s] per revolution: how far earlier windows' bounds loosen


class ScanTimer:
    """When each LiDAR revolution was measured, on MCU time.

    The host reads the LiDAR's port at each telemetry frame, so a revolution that arrives alone
    with a frame is known to have ended between the previous frame and that one (its window):
    on the twin in lockstep exactly, on the robot give or take the bytes' way over USB. A
    spinning LiDAR's revolutions follow each other back to back, each lasting its samples
    times the sample period, so the timer keeps a timeline of their ends and lets the windows
    correct only its phase, a little at a time:

    - the sample period is the least-squares slope of the windows' ends over the samples
      counted, over the last :data:`SCAN_TIMER_WINDOW` revolutions that came alone since the
      last gap, once :data:`SCAN_TIMER_MIN` have (the frames' quantisation averages out);
      before the first fit, a revolution lasts the A1M8's :data:`SCAN_PERIOD_S`;
    - each end is predicted as the previous end plus this revolution's duration; the windows
      of the last revolutions are intersected (each bounds where the timeline's phase may be,
      loosened by :data:`SCAN_TIMER_DRIFT_S` a revolution), and the prediction moves towards
      the middle of what they allow by at most :data:`SCAN_TIMER_SLEW_S`: consecutive stamps
      are one revolution apart within it from the first, while the phase settles;
    - a window half a period or more past the prediction (revolutions lost: nothing came for
      them) moves the timeline on by whole revolutions, and the revolution after the gap lasts
      as the one before it (its first samples may be the lost turn's); windows that disagree
      with all before (the robot's bytes late) start the intersection again;
    - revolutions that arrive together with one frame cannot all have ended in its window:
      the pairing is lost (a lockstep twin that ran on in real time while the host was kept
      from reading, a port read late); they follow back to back and tell nothing of the phase.
      Before the timeline has a phase (the first revolutions, or a first frame that brought
      several) they are held, and stamped back to back before the first revolution that comes
      alone in a window; held revolutions that cannot have followed each other up to it (the
      first would have started before the MCU's clock did, at time 0: some were lost between
      them) start at the frame the first of them came with instead, so no stamp is 0.

    The stamp (the LaserScan convention) is the revolution's first measurement: its end less
    its duration.
    """

    def __init__(self) -> None:
        self._points: deque[tuple[float, int]] = deque(maxlen=SCAN_TIMER_WINDOW)
        self._sample_s = 0.0  # the last fit of the sample period [s] (0: none yet)
        self._last_duration_s = SCAN_PERIOD_S  # the last revolution's
        self._samples = 0  # samples of the revolutions stamped (the fit's abscissa)
        self._end_s: float | None = None  # the last revolution's end on the timeline
        self._held: list[int] = []  # samples of revolutions waiting for the timeline's phase
        self._held_since_s = 0.0  # the frame the first of them came with
        # the corrections of the last end that the windows allow (low, high) [s]; None: unknown
        self._allowed: tuple[float, float] | None = None

    def sample_s(self) -> float:
        """The sample period [s]: fitted over the revolutions that came alone since the last
        gap once :data:`SCAN_TIMER_MIN` have, else the fit before the gap (0: none yet)."""
        pts = self._points
        if len(pts) >= SCAN_TIMER_MIN:
            t = np.fromiter((p[0] for p in pts), np.float64, len(pts))
            n = np.fromiter((p[1] for p in pts), np.float64, len(pts))
            n -= n.mean()
            spread = float(n @ n)
            if spread > 0.0:
                self._sample_s = float(n @ (t - t.mean())) / spread
        return self._sample_s

    def _gap(self) -> None:
        """Revolutions lost, or their pairing with the frames: the sample count no longer
        tells the time since the earlier windows, whose fit is kept until a new one has
        enough."""
        self._points.clear()
        self._allowed = None

    def _duration(self, samples: int) -> float:
        per = self.sample_s()
        return per * samples if per > 0.0 else SCAN_PERIOD_S

    def stamp(
        self, samples: Sequence[int], arrived_s: float, since_s: float | None
    ) -> list[tuple[float, float]]:
        """(start [s], duration [s]) of each revolution held so far and of ``samples``, the
        revolutions that arrived with the frame of MCU time ``arrived_s`` (their sample
        counts, in order), the previous frame being at ``since_s`` (None: none); empty while
        they are held."""
        if not samples:
            return []
        alone = len(samples) == 1 and since_s is not None and since_s < arrived_s
        if self._end_s is None:
            if not self._held:
                self._held_since_s = arrived_s
            self._held += samples
            return self._anchor(arrived_s, since_s) if alone else []
        out = []
        for n in samples:
            duration = self._duration(n)
            end = self._end_s + duration
            if alone:
                assert since_s is not None
                end, duration = self._correct(end, duration, n, since_s, arrived_s)
                self._points.append((arrived_s, self._samples + n))
            else:  # the window said nothing true
                self._gap()
            self._samples += n
            self._end_s, self._last_duration_s = end, duration
            out.append((end - duration, duration))
        return out

    def _anchor(self, arrived_s: float, since_s: float | None) -> list[tuple[float, float]]:
        """The first revolution alone in a window ends at the window's end; the revolutions
        held before it end back to back before it."""
        durations = [self._duration(n) for n in self._held]
        ends = arrived_s - np.concatenate((np.cumsum(durations[:0:-1])[::-1], [0.0]))
        first_start = float(ends[0]) - durations[0]
        if first_start <= 0.0:  # they cannot all have followed each other: some were lost
            ends += max(self._held_since_s, first_start) - first_start
        lo = since_s if since_s is not None else -math.inf
        self._allowed = (lo - arrived_s, 0.0)
        self._samples = sum(self._held)
        if ends[-1] == arrived_s:
            self._points.append((arrived_s, self._samples))
        else:
            self._gap()
        self._end_s, self._last_duration_s = float(ends[-1]), durations[-1]
        self._held = []
        return [(float(e) - d, d) for e, d in zip(ends, durations, strict=True)]

    def _correct(
        self, end: float, duration: float, samples: int, since_s: float, arrived_s: float
    ) -> tuple[float, float]:
        """(end, duration) of a revolution alone in the window (since_s, arrived_s], predicted
        to end at ``end``."""
        low, high = since_s - end, arrived_s - end  # the corrections this window allows
        if low >= 0.5 * duration:  # revolutions lost: the timeline moves on by whole turns
            # the samples before the gap that this revolution holds (the lost turn's first,
            # sent with the turn before it) are not this turn's: it lasts as the one before
            turn = self._last_duration_s
            lost = math.floor(low / turn + 0.5)
            end += lost * turn + turn - duration
            duration = turn
            low, high = since_s - end, arrived_s - end
            self._gap()
        if self._allowed is not None:
            a_low = self._allowed[0] - SCAN_TIMER_DRIFT_S
            a_high = self._allowed[1] + SCAN_TIMER_DRIFT_S
            if max(low, a_low) <= min(high, a_high):
                low, high = max(low, a_low), min(high, a_high)
        step = min(SCAN_TIMER_SLEW_S, max(-SCAN_TIMER_SLEW_S, 0.5 * (low + high)))
        self._allowed = (low - step, high - step)
        return end + step, duration
