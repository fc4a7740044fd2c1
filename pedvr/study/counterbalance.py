"""Counterbalancing: balanced Latin squares and left/right assignment.

PedVR §6.4 presents the scenarios, and the three conditions inside each
scenario, "in a counterbalanced order". A balanced Latin square (Williams
1949) has every condition in every position equally often and every
condition immediately followed by every other equally often. For an odd
number of conditions that needs the square and its mirror image, so for the
three conditions of the paper the square has 2 × 3 = 6 rows: all 6 orders.

Assignment is a pure function of the participant number (``P07`` → 7), so a
restarted session gets the same orders and any participant's orders can be
recomputed from the protocol alone.
"""

from __future__ import annotations

import zlib

import numpy as np


def balanced_latin_square(n: int) -> list[list[int]]:
    """Rows of a balanced Latin square over ``0..n-1`` (n rows if n is even, 2n if odd).

    First row ``0, 1, n-1, 2, n-2, ...``; row ``i`` adds ``i`` modulo ``n``;
    for odd ``n`` the reversed rows follow.
    """
    if n < 1:
        raise ValueError(f"balanced_latin_square: n = {n}: must be >= 1")
    first = [0]
    lo, hi = 1, n - 1
    take_lo = True
    while len(first) < n:
        if take_lo:
            first.append(lo)
            lo += 1
        else:
            first.append(hi)
            hi -= 1
        take_lo = not take_lo
    rows = [[(c + i) % n for c in first] for i in range(n)]
    if n % 2 == 1:
        rows += [list(reversed(r)) for r in rows]
    return rows


def square_row(*, number: int, n: int, offset: int = 0) -> list[int]:
    """The order for participant ``number`` (1-based) from the balanced square over ``n``.

    Participant 1 gets row ``offset``, participant 2 the next row, and so on
    cyclically; a multiple of the row count of consecutive participants
    therefore covers every row equally often. ``offset`` lets two blocks of the
    same participant use different rows.
    """
    rows = balanced_latin_square(n)
    return rows[(number - 1 + offset) % len(rows)]


def rows_in_square(n: int) -> int:
    return len(balanced_latin_square(n))


def left_right_flipped(*, number: int, block: int, comparison: int, cycle: int) -> bool:
    """Whether comparison ``comparison`` of block ``block`` is shown right-to-left.

    The fixed orientation puts a comparison's first condition on the left.
    Flipping alternates between consecutive participants, between comparisons
    and between blocks, and inverts every ``cycle`` participants (``cycle`` =
    rows of the condition square), so each order row meets each comparison
    both ways round over 2 × ``cycle`` participants.
    """
    k = number - 1
    return (k + comparison + block + k // cycle) % 2 == 1


def stable_seed(*parts: int | str) -> int:
    """A 32-bit seed from integers and strings, stable across processes (unlike ``hash``)."""
    ints = [p if isinstance(p, int) else zlib.crc32(p.encode("utf-8")) for p in parts]
    return int(np.random.SeedSequence([abs(i) for i in ints]).generate_state(1)[0])


def random_order(*, n: int, seed: int) -> list[int]:
    """A seeded random permutation of ``0..n-1`` (PedVR §6.4: corridor trials "in random order")."""
    return [int(i) for i in np.random.default_rng(seed).permutation(n)]
