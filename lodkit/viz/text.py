"""A built-in 5x7 pixel font for labels (no font files, no Pillow)."""
from __future__ import annotations

import numpy as np

# A 5x7 pixel font (rows top to bottom, 5 bits each, most significant = left): digits,
# capitals (lower case is drawn as capitals) and some punctuation; "?" for the rest.
_GLYPHS = {
    "0": (14, 17, 19, 21, 25, 17, 14), "1": (4, 12, 4, 4, 4, 4, 14), "2": (14, 17, 1, 2, 4, 8, 31),
    "3": (31, 2, 4, 2, 1, 17, 14), "4": (2, 6, 10, 18, 31, 2, 2), "5": (31, 16, 30, 1, 1, 17, 14),
    "6": (6, 8, 16, 30, 17, 17, 14), "7": (31, 1, 2, 4, 8, 8, 8), "8": (14, 17, 17, 14, 17, 17, 14),
    "9": (14, 17, 17, 15, 1, 2, 12),
    "A": (14, 17, 17, 31, 17, 17, 17), "B": (30, 17, 17, 30, 17, 17, 30), "C": (14, 17, 16, 16, 16, 17, 14),
    "D": (28, 18, 17, 17, 17, 18, 28), "E": (31, 16, 16, 30, 16, 16, 31), "F": (31, 16, 16, 30, 16, 16, 16),
    "G": (14, 17, 16, 23, 17, 17, 15), "H": (17, 17, 17, 31, 17, 17, 17), "I": (14, 4, 4, 4, 4, 4, 14),
    "J": (7, 2, 2, 2, 2, 18, 12), "K": (17, 18, 20, 24, 20, 18, 17), "L": (16, 16, 16, 16, 16, 16, 31),
    "M": (17, 27, 21, 21, 17, 17, 17), "N": (17, 17, 25, 21, 19, 17, 17), "O": (14, 17, 17, 17, 17, 17, 14),
    "P": (30, 17, 17, 30, 16, 16, 16), "Q": (14, 17, 17, 17, 21, 18, 13), "R": (30, 17, 17, 30, 20, 18, 17),
    "S": (15, 16, 16, 14, 1, 1, 30), "T": (31, 4, 4, 4, 4, 4, 4), "U": (17, 17, 17, 17, 17, 17, 14),
    "V": (17, 17, 17, 17, 17, 10, 4), "W": (17, 17, 17, 21, 21, 21, 10), "X": (17, 17, 10, 4, 10, 17, 17),
    "Y": (17, 17, 17, 10, 4, 4, 4), "Z": (31, 1, 2, 4, 8, 16, 31),
    " ": (0, 0, 0, 0, 0, 0, 0), ".": (0, 0, 0, 0, 0, 12, 12), ",": (0, 0, 0, 0, 12, 4, 8),
    "-": (0, 0, 0, 31, 0, 0, 0), "+": (0, 4, 4, 31, 4, 4, 0), "%": (24, 25, 2, 4, 8, 19, 3),
    ":": (0, 12, 12, 0, 12, 12, 0), "=": (0, 0, 31, 0, 31, 0, 0), "(": (2, 4, 8, 8, 8, 4, 2),
    ")": (8, 4, 2, 2, 2, 4, 8), "/": (0, 1, 2, 4, 8, 16, 0), "_": (0, 0, 0, 0, 0, 0, 31),
    "?": (14, 17, 1, 2, 4, 0, 4), "'": (4, 4, 8, 0, 0, 0, 0), "<": (2, 4, 8, 16, 8, 4, 2),
    ">": (8, 4, 2, 1, 2, 4, 8), "#": (10, 10, 31, 10, 31, 10, 10), "[": (14, 8, 8, 8, 8, 8, 14),
    "]": (14, 2, 2, 2, 2, 2, 14), "*": (0, 4, 21, 14, 21, 4, 0), "|": (4, 4, 4, 4, 4, 4, 4),
}
_GLYPH_BITS = {k: np.array([[(row >> (4 - i)) & 1 for i in range(5)] for row in v], dtype=bool)
               for k, v in _GLYPHS.items()}


def _text_mask(text: str, scale: int) -> np.ndarray:
    """Boolean (7*scale, (6*len - 1)*scale) mask of ``text`` in the 5x7 font."""
    if not text:
        return np.zeros((7 * scale, 0), dtype=bool)
    cells = []
    for ch in text:
        g = _GLYPH_BITS.get(ch.upper(), _GLYPH_BITS["?"])
        cells += [g, np.zeros((7, 1), dtype=bool)]
    mask = np.concatenate(cells[:-1], axis=1)
    return np.kron(mask, np.ones((scale, scale), dtype=bool))


def text_size(text: str, scale: int = 2) -> tuple[int, int]:
    """(height, width) in pixels of ``text`` drawn by :func:`draw_text`."""
    return 7 * scale, max(0, (6 * len(text) - 1) * scale)


def draw_text(image: np.ndarray, text: str, x: int, y: int, color=(30, 30, 30), scale: int = 2) -> np.ndarray:
    """Write ``text`` into ``image`` (H, W, 3) uint8 in place with its top-left corner at
    (x, y), in a built-in 5x7 pixel font magnified ``scale`` times (lower case comes out as
    capitals); what falls outside the image is cut. Returns ``image``."""
    mask = _text_mask(str(text), int(scale))
    h, w = mask.shape
    H, W = image.shape[:2]
    x0, y0 = max(0, x), max(0, y)
    x1, y1 = min(W, x + w), min(H, y + h)
    if x1 > x0 and y1 > y0:
        sub = mask[y0 - y:y1 - y, x0 - x:x1 - x]
        image[y0:y1, x0:x1][sub] = np.asarray(color, dtype=np.uint8)
    return image
