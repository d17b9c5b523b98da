"""Offset and drift of the coprocessor's clock against this computer's, from NTP-style
exchanges over the link (docs/protocol.md, "Clock sync"); the same estimator as the C++
tools/ballvision/clock_sync.h.

    sync = ClockSync()
    sync.request_sent(rid, t1_us)          # t1_us: this computer's clock, µs, in the request
    sync.reply(reply, t4_us)               # reply: a ClockSyncReply, t4_us: when it arrived
    host_us = sync.to_host_time(ball.t_us)

Each exchange gives offset = host - device = ((t1 - t2) + (t4 - t3)) / 2 and the path delay
d = (t4 - t1) - (t3 - t2); the true offset lies within +-d/2 of it. The estimate is a line
fitted by weighted least squares over the last 1024 exchanges with weights
1 / (d - d_min + 30 µs)^2, so the minimum-delay exchanges decide. An exchange that cannot
contain the current line (beyond d/2 + d_min/2, a 500 µs margin and 200 ppm of drift since the
newest exchange) means a clock
jumped (coprocessor reset): the estimator restarts from it.
"""
from collections import deque

from .protocol import WIRE_OVERHEAD_BYTES

SYNC_REQUEST_BYTES, SYNC_REPLY_BYTES = 12, 28

ACCEPTED, DUPLICATE, UNKNOWN_ID, MISMATCH, INCONSISTENT, HELD, RESTARTED, REJECTED = (
    "accepted", "duplicate", "unknown id", "mismatch", "inconsistent", "held", "restarted",
    "rejected")


def wire_frame_bytes(payload: int) -> int:
    """Upper bound of a frame's bytes on the wire (protocol::WireFrameBytes)."""
    raw = WIRE_OVERHEAD_BYTES + payload
    return raw + raw // 254 + 2


class ClockSync:
    WINDOW, PENDING, ANSWERED = 1024, 32, 32

    def __init__(self, baud: float = 921600.0, delay_floor_us: float = 20.0,
                 max_drift_ppm: float = 200.0, jump_margin_us: float = 500.0):
        self.byte_us = 10.0 / baud * 1e6 if baud else 0.0
        self.delay_floor_us = delay_floor_us
        self.max_drift_ppm = max_drift_ppm
        self.jump_margin_us = jump_margin_us
        self._pending = {}            # id -> t1, at most PENDING (oldest dropped)
        self._answered = deque(maxlen=self.ANSWERED)
        self._samples = deque(maxlen=self.WINDOW)  # (t_dev, offset, delay), relative
        self._dev_ref = 0
        self._offset_ref = 0
        self._last_t_dev = 0.0
        self._intercept = self._slope = self.min_delay_us = self._centroid = 0.0
        self._suspect = None
        self.counts = {ACCEPTED: 0, DUPLICATE: 0, UNKNOWN_ID: 0, MISMATCH: 0, INCONSISTENT: 0,
                       HELD: 0, RESTARTED: 0, REJECTED: 0}

    @property
    def valid(self) -> bool:
        return bool(self._samples)

    @property
    def drift_ppm(self) -> float:
        """Host µs per coprocessor µs, minus 1, in ppm."""
        return self._slope * 1e6

    @property
    def restarts(self) -> int:
        return self.counts[RESTARTED]

    def request_sent(self, rid: int, t1_us: int) -> None:
        if len(self._pending) >= self.PENDING:
            self._pending.pop(next(iter(self._pending)))
        self._pending[rid] = t1_us

    def reply(self, reply, t4_us: int) -> str:
        """Feeds a reply (anything with id, t1_host_us, t2_rx_us, t3_tx_us); the verdict."""
        t1 = self._pending.get(reply.id)
        if t1 is None:
            verdict = DUPLICATE if reply.id in self._answered else UNKNOWN_ID
            self.counts[verdict] += 1
            return verdict
        if t1 != reply.t1_host_us:
            self.counts[MISMATCH] += 1
            return MISMATCH
        if t4_us < t1 or reply.t3_tx_us < reply.t2_rx_us:
            self.counts[INCONSISTENT] += 1
            return INCONSISTENT
        del self._pending[reply.id]
        self._answered.append(reply.id)
        raw = (t1, reply.t2_rx_us, reply.t3_tx_us, t4_us)
        verdict = ACCEPTED
        if self._samples and not self._consistent(raw):
            # One odd exchange is held back; a second that agrees with it, and not with the
            # estimate, is a clock jump: restart from the two.
            if self._suspect is None or not self._agree(self._suspect, raw):
                if self._suspect is not None:
                    self.counts[REJECTED] += 1
                self._suspect = raw
                self.counts[HELD] += 1
                return HELD
            verdict = RESTARTED
            self._samples.clear()
            self._add(self._suspect)
        elif self._suspect is not None:
            self.counts[REJECTED] += 1  # the held exchange was an outlier
        self._suspect = None
        self._add(raw)
        self.counts[verdict] += 1
        self._fit()
        return verdict

    def _sample(self, raw):
        """(t_dev, offset, delay) relative to the current references; see the module text."""
        t1, t2, t3, t4 = raw
        h1 = self.byte_us * wire_frame_bytes(SYNC_REQUEST_BYTES)
        h4 = (t4 - t1) - self.byte_us * wire_frame_bytes(SYNC_REPLY_BYTES)
        d3 = t3 - t2
        return ((t2 - self._dev_ref) + d3 / 2.0,
                ((t1 - t2) - self._offset_ref) + (h1 + (h4 - d3)) / 2.0,
                max((h4 - h1) - d3, 0.0))

    def _add(self, raw):
        if not self._samples:
            self._dev_ref, self._offset_ref = raw[1], raw[0] - raw[1]
        s = self._sample(raw)
        self._samples.append(s)
        if len(self._samples) == 1 or s[0] > self._last_t_dev:
            self._last_t_dev = s[0]

    def _consistent(self, raw) -> bool:
        x, y, d = self._sample(raw)
        allowance = ((d + self.min_delay_us) / 2.0 + self.jump_margin_us +
                     2.0 * self.max_drift_ppm * 1e-6 * abs(x - self._centroid))
        return abs(y - (self._intercept + self._slope * x)) <= allowance

    def _agree(self, a, b) -> bool:
        xa, ya, da = self._sample(a)
        xb, yb, db = self._sample(b)
        allowance = ((da + db) / 2.0 + self.jump_margin_us +
                     self.max_drift_ppm * 1e-6 * abs(xa - xb))
        return abs(ya - yb) <= allowance

    def _fit(self) -> None:
        dmin = min(s[2] for s in self._samples)
        self.min_delay_us = dmin
        f = self.delay_floor_us
        ws = [(f / (d - dmin + f)) ** 4 for _, _, d in self._samples]
        sw = sum(ws)
        mx = sum(w * s[0] for w, s in zip(ws, self._samples)) / sw
        my = sum(w * s[1] for w, s in zip(ws, self._samples)) / sw
        sxx = sum(w * (s[0] - mx) ** 2 for w, s in zip(ws, self._samples))
        sxy = sum(w * (s[0] - mx) * (s[1] - my) for w, s in zip(ws, self._samples))
        # Below ~0.1 s of weighted spread the slope is noise: hold the offset flat until then;
        # and no crystal drifts more than max_drift_ppm.
        limit = self.max_drift_ppm * 1e-6
        self._slope = min(max(sxy / sxx, -limit), limit) if sxx / sw > 1e10 else 0.0
        self._intercept = my - self._slope * mx
        self._centroid = mx

    def offset_us(self, t_dev_us: int) -> float:
        """Host minus coprocessor time (µs) at coprocessor time t_dev_us."""
        return self._offset_ref + self._intercept + self._slope * (t_dev_us - self._dev_ref)

    def to_host_time(self, t_us: int) -> int:
        """Host time (µs, the clock given to request_sent / reply) of a packet's t_us."""
        if not self._samples:
            raise ValueError("clock sync: no exchange yet")
        rel = self._intercept + self._slope * (t_us - self._dev_ref)
        return t_us + self._offset_ref + round(rel)
