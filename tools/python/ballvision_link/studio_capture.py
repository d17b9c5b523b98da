"""Captured pairs from the link into a sequence folder (DESIGN.md section 4), for the studio:
frames.csv and one 640x480 .yuyv per image (half and quarter images scaled back, nearest
neighbour, as `ballvision capture` does). A pair is written only when every byte of its images
arrived in order; a gap breaks that pair and is counted."""
import os
from pathlib import Path

from .protocol import CAPTURE_MODES, CaptureChunk, CaptureEnd, CaptureFrame

FULL_W, FULL_H = 640, 480


def upsample(image: bytes, mode: int) -> bytes:
    """A 640x480 YUYV image from a half (2x) or quarter (4x) decimated one."""
    w, h = CAPTURE_MODES[mode]
    f = FULL_W // w
    if f == 1:
        return image
    out = bytearray()
    for y in range(h):
        row = image[y * w * 2:(y + 1) * w * 2]
        dst = bytearray()
        for x in range(w):
            pair = x & ~1
            yv, u, v = row[x * 2], row[pair * 2 + 1], row[pair * 2 + 3]
            dst += bytes((yv, u, yv, v)) * (f // 2)
        out += bytes(dst) * f
    return bytes(out)


class CaptureWriter:
    def __init__(self, out: Path, pairs: int, mode: int):
        self.out, self.requested, self.mode = Path(out), pairs, mode
        self.frame, self.images, self.rows = None, None, []
        self.broken = 0

    def feed(self, msg):
        """(done, text): done once the capture's end packet arrived."""
        if isinstance(msg, CaptureFrame):
            if self.frame is not None:
                self.broken += 1  # the previous pair never completed
            self.frame, self.images = msg, {}
        elif isinstance(msg, CaptureChunk) and self.frame is not None:
            img = self.images.setdefault(msg.camera, bytearray())
            if msg.pair_index != self.frame.pair_index or msg.offset != len(img):
                self.frame, self.broken = None, self.broken + 1
            else:
                img += msg.data
                self._maybe_complete()
        elif isinstance(msg, CaptureEnd):
            why = "" if msg.reason == "complete" else f" ({msg.reason})"
            return True, self.finish(f"{msg.pairs_sent} of {msg.requested} sent{why}")
        return False, None

    def _maybe_complete(self):
        f = self.frame
        cams = [c for c in (0, 1) if f.cameras & (1 << c)]
        if any(len(self.images.get(c, b"")) < f.image_bytes for c in cams):
            return
        self.out.mkdir(parents=True, exist_ok=True)
        names = {}
        for c, name in ((0, "omni"), (1, "persp")):
            if c in cams:
                (self.out / name).mkdir(exist_ok=True)
                names[c] = f"{name}/{len(self.rows):06d}.yuyv"
                (self.out / names[c]).write_bytes(upsample(bytes(self.images[c]), f.mode))
        index = f.omni_sequence if 0 in cams else f.persp_sequence
        self.rows.append(f"{index},{f.exposure_us},{names.get(0, '')},{names.get(1, '')}")
        self.frame = None

    def finish(self, why):
        if self.frame is not None:
            self.broken += 1
            self.frame = None
        if not self.rows:
            return f"capture: no complete pair ({why}; {self.broken} broken)"
        tmp = self.out / "frames.csv.tmp"
        tmp.write_text("index,t_us,omni_file,persp_file\n" + "\n".join(self.rows) + "\n")
        os.replace(tmp, self.out / "frames.csv")
        return (f"capture: {len(self.rows)} pair(s) written to {self.out}; {why}, "
                f"{self.broken} broken")
