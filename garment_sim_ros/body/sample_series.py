"""One frame's dynamic transforms over time: the storage behind ``PoseBuffer``.

Samples (stamp s, translation m, rotation xyzw) sorted by stamp in preallocated arrays, appended
in O(1) amortised, inserted in place when out of order, trimmed by age and count, and bracketed
around any times for interpolation or a bounded extrapolation.
"""

from __future__ import annotations

import numpy as np

EXTRAPOLATION_SPAN_S = 0.01  # extrapolation takes its velocity over at least this span (see SampleSeries.bracket)


class SampleSeries:
    """A child's dynamic samples sorted by stamp, in preallocated arrays of twice the capacity:
    appends are O(1) amortised (the live block is moved to the front when it reaches the end)."""

    def __init__(self, capacity: int):
        self.capacity = capacity
        self._stamps = np.empty(2 * capacity)
        self._translations = np.empty((2 * capacity, 3))
        self._rotations = np.empty((2 * capacity, 4))
        self._start = 0
        self._end = 0

    def __len__(self) -> int:
        return self._end - self._start

    @property
    def stamps(self) -> np.ndarray:
        return self._stamps[self._start:self._end]

    @property
    def translations(self) -> np.ndarray:
        return self._translations[self._start:self._end]

    @property
    def rotations(self) -> np.ndarray:
        return self._rotations[self._start:self._end]

    def insert(self, stamp: float, translation: np.ndarray, rotation: np.ndarray) -> str:
        """Store a sample; returns 'appended', 'inserted' (out of order) or 'replaced' (same stamp)."""
        if self._end == len(self._stamps):
            live = slice(self._start, self._end)
            count = len(self)
            for array in (self._stamps, self._translations, self._rotations):
                array[:count] = array[live]
            self._start, self._end = 0, count
        stamps = self.stamps
        if len(stamps) == 0 or stamp > stamps[-1]:
            at, outcome = self._end, "appended"
            self._end += 1
        else:
            offset = int(np.searchsorted(stamps, stamp))
            at = self._start + offset
            if stamps[offset] == stamp:
                outcome = "replaced"
            else:
                for array in (self._stamps, self._translations, self._rotations):
                    array[at + 1:self._end + 1] = array[at:self._end].copy()
                self._end += 1
                outcome = "inserted"
        self._stamps[at] = stamp
        self._translations[at] = translation
        self._rotations[at] = rotation
        return outcome

    @property
    def newest(self) -> float:
        return float(self._stamps[self._end - 1])

    def clear(self) -> None:
        self._start = self._end = 0

    def append(self, stamp: float, translation: np.ndarray, rotation: np.ndarray) -> None:
        """Append one sample whose stamp is after the newest (the caller checks)."""
        if self._end == len(self._stamps):  # as in ``insert``: the live block moves to the front,
            count = min(len(self), self.capacity)  # without what ``trim`` would drop (a block can be long)
            for array in (self._stamps, self._translations, self._rotations):
                array[:count] = array[self._end - count:self._end]
            self._start, self._end = 0, count
        end = self._end
        self._stamps[end] = stamp
        self._translations[end] = translation
        self._rotations[end] = rotation
        self._end = end + 1

    def trim(self, max_duration_s: float) -> None:
        """Drop samples beyond the capacity or older than ``max_duration_s`` behind the newest (keeps two)."""
        if self._stamps[self._start] >= self._stamps[self._end - 1] - max_duration_s and len(self) <= self.capacity:
            return  # nothing to drop: no search (called once per appended block)
        stamps = self.stamps
        keep_from = max(len(stamps) - self.capacity, int(np.searchsorted(stamps, stamps[-1] - max_duration_s)))
        self._start += max(0, min(keep_from, len(stamps) - 2))

    def bracket(self, times: np.ndarray, max_extrapolation_s: float):
        """The samples around each of ``times`` (K,) and the interpolation weight between them:
        p0, p1 (K, 3), q0, q1 (K, 4), weight (K,) (0 before the oldest, > 1 when extrapolating).
        Past the newest stamp the pair is the newest and the last sample at least
        ``EXTRAPOLATION_SPAN_S`` before it: at 60 Hz the last pair, at 1 kHz not two stamps whose
        microseconds of jitter would turn into metres per second."""
        if len(times) == 1:
            return self._bracket_one(float(times[0]), max_extrapolation_s)
        stamps, translations, rotations = self.stamps, self.translations, self.rotations
        if len(stamps) == 1:
            p, q = np.repeat(translations, len(times), axis=0), np.repeat(rotations, len(times), axis=0)
            return p, p, q, q, np.zeros(len(times))
        newest = len(stamps) - 1
        clamped = np.minimum(times, stamps[-1] + max_extrapolation_s)
        low = np.minimum(np.maximum(np.searchsorted(stamps, clamped, side="right") - 1, 0), newest - 1)
        high = low + 1
        beyond = clamped > stamps[-1]
        if beyond.any():
            base = int(np.searchsorted(stamps, stamps[-1] - EXTRAPOLATION_SPAN_S, side="right")) - 1
            low = np.where(beyond, min(max(base, 0), newest - 1), low)
            high = np.where(beyond, newest, high)
        weight = np.maximum((clamped - stamps[low]) / (stamps[high] - stamps[low]), 0.0)
        return translations[low], translations[high], rotations[low], rotations[high], weight

    def _bracket_one(self, time: float, max_extrapolation_s: float):
        """``bracket`` for one time, in Python scalars (a frame samples each joint at one time: the
        vector path's dozen numpy calls cost more than the interpolation); the same result."""
        stamps = self.stamps
        start, newest = self._start, len(stamps) - 1
        if newest == 0:
            low = high = start
            weight = 0.0
        else:
            last = float(stamps[newest])
            clamped = min(time, last + max_extrapolation_s)
            if clamped > last:
                base = int(np.searchsorted(stamps, last - EXTRAPOLATION_SPAN_S, side="right")) - 1
                low, high = min(max(base, 0), newest - 1), newest
            else:
                low = min(max(int(np.searchsorted(stamps, clamped, side="right")) - 1, 0), newest - 1)
                high = low + 1
            t0 = float(stamps[low])
            weight = max((clamped - t0) / (float(stamps[high]) - t0), 0.0)
            low, high = start + low, start + high
        translations, rotations = self._translations, self._rotations
        return (translations[low:low + 1], translations[high:high + 1], rotations[low:low + 1],
                rotations[high:high + 1], np.array([weight]))
