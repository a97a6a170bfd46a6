"""Sketch images in, network inputs out: reading and checking a sketch, turning it into an
ink map, normalising it the same way for user sketches and training renders, and the
distance transform of the refinement score.

Sketches are dark lines on a light background (a transparent background counts as white).
The network input is `RES x RES` (128, as the paper's regression networks): an "anchor"-framed
canvas is resized as a whole (its aspect ratio is the stage's, checked on input); a "fit"-framed
sketch is cropped to its drawn extent and scaled to fill the input with a fixed margin.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from grammarkit.errors import ShapeError

RES = 128
FIT_MARGIN = 0.06  # free border around a fit-framed drawing, fraction of RES
INK_THRESHOLD = 0.08  # ink level below which a pixel counts as paper
MIN_SIDE = 32  # smallest sketch image side accepted, pixels
ASPECT_TOLERANCE = 0.04
MAX_PIXELS = 40_000_000  # largest sketch image read, pixels (a 6,000 x 6,000 scan fits)


class SketchError(ShapeError):
    """A sketch image (or stroke list) that cannot be recognised: names the input and says why."""


def _name(source: Any) -> str:
    return str(source) if isinstance(source, (str, Path)) else "<sketch>"


def _check_pixels(name: str, w: int, h: int) -> None:
    if w * h > MAX_PIXELS:
        raise SketchError(f"{name}: image is {w}x{h} pixels ({w * h / 1e6:.0f} megapixels); a "
                          f"sketch may have at most {MAX_PIXELS / 1e6:.0f} megapixels (scale it "
                          f"down: the recognizer reads it at {RES}x{RES})")


def _read_image(p: Path) -> Any:
    """The decoded image of file `p`, or a SketchError naming it: unreadable, damaged, or
    larger than MAX_PIXELS (checked from the header, before anything is decoded: PIL's own
    guard, DecompressionBombError, fires only at twice its warning size and as an exception
    of its own)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(p) as im:
            _check_pixels(str(p), *im.size)
            im.load()
            return im.copy()
    except SketchError:
        raise
    except Image.DecompressionBombError as exc:  # raised by open() from the header's size
        import re

        found = re.search(r"\((\d+) pixels\)", str(exc))
        size = f"{int(found.group(1)) / 1e6:.0f} megapixels" if found else "too many pixels"
        raise SketchError(f"{p}: image is {size}; a sketch may have at most "
                          f"{MAX_PIXELS / 1e6:.0f} megapixels (scale it down: the recognizer "
                          f"reads it at {RES}x{RES})") from None
    except UnidentifiedImageError as exc:
        raise SketchError(f"{p}: not a readable image ({exc.__class__.__name__}: "
                          f"{str(exc).splitlines()[0] if str(exc) else ''}); expected a PNG, "
                          "JPEG or other raster image") from None
    except (OSError, ValueError, SyntaxError, EOFError, MemoryError, IndexError,
            TypeError) as exc:  # what PIL's decoders raise for damaged files
        raise SketchError(f"{p}: damaged or unreadable image ({exc.__class__.__name__}: "
                          f"{str(exc).splitlines()[0] if str(exc) else ''})") from None


def load_ink(source: Any) -> np.ndarray:
    """Ink map (float32 H x W in [0, 1], 1 = black) from a path, a PIL image or an array.

    Arrays: 2-D greyscale (0-255 or 0-1, white paper) or H x W x 3/4. Raises SketchError for a
    missing or unreadable file, an image that is too small, or one with nothing drawn on it.
    """
    from PIL import Image

    name = _name(source)
    if isinstance(source, (str, Path)):
        p = Path(source)
        if not p.is_file():
            raise SketchError(f"{p}: sketch image not found")
        source = _read_image(p)
    if isinstance(source, Image.Image):
        img = source
        _check_pixels(name, *img.size)
        if img.mode in ("RGBA", "LA", "PA") or (img.mode == "P" and "transparency" in img.info):
            rgba = img.convert("RGBA")
            white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
            img = Image.alpha_composite(white, rgba)
        grey = np.asarray(img.convert("L"), dtype=np.float32) / 255.0
        ink = 1.0 - grey
    else:
        arr = np.asarray(source)
        if arr.dtype == object or arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] not in (3, 4)):
            raise SketchError(f"{name}: expected an image or an H x W (x 3/4) array, got shape "
                              f"{getattr(arr, 'shape', None)}")
        _check_pixels(name, arr.shape[1], arr.shape[0])
        a = arr.astype(np.float32)
        if a.size and a.max() > 1.0:
            a = a / 255.0
        if a.ndim == 3:
            a = a[..., :3].mean(axis=2) if a.shape[2] == 3 else (
                1.0 - a[..., 3] * (1.0 - a[..., :3].mean(axis=2)))
        ink = 1.0 - a
    ink = np.clip(np.nan_to_num(ink, nan=0.0), 0.0, 1.0).astype(np.float32)
    h, w = ink.shape
    if min(h, w) < MIN_SIDE:
        raise SketchError(f"{name}: image is {w}x{h} pixels; a sketch needs at least "
                          f"{MIN_SIDE} pixels on each side")
    # Paper that is not white (a scan, a grey background) is levelled to the median.
    paper = float(np.median(ink))
    if paper > 0.5:
        raise SketchError(f"{name}: the image is mostly dark; expected dark lines on light paper")
    ink = np.clip((ink - paper) / max(1.0 - paper, 1e-6), 0.0, 1.0)
    if not (ink > 0.25).any():
        raise SketchError(f"{name}: the image is blank: no strokes found")
    return ink


def check_aspect(ink: np.ndarray, canvas: tuple[int, int], what: str) -> None:
    """An anchor-framed sketch must be drawn on the stage's canvas (same aspect ratio)."""
    h, w = ink.shape
    want = canvas[0] / canvas[1]
    got = w / h
    if abs(got / want - 1.0) > ASPECT_TOLERANCE:
        raise SketchError(f"{what}: the sketch is {w}x{h} pixels (aspect {got:.2f}) but the "
                          f"canvas of this object type is {canvas[0]}x{canvas[1]} (aspect "
                          f"{want:.2f}); draw on a canvas of that shape (any resolution), "
                          "e.g. the one `grammarkit recognize --canvas` writes")


def resize(ink: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    from PIL import Image

    img = Image.fromarray(np.clip(ink * 255.0, 0, 255).astype(np.uint8), "L")
    if img.size == tuple(size):
        return ink.astype(np.float32)
    resample = Image.Resampling.BOX if img.width >= size[0] and img.height >= size[1] else \
        Image.Resampling.BILINEAR
    return np.asarray(img.resize(size, resample), dtype=np.float32) / 255.0


def level(x: np.ndarray) -> np.ndarray:
    """Lines thinner than a pixel after resizing come out grey: scale the ink so the typical
    line is black again (robust to a few dark specks), whatever the pen width was."""
    lit = x[x > INK_THRESHOLD]
    if lit.size == 0:
        return x
    top = float(np.percentile(lit, 90))
    return np.clip(x / max(top, 0.25), 0.0, 1.0).astype(np.float32)


def ink_bbox(ink: np.ndarray) -> tuple[int, int, int, int] | None:
    ys, xs = np.nonzero(ink > INK_THRESHOLD)
    if len(xs) == 0:
        return None
    return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1


def fit_transform(ink: np.ndarray, res: int = RES) -> tuple[float, float, float]:
    """(scale, dx, dy) mapping canvas pixels to network-input pixels for fit framing."""
    box = ink_bbox(ink)
    if box is None:
        return 1.0, 0.0, 0.0
    x0, y0, x1, y1 = box
    inner = res * (1.0 - 2.0 * FIT_MARGIN)
    scale = inner / max(x1 - x0, y1 - y0, 1)
    dx = (res - scale * (x1 - x0)) / 2.0 - scale * x0
    dy = (res - scale * (y1 - y0)) / 2.0 - scale * y0
    return scale, dx, dy


def to_input(ink: np.ndarray, framing: str, res: int = RES) -> np.ndarray:
    """The network input (float32 res x res, ink in [0, 1]) of a full-canvas ink map."""
    if framing == "fit":
        from PIL import Image

        scale, dx, dy = fit_transform(ink, res)
        img = Image.fromarray(np.clip(ink * 255.0, 0, 255).astype(np.uint8), "L")
        # an affine resampling (not crop + resize) keeps sub-pixel placement exact
        inv = (1.0 / scale, 0.0, -dx / scale, 0.0, 1.0 / scale, -dy / scale)
        if scale < 1.0:  # shrinking: pre-filter so thin lines do not vanish between samples
            k = int(np.floor(1.0 / scale))
            if k >= 2:
                img = img.reduce(k)
                inv = (inv[0] / k, 0.0, inv[2] / k, 0.0, inv[4] / k, inv[5] / k)
        out = img.transform((res, res), Image.Transform.AFFINE, inv, Image.Resampling.BILINEAR,
                            fillcolor=0)
        x = np.asarray(out, dtype=np.float32) / 255.0
    else:
        x = resize(ink, (res, res))
    return level(x)


def distance_map(x: np.ndarray) -> np.ndarray:
    """D(I) of the refinement score: the Euclidean distance (in input pixels) from every pixel
    to the nearest line pixel (scipy's exact EDT)."""
    from scipy.ndimage import distance_transform_edt

    lines = x > 0.5
    if not lines.any():
        return np.full(x.shape, float(max(x.shape)), dtype=np.float32)
    return distance_transform_edt(~lines).astype(np.float32)
