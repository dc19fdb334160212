"""Spots extracted from an image (a leaf module: identification reads them without the image code)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

#: Spot flags (bits of :attr:`Centroids.flags`).
FLAGS = {"hot_pixel": 1, "saturated": 2, "elongated": 4, "border": 8, "deblended": 16, "cluttered": 32}


@dataclass(frozen=True)
class Centroids:
    """Spots extracted from an image, brightest first.

    ``xy`` (N, 2) pixels (x right, y down, origin at the top-left corner: the centre of pixel
    ``(i, j)`` is ``(i + 0.5, j + 0.5)``), ``flux`` (background subtracted), ``magnitudes``
    (instrument, ``-2.5 log10 flux``), ``peak``, ``pixels`` (above the threshold),
    ``elongation``, ``flags`` (:data:`FLAGS` bits: saturated, border, deblended; hot pixels,
    elongated spots and spots on a cluttered background, such as branches or a roof, are
    dropped unless ``drop_flagged=False``), and of the image: ``image_size``,
    ``background`` (median level), ``noise_sigma``, ``hot_pixels`` (cleaned), ``dropped``.
    """

    xy: npt.NDArray[np.float64]
    flux: npt.NDArray[np.float64]
    magnitudes: npt.NDArray[np.float64]
    peak: npt.NDArray[np.float64]
    pixels: npt.NDArray[np.int64]
    elongation: npt.NDArray[np.float64]
    flags: npt.NDArray[np.uint8]
    image_size: tuple[float, float]
    background: float
    noise_sigma: float
    hot_pixels: int
    dropped: int
    #: Seconds spent reading the image file (0 for an array) and extracting its spots.
    read_s: float = 0.0
    extract_s: float = 0.0

    def __len__(self) -> int:
        return int(self.xy.shape[0])
