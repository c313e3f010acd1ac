"""The Hampy marker format: a 9x9 grid, black border, seven Hamming(7,4) rows, 28-bit id.

This is the format the Dobot report used (Showers 2016, ref. [10]) as PyPI hampy
1.4.2's ``detect_markers`` reads it:

* the outer ring of cells is black; inside it a 7x7 grid where a white cell
  is a 1 bit;
* the id is written MSB first as 28 bits, cut into seven 4-bit nibbles, one
  per row from the top;
* each row is the Hamming(7,4) code word of its nibble ``(d1, d2, d3, d4)``,
  laid out left to right as ``(p1, p2, d1, p3, d2, d3, d4)`` with
  ``p1 = d1^d2^d4``, ``p2 = d1^d3^d4``, ``p3 = d2^d3^d4``.

Hamming(7,4) is a perfect code: every 7-bit word is at most one bit from
exactly one code word, so a row always "decodes"; what tells a right reading
from a wrong one is how many bits had to be corrected. The decoding tables
here return that count with the nibble.

Not every id makes a usable marker. A marker is read in four orientations and
the one that decodes wins; a clean print must decode in one orientation only,
so an id is *valid* (:func:`id_problem`) when each of its other three quarter
turns is more than ``max_corrected_bits`` bit flips from the grid of any id a
tracker accepts (ids 0 and ``2**28 - 1``, an all-black and an all-white inside,
are never accepted: they have no orientation). Small ids fail: id 1 turned
upside down is one flip from id ``3 << 24``. docs/trackers.md gives the rule's
reasons and the robust ids the shipped profiles use.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

#: Cells along one side of a marker, border included.
GRID = 9
#: Data cells along one side (one code word per row).
BITS = 7
#: Bits of an id, and the first id that does not fit.
ID_BITS = 28
MAX_ID = 1 << ID_BITS

# Generator and parity-check matrices in hampy's bit order (p1 p2 d1 p3 d2 d3 d4).
GENERATOR = np.array(
    [
        [1, 1, 0, 1],
        [1, 0, 1, 1],
        [1, 0, 0, 0],
        [0, 1, 1, 1],
        [0, 1, 0, 0],
        [0, 0, 1, 0],
        [0, 0, 0, 1],
    ],
    dtype=np.uint8,
)
PARITY_CHECK = np.array(
    [[0, 0, 0, 1, 1, 1, 1], [0, 1, 1, 0, 0, 1, 1], [1, 0, 1, 0, 1, 0, 1]], dtype=np.uint8
)
#: Positions of the data bits d1..d4 inside a code word.
DATA_POSITIONS = (2, 4, 5, 6)
#: Weights that turn a row of 7 bits (left to right) into an integer word, MSB first.
ROW_WEIGHTS = 1 << np.arange(BITS - 1, -1, -1)


def _codeword(nibble: int) -> np.ndarray:
    data = np.array([(nibble >> (3 - i)) & 1 for i in range(4)], dtype=np.uint8)
    return (GENERATOR.astype(int) @ data) % 2


#: Code word (7 bits, left to right) of each nibble 0..15.
CODEWORDS = np.array([_codeword(n) for n in range(16)], dtype=np.uint8)


def _decode_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    words = (np.arange(128)[:, None] >> np.arange(BITS - 1, -1, -1)) & 1
    diff = words[:, None, :] != CODEWORDS[None, :, :]
    dist = diff.sum(axis=2)
    nibble = dist.argmin(axis=1)
    nearest = diff[np.arange(128), nibble]
    flip = np.where(nearest.any(axis=1), nearest.argmax(axis=1), -1)
    return nibble.astype(np.int64), dist.min(axis=1).astype(np.int64), flip.astype(np.int64)


#: For each 7-bit word (as an integer, left bit most significant): the nearest
#: code word's nibble, the bits corrected to reach it (0 or 1), and which bit
#: (0-6 from the left, -1 for none).
WORD_NIBBLE, WORD_ERRORS, WORD_FLIP = _decode_tables()


def check_id(marker_id: int) -> int:
    """``marker_id`` as an int, or ``ValueError`` unless ``0 <= id < 2**28``."""
    if isinstance(marker_id, bool) or not isinstance(marker_id, (int, np.integer)):
        raise ValueError(f"a Hamming marker id is an integer, got {marker_id!r}")
    if not 0 <= int(marker_id) < MAX_ID:
        raise ValueError(f"a Hamming marker id must be 0 <= id < 2**28, got {marker_id}")
    return int(marker_id)


def encode_id(marker_id: int) -> np.ndarray:
    """The 7x7 data bits of ``marker_id`` (row r carries nibble r from the MSB end)."""
    marker_id = check_id(marker_id)
    nibbles = [(marker_id >> (4 * (BITS - 1 - r))) & 0xF for r in range(BITS)]
    return CODEWORDS[nibbles].copy()


def marker_grid(marker_id: int) -> np.ndarray:
    """The 9x9 cells of a marker as printed, 1 for white and 0 for black."""
    grid = np.zeros((GRID, GRID), dtype=np.uint8)
    grid[1:-1, 1:-1] = encode_id(marker_id)
    return grid


def decode_bits(bits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Decode data grids ``(..., 7, 7)`` of 0/1 read row by row as printed.

    Returns ``(ids, corrected)``, each of shape ``(...)``: the id of the nearest
    code words, and the number of bits corrected to reach them (at most one per
    row, as Hamming(7,4) allows, so also the number of rows in error).
    """
    words = (np.asarray(bits, dtype=np.int64) * ROW_WEIGHTS).sum(axis=-1)
    nibbles = WORD_NIBBLE[words]
    errors = WORD_ERRORS[words]
    shifts = 4 * np.arange(BITS - 1, -1, -1)
    ids = (nibbles << shifts).sum(axis=-1)
    return ids, errors.sum(axis=-1)


#: Bits between each 7-bit word and each code word, ``(128, 16)``.
WORD_DISTANCES = np.array(
    [[bin(w ^ int(c @ ROW_WEIGHTS)).count("1") for c in CODEWORDS] for w in range(128)],
    dtype=np.int64,
)
#: What an inside never reads as: all black (id 0) and all white (every bit set).
REFUSED_IDS = (0, MAX_ID - 1)
#: Bit corrections the hamming tracker allows by default (``max_corrected_bits``).
DEFAULT_MAX_CORRECTED = 2


def turn_readings(marker_id: int) -> tuple[tuple[int, int], ...]:
    """For each of the id's quarter turns (1, 2, 3, as ``np.rot90``): the fewest bit flips
    that make the turned marker decode as an id other than 0 and ``2**28 - 1``, and that id.

    Rows decode on their own (each to its nearest code word), so the count is the
    rows that are not code words, unless those nearest words spell a refused id:
    then the row cheapest to move goes to its next-nearest code word instead.
    """
    grid = encode_id(marker_id)
    shifts = 4 * np.arange(BITS - 1, -1, -1)
    out = []
    for k in (1, 2, 3):
        words = np.rot90(grid, k) @ ROW_WEIGHTS
        costs = WORD_DISTANCES[words]  # (7, 16)
        nibbles = costs.argmin(axis=1)
        total = int(costs.min(axis=1).sum())
        if (nibbles == 0).all() or (nibbles == 15).all():
            ordered = np.argsort(costs, axis=1, kind="stable")
            extra = costs[np.arange(BITS), ordered[:, 1]] - costs[np.arange(BITS), ordered[:, 0]]
            row = int(extra.argmin())
            nibbles[row] = ordered[row, 1]
            total += int(extra[row])
        out.append((total, int((nibbles << shifts).sum())))
    return tuple(out)


@lru_cache(maxsize=4096)
def id_problem(marker_id: int, max_corrected_bits: int = DEFAULT_MAX_CORRECTED) -> str | None:
    """Why ``marker_id`` is not a valid Hampy marker for a tracker allowing
    ``max_corrected_bits`` corrections, or None when it is (see the module docstring).

    Raises ``ValueError`` for an id outside ``0 <= id < 2**28``.
    """
    marker_id = check_id(marker_id)
    if marker_id == 0:
        return "its inside is all black: no white cell to give it an orientation or data"
    if marker_id == MAX_ID - 1:
        return "its inside is all white: no black cell to give it an orientation or data"
    readings = turn_readings(marker_id)
    k = min(range(3), key=lambda i: readings[i][0])
    flips, other = readings[k]
    if flips <= max_corrected_bits:
        how = "as it is" if flips == 0 else f"after {flips} correction" + "s" * (flips > 1)
        return (
            f"turned {90 * (k + 1)} degrees it reads as id {other} {how} "
            f"(the tracker allows {max_corrected_bits}), so its orientation is not unique"
        )
    return None


def is_valid_id(marker_id: int, max_corrected_bits: int = DEFAULT_MAX_CORRECTED) -> bool:
    """True when ``marker_id`` is in range and :func:`id_problem` finds nothing."""
    try:
        return id_problem(int(marker_id), max_corrected_bits) is None
    except ValueError:
        return False


def valid_ids_near(
    marker_id: int, count: int = 3, max_corrected_bits: int = DEFAULT_MAX_CORRECTED
) -> list[int]:
    """The ``count`` valid ids nearest ``marker_id`` (ties: the smaller first)."""
    centre = min(max(int(marker_id), 0), MAX_ID - 1)
    found: list[int] = []
    step = 0
    while len(found) < count and step < MAX_ID:
        for candidate in (centre - step, centre + step) if step else (centre,):
            valid = 0 <= candidate < MAX_ID and is_valid_id(candidate, max_corrected_bits)
            if valid and candidate not in found:
                found.append(candidate)
        step += 1
    return found[:count]
