"""Image files and arrays in: PNG through the core, JPEG and TIFF through Pillow, FITS through
astropy, colour to luminance, and the pixel types the core reads in place."""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import Any, Union

import numpy as np
import numpy.typing as npt

from . import _starid
from ._errors import InvalidInputError
from ._files import checked_input

__all__ = ["LUMA_WEIGHTS", "MAX_IMAGE_PIXELS", "read_image"]

PathLike = Union[str, "os.PathLike[str]"]

_PIL_SUFFIXES = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".gif", ".webp"}
_FITS_SUFFIXES = (".fits", ".fit", ".fts", ".fits.gz", ".fit.gz")


#: Largest image read, in pixels (``STARID_MAX_IMAGE_PIXELS`` changes it): checked from the file's
#: header before its pixels are decoded. Pillow's own limit (``PIL.Image.MAX_IMAGE_PIXELS``,
#: twice which it refuses a file) applies to PNG, JPEG and TIFF as well; the default is that.
MAX_IMAGE_PIXELS = int(os.environ.get("STARID_MAX_IMAGE_PIXELS", 178_956_970))


def _check_pixels(p: Path, width: int, height: int) -> None:
    if width * height > MAX_IMAGE_PIXELS:
        raise InvalidInputError(
            f"{p}: {width} x {height} pixels, over the {MAX_IMAGE_PIXELS}-pixel limit (STARID_MAX_IMAGE_PIXELS raises it)"
        )


def read_image(path: PathLike) -> npt.NDArray[Any]:
    """Read an image file as a 2-D array (H, W): uint8 or uint16 as stored, float32 otherwise
    (colour converted to luminance): PNG (8 or 16 bit) decoded by the core, JPEG (a colour one
    as its luminance channel) and TIFF through Pillow, FITS through astropy
    (``pip install 'starid-solver[fits]'``; the first image HDU).

    A file that is not a regular file, is over :data:`~starid._files.MAX_FILE_BYTES` or
    :data:`MAX_IMAGE_PIXELS`, or cannot be decoded (truncated, corrupt, a decompression bomb)
    raises InvalidInputError naming it, never the reader's own exception."""
    p = checked_input(path, "image")
    name = p.name.lower()
    if name.endswith(_FITS_SUFFIXES):
        try:
            from astropy.io import fits  # type: ignore[import-untyped,import-not-found,unused-ignore]
        except ImportError:
            raise ImportError("reading FITS images needs astropy: pip install 'starid-solver[fits]'") from None
        try:
            # The file is ours to close (astropy's handle would live on in a traceback).
            with open(p, "rb") as fh, fits.open(fh, memmap=False) as hdus:
                data = None
                for h in hdus:
                    shape = [int(h.header.get(f"NAXIS{k}", 0)) for k in range(1, int(h.header.get("NAXIS", 0)) + 1)]
                    if len(shape) >= 2 and all(n > 0 for n in shape):
                        _check_pixels(p, shape[0], int(np.prod(shape[1:])))
                        data = np.asarray(h.data)
                        break
        except InvalidInputError:
            raise
        except Exception as e:  # astropy raises OSError, TypeError, ValueError... for broken files
            raise InvalidInputError(f"{p}: not a readable FITS file ({type(e).__name__}: {e})") from None
        if data is None:
            raise InvalidInputError(f"{p}: holds no image")
        return _as_image(data, str(p))
    if p.suffix.lower() == ".png":
        # The core decodes PNG itself (one pass, grey as stored); what it cannot read, Pillow tries.
        try:
            return _as_image(_starid.read_png(os.fspath(p), MAX_IMAGE_PIXELS), str(p))
        except (InvalidInputError, OSError):
            pass
    if p.suffix.lower() in _PIL_SUFFIXES:
        try:
            from PIL import Image
        except ImportError:
            raise ImportError("reading PNG/JPEG/TIFF images needs Pillow: pip install Pillow") from None
        try:
            with warnings.catch_warnings():
                # Our own pixel limit stands in for Pillow's decompression-bomb warning.
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                with Image.open(p) as im:
                    _check_pixels(p, *im.size)
                    # A colour JPEG holds its luminance as a channel of its own (Y of YCbCr,
                    # BT.601): decoded alone, with no colour planes built.
                    if im.format == "JPEG" and im.mode in ("RGB", "YCbCr"):
                        im.draft("L", im.size)
                    # RGB(A) as stored, to luminance in the core (one pass); other colour
                    # modes to luminance in Pillow, straight to float32.
                    if im.mode in _PIL_RGB_MODES:
                        arr = np.asarray(im)
                    else:
                        arr = np.asarray(im.convert("F") if im.mode in _PIL_COLOUR_MODES else im)
        except InvalidInputError:
            raise
        except Exception as e:  # Pillow raises OSError, ValueError, DecompressionBombError, SyntaxError...
            raise InvalidInputError(f"{p}: not a readable image ({type(e).__name__}: {e})") from None
        return _as_image(arr, str(p))
    raise InvalidInputError(f"{p}: unsupported image format {p.suffix or '(none)'}: PNG, JPEG, TIFF or FITS")


#: Pillow modes read as luminance (ITU-R 601 weights, as Pillow converts them).
_PIL_COLOUR_MODES = ("RGB", "RGBA", "RGBX", "P", "PA", "LA", "CMYK", "YCbCr")

#: Pillow modes whose 8-bit channels are red, green and blue (and alpha or padding): read as
#: stored and converted to luminance by the core.
_PIL_RGB_MODES = ("RGB", "RGBA", "RGBX")

#: Luminance weights of red, green and blue (ITU-R 601, Pillow's "L" and "F" conversion, and
#: the core's).
LUMA_WEIGHTS = (0.299, 0.587, 0.114)

#: Pixel types the core reads in place; other real types are converted to float32.
_NATIVE_DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.float32))


def image_size_of(image: Any) -> "tuple[float, float] | None":
    """An image's (width, height) without decoding its pixels: an array's shape, a PNG's
    header, or Pillow's reading of a JPEG's or TIFF's; None where that is not at hand (FITS,
    an unreadable file: reading it says what is wrong)."""
    if isinstance(image, np.ndarray):
        return (float(image.shape[1]), float(image.shape[0])) if image.ndim in (2, 3) else None
    if not isinstance(image, (str, os.PathLike)):
        return None
    name = os.fspath(image).lower()
    if not os.path.isfile(image):
        return None  # (a pipe or a device is refused by the read, never opened here)
    try:
        if name.endswith(".png"):
            with open(image, "rb") as fh:
                head = fh.read(24)
            if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
                return (float(int.from_bytes(head[16:20], "big")), float(int.from_bytes(head[20:24], "big")))
            return None
        if name.endswith(tuple(_PIL_SUFFIXES)):
            from PIL import Image

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the read warns, if there is cause
                with Image.open(image) as im:
                    return (float(im.size[0]), float(im.size[1]))
    except Exception:  # a probe: the read reports what is wrong with the file
        return None
    return None


def _as_image(arr: Any, name: str = "image") -> npt.NDArray[Any]:
    """A 2-D image from an array: (H, W), or (H, W, 3|4) colour → luminance (float32, in the
    core). uint8, uint16 and float32 stay as they are (the core reads them in place); other
    real types become float32."""
    a = np.asarray(arr)
    colour = a.ndim == 3 and a.shape[2] in (3, 4)
    if a.ndim != 2 and not colour:
        raise InvalidInputError(f"{name} must be a 2-D image (H, W) or colour (H, W, 3), got shape {a.shape}")
    if not np.issubdtype(a.dtype, np.number) or np.issubdtype(a.dtype, np.complexfloating):
        raise InvalidInputError(f"{name} must hold real numbers, got {a.dtype}")
    if colour:
        a = _starid.luminance(a if a.dtype in _NATIVE_DTYPES else a.astype(np.float32))
    img = np.ascontiguousarray(a, dtype=a.dtype if a.dtype in _NATIVE_DTYPES else np.float32)
    if img.shape[0] < 3 or img.shape[1] < 3:
        raise InvalidInputError(f"{name} must be at least 3 x 3 pixels, got {img.shape}")
    if img.dtype == np.float32 and not np.isfinite(img).any():
        raise InvalidInputError(f"{name} holds no finite pixel")
    return img


def _load(image: Any) -> npt.NDArray[Any]:
    if isinstance(image, (str, os.PathLike)):
        return read_image(image)
    return _as_image(image)
