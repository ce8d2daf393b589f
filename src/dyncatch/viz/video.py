"""Writing (H, W, 3) uint8 frames as a GIF or an MP4, atomically."""

from __future__ import annotations

import os
import uuid
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

VIDEO_SUFFIXES = (".gif", ".mp4")


def write_video(frames: Sequence[np.ndarray], path: str | os.PathLike, fps: int) -> Path:
    """Write (H, W, 3) uint8 frames to ``path`` (``.gif`` or ``.mp4``) atomically.

    The parent folder is created; the file appears only once complete (written to a
    temporary file beside it, then renamed). Returns the path.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in VIDEO_SUFFIXES:
        raise ValueError(
            f"cannot write video {str(path)!r}: use one of the suffixes {', '.join(VIDEO_SUFFIXES)}"
        )
    if not frames:
        raise ValueError("no frames to write")
    if fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    path.parent.mkdir(parents=True, exist_ok=True)
    # A fresh name beside the target (same file system, so os.replace is atomic); the
    # writer creates it, so it gets the usual permissions rather than mkstemp's 0600.
    tmp = str(path.parent / f".{path.stem}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp{suffix}")
    try:
        if suffix == ".gif":
            _write_gif(frames, tmp, fps)
        else:
            _write_mp4(frames, tmp, fps)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _write_gif(frames: Sequence[np.ndarray], path: str, fps: int) -> None:
    import imageio.v3 as iio

    # Pillow's GIF writer takes the frame duration in milliseconds; loop=0 repeats forever.
    iio.imwrite(path, np.stack(frames), extension=".gif", duration=1000.0 / fps, loop=0)


def _write_mp4(frames: Sequence[np.ndarray], path: str, fps: int) -> None:
    import imageio_ffmpeg

    h, w = frames[0].shape[:2]
    writer = imageio_ffmpeg.write_frames(path, (w, h), fps=fps, codec="libx264",
                                         pix_fmt_out="yuv420p", macro_block_size=2,
                                         ffmpeg_log_level="error")  # fmt: skip
    with warnings.catch_warnings():
        # JAX warns on any fork; the ffmpeg subprocess execs at once and shares no threads.
        warnings.filterwarnings("ignore", message="os.fork", category=RuntimeWarning)
        writer.send(None)
    for frame in frames:
        writer.send(np.ascontiguousarray(frame))
    writer.close()
