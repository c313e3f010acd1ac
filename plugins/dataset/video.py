"""The camera's frames as h264 in MP4 (PyAV), and MP4 files joined without re-encoding.

Frame ``i`` of an episode's video is shown at ``i / fps`` seconds: one frame per
dataset frame, so a decoder that asks for a timestamp gets that frame. The encoder
keeps a constant quantiser, so a frame that repeats the last one (the camera was not
read in between) costs a few bytes and little time, and a key frame every second,
so a reader seeking to any frame decodes at most a second of video. Joining files
copies their packets, shifting each file's timestamps to follow the last.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from . import deps

CODEC = "libx264"
#: x264's fastest preset at a fixed quantiser; no B-frames, so decode order is show order.
QUANTISER = 23


class EpisodeVideo:
    """Encodes one episode's frames into an MP4 at ``fps``, on a thread of its own.

    :meth:`add` returns at once: a new image is converted on the caller's thread (a
    repeated one not at all) and the encoding is left to the thread, which PyAV lets
    run beside the caller (it releases the GIL while x264 works). An error of the
    thread (a full disk) is raised by :meth:`finish`.
    """

    def __init__(self, path: Path, fps: int, width: int, height: int, threads: int = 1) -> None:
        av = deps.av()
        self.path = Path(path)
        self.fps = int(fps)
        self.width, self.height = int(width), int(height)
        #: Frames added so far.
        self.frames = 0
        self._av = av
        self._container = av.open(str(self.path), "w")
        stream = self._container.add_stream(
            CODEC,
            rate=self.fps,
            options={
                "preset": "ultrafast",
                "qp": str(QUANTISER),
                "g": str(max(1, self.fps)),
                "bframes": "0",
            },
        )
        stream.width, stream.height, stream.pix_fmt = self.width, self.height, "yuv420p"
        stream.codec_context.thread_count = threads
        self._stream = stream
        self._last: np.ndarray | None = None
        # A bounded queue: a caller faster than the encoder waits rather than filling memory.
        self._queue: queue.Queue = queue.Queue(maxsize=64)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._encode, name="armtree-video", daemon=True)
        self._thread.start()

    def add(self, image: np.ndarray, repeat: int = 1) -> None:
        """Append ``image`` (H, W, 3 BGR uint8, the video's size) ``repeat`` times."""
        if self._error is not None:
            raise self._error
        frame = None
        if image is not self._last:
            frame = self._frame(image)
            self._last = image
        self._queue.put((frame, repeat))
        self.frames += repeat

    def _frame(self, image: np.ndarray) -> Any:
        if image.shape[:2] != (self.height, self.width):
            raise ValueError(
                f"a camera frame of {image.shape[1]}x{image.shape[0]} px in a "
                f"{self.width}x{self.height} video"
            )
        if self.width % 2 == 0 and self.height % 2 == 0:
            # OpenCV's conversion is several times faster than swscale's here and
            # decodes to the same colours.
            planes = cv2.cvtColor(image, cv2.COLOR_BGR2YUV_I420)
            return self._av.VideoFrame.from_ndarray(planes, format="yuv420p")
        frame = self._av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="bgr24")
        return frame.reformat(format="yuv420p")

    def _encode(self) -> None:
        shown, pts = None, 0
        try:
            while (item := self._queue.get()) is not None:
                frame, repeat = item
                shown = frame if frame is not None else shown
                if shown is None:
                    # add() converts the first image it is given, so only a bug gets here.
                    raise RuntimeError("a repeated frame before any frame")
                for _ in range(repeat):
                    shown.pts = pts
                    pts += 1
                    for packet in self._stream.encode(shown):
                        self._container.mux(packet)
            for packet in self._stream.encode():
                self._container.mux(packet)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller by finish()
            self._error = exc
            while self._queue.get() is not None:  # let a waiting caller go on
                pass

    def finish(self) -> int:
        """Encode what is queued, flush and close the file; the number of frames written.
        Raises the encoder's error (a full disk), the file left incomplete."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        self.close()
        if self._error is not None:
            raise self._error
        return self.frames

    def close(self) -> None:
        """Stop encoding and close the file (safe twice); an unfinished video is incomplete."""
        if self._thread.is_alive():
            self._error = self._error or RuntimeError("closed before it was finished")
            self._queue.put(None)
            self._thread.join()
        container, self._container = self._container, None
        if container is not None:
            container.close()


def join(paths: Sequence[Path], out: Path) -> None:
    """Write the videos ``paths`` one after the other into ``out``, copying packets.

    Every input has the same codec, size and rate (the same encoder made them); the
    timestamps of each continue where the previous file ended.
    """
    av = deps.av()
    with av.open(str(out), "w", format="mp4") as output:
        stream = None
        offset = 0
        for path in paths:
            with av.open(str(path)) as source:
                video = source.streams.video[0]
                if stream is None:
                    stream = output.add_stream_from_template(video)
                end = offset
                for packet in source.demux(video):
                    if packet.dts is None:
                        continue  # the demuxer's empty flush packet
                    packet.pts += offset
                    packet.dts += offset
                    end = max(end, packet.pts + (packet.duration or 0))
                    packet.stream = stream
                    output.mux(packet)
                offset = end


def frame_times(path: Path) -> list[float]:
    """The presentation time (s) of every frame of the video at ``path``, decoded."""
    av = deps.av()
    with av.open(str(path)) as source:
        return [float(frame.time) for frame in source.decode(video=0)]


def probe(path: Path) -> dict[str, Any]:
    """The first video stream's codec, size, pixel format, rate, frame count and duration
    (s) as the container says, without decoding."""
    av = deps.av()
    with av.open(str(path)) as source:
        video = source.streams.video[0]
        duration = (
            float(video.duration * video.time_base)
            if video.duration is not None
            else float(source.duration or 0) / av.time_base
        )
        return {
            "codec": video.codec_context.name,
            "width": video.width,
            "height": video.height,
            "pix_fmt": video.pix_fmt,
            "fps": float(video.average_rate) if video.average_rate else None,
            "frames": int(video.frames),
            "duration": duration,
        }


__all__ = ["EpisodeVideo", "frame_times", "join", "probe"]
