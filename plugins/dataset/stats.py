"""Statistics of an episode's features and their aggregate over a dataset, as LeRobot
keeps them (``lerobot/datasets/compute_stats.py``): min, max, mean, std and count per
feature; images per channel (RGB, scaled to 0-1) from a sample of the episode's frames.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

Stats = dict[str, np.ndarray]
#: Images wider or taller than this are sampled every few pixels for their statistics.
_DOWNSAMPLE_FROM_PX = 300
_DOWNSAMPLE_TO_PX = 150


def sample_count(length: int, least: int = 100, most: int = 10_000, power: float = 0.75) -> int:
    """How many of an episode's ``length`` frames its image statistics sample."""
    least = min(least, length)
    return max(least, min(int(length**power), most))


def sample_indices(length: int) -> np.ndarray:
    """The frames (indices) the image statistics of an episode of ``length`` frames read."""
    return np.round(np.linspace(0, length - 1, sample_count(length))).astype(int)


def downsample(image: np.ndarray) -> np.ndarray:
    """``image`` (H, W, C) read every few pixels when it is large, for statistics."""
    height, width = image.shape[:2]
    if max(height, width) < _DOWNSAMPLE_FROM_PX:
        return image
    step = int(max(height, width) / _DOWNSAMPLE_TO_PX)
    return image[::step, ::step]


def of_values(values: np.ndarray) -> Stats:
    """Statistics of a ``(frames,)`` or ``(frames, n)`` array, over the frames."""
    values = np.asarray(values)
    keep = values.ndim == 1
    return {
        "min": np.min(values, axis=0, keepdims=keep),
        "max": np.max(values, axis=0, keepdims=keep),
        "mean": np.mean(values, axis=0, keepdims=keep),
        "std": np.std(values, axis=0, keepdims=keep),
        "count": np.array([len(values)]),
    }


def of_images(images: Sequence[np.ndarray], times: Sequence[int] | None = None) -> Stats:
    """Per-channel statistics of RGB ``images`` (H, W, 3 uint8), as fractions of 255,
    each ``(3, 1, 1)``; ``times[i]`` says how many of the sampled frames image ``i``
    stands for (default once each), so a repeated frame is counted, not read, again.

    Worked out from each channel's histogram of the 256 grey levels: exact, and a
    small fraction of the time of a reduction over the pixels in floating point.
    """
    times = [1] * len(images) if times is None else list(times)
    levels = np.arange(256, dtype=np.float64)
    out: dict[str, list[float]] = {"min": [], "max": [], "mean": [], "std": []}
    for channel in range(images[0].shape[-1]):
        counts = np.zeros(256, dtype=np.float64)
        for image, n in zip(images, times, strict=True):
            counts += n * np.bincount(image[..., channel].ravel(), minlength=256)
        total = counts.sum()
        mean = float(counts @ levels / total)
        variance = max(0.0, float(counts @ (levels - mean) ** 2 / total))
        seen = np.nonzero(counts)[0]
        out["min"].append(float(seen[0]))
        out["max"].append(float(seen[-1]))
        out["mean"].append(mean)
        out["std"].append(variance**0.5)
    result = {k: np.asarray(v).reshape(-1, 1, 1) / 255.0 for k, v in out.items()}
    result["count"] = np.array([sum(times)])
    return result


def aggregate(parts: Sequence[Stats]) -> Stats:
    """One feature's statistics over several episodes (counts weigh the means; the
    variance by the parallel algorithm)."""
    means = np.stack([np.asarray(p["mean"], dtype=np.float64) for p in parts])
    variances = np.stack([np.asarray(p["std"], dtype=np.float64) ** 2 for p in parts])
    counts = np.stack([np.asarray(p["count"], dtype=np.float64) for p in parts])
    total = counts.sum(axis=0)
    while counts.ndim < means.ndim:
        counts = counts[..., None]
    mean = (means * counts).sum(axis=0) / total
    variance = ((variances + (means - mean) ** 2) * counts).sum(axis=0) / total
    return {
        "min": np.min(np.stack([np.asarray(p["min"]) for p in parts]), axis=0),
        "max": np.max(np.stack([np.asarray(p["max"]) for p in parts]), axis=0),
        "mean": mean,
        "std": np.sqrt(variance),
        "count": total.astype(np.int64),
    }


def aggregate_all(parts: Sequence[dict[str, Stats]]) -> dict[str, Stats]:
    """Every feature's statistics over several sets (a feature missing from some is
    aggregated over the others)."""
    keys = list(dict.fromkeys(key for part in parts for key in part))
    return {key: aggregate([p[key] for p in parts if key in p]) for key in keys}


def to_json(stats: dict[str, Stats]) -> dict[str, dict[str, Any]]:
    """``stats`` as plain lists and numbers (stats.json)."""
    return {
        feature: {name: np.asarray(value).tolist() for name, value in values.items()}
        for feature, values in stats.items()
    }


def from_json(data: dict[str, dict[str, Any]]) -> dict[str, Stats]:
    """stats.json read back as arrays."""
    return {
        feature: {name: np.atleast_1d(np.asarray(value)) for name, value in values.items()}
        for feature, values in data.items()
    }


__all__ = [
    "aggregate",
    "aggregate_all",
    "downsample",
    "from_json",
    "of_images",
    "of_values",
    "sample_indices",
    "to_json",
]
