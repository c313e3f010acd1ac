"""The camera's frames as h264 in MP4 (PyAV), and MP4 files joined without re-encoding.

Frame ``i`` of an episode's video is shown at ``i / fps`` seconds: one frame per
dataset frame, so a decoder that asks for a timestamp gets that frame. The encoder
keeps a constant quantiser, so a frame that repeats the last one (the camera was not
read in between) costs a few bytes and little time, and a key frame every second,
so a reader seeking to any frame decodes at most a second of video. Joining files
copies their packets, shifting each file's timestamps to follow the last.
"""

from __future__ import annotations

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
    """Encodes one episode's frames into an MP4 at ``fps``.

    :meth:`add` converts a new image (a repeated one not at all) and hands it to
    x264, which encodes on ``threads`` threads of its own (frame threads: each
    frame's bytes are the same whatever the timing). Those threads need no GIL, so
    the encoding runs beside the run on another core; a Python thread calling the
    encoder would wait for the GIL at every frame while the run holds it. An error
    (a full disk) is raised by the :meth:`add` or :meth:`finish` that meets it.
    """

    def __init__(self, path: Path, fps: int, width: int, height: int, threads: int = 2) -> None:
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
        stream.codec_context.thread_count = max(1, int(threads))
        stream.codec_context.thread_type = "FRAME"
        self._stream = stream
        self._last: np.ndarray | None = None
        self._shown: Any = None

    def add(self, image: np.ndarray, repeat: int = 1) -> None:
        """Append ``image`` (H, W, 3 BGR uint8, the video's size) ``repeat`` times."""
        if self._container is None:
            raise RuntimeError("the video is closed")
        if image is not self._last:
            self._shown = self._frame(image)
            self._last = image
        for _ in range(repeat):
            self._shown.pts = self.frames
            self.frames += 1
            for packet in self._stream.encode(self._shown):
                self._container.mux(packet)

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

    def finish(self) -> int:
        """Flush the encoder and close the file; the number of frames written. Raises the
        encoder's error (a full disk), the file left incomplete."""
        if self._container is None:
            raise RuntimeError("the video is closed")
        try:
            for packet in self._stream.encode():
                self._container.mux(packet)
        finally:
            self.close()
        return self.frames

    def close(self) -> None:
        """Close the file (safe twice); an unfinished video is incomplete."""
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
