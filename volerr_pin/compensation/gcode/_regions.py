"""Kept regions: modes under which a program's coordinates are not axis positions or tool tips.

Polar and cylindrical interpolation, polar coordinates, rotated, tilted, scaled or mirrored
coordinates, a tool orientation given as a vector, a shifted zero (G52, G92) or a work offset
changed by the program (G10 L2 / L20, or G50 with axis words: a Fanuc lathe's coordinate
setting) change how the blocks *after* them are read. A move
read under such a mode as if it were untransformed would be compensated at the wrong place,
so every block from the code that starts the mode up to the block that ends it is kept
unchanged (and named in the report), or refused with ``strict``. Modes nest: a region ends
when every mode started in it has ended.

A region is a tuple ``(what, line, name, ends)``: what it is (for messages), the line that
started it, the code that started it (``"G68.2"``, ``"TRACYL"``) and the codes that end it
(for a shift, the axes still shifted).
"""

from __future__ import annotations

from ._lexer import CYLINDRICAL, OFFSET_DATA, REGIONS, SCALING_OFF, SHIFTS, AXIS_LETTERS as AXES

__all__ = ["follow", "region_of"]



def region_of(g: float, words: list[tuple[str, float]], number: int) -> tuple | None:
    """The region a G code starts, if any.

    Parameters
    ----------
    g : float
        The G code.
    words : list of (str, float)
        The words of its block, (letter, value).
    number : int
        Its line number.

    Returns
    -------
    tuple or None
        The region (see the module docstring); None if the code starts none (a shift of
        every axis it names to zero starts none).
    """
    if g in REGIONS:
        what, ends = REGIONS[g]
        return (f"{what} (G{g:g})", number, f"G{g:g}", ends)
    if g in SHIFTS:
        shifted = tuple(sorted({letter for letter, v in words if letter in AXES and v}))
        return (f"{SHIFTS[g]} (G{g:g})", number, f"G{g:g}", shifted) if shifted else None
    if g == 10 and any(letter == "L" and v in OFFSET_DATA for letter, v in words):
        return ("work offset set by G10 (the origin given no longer holds)", number, "G10", ())
    if g == SCALING_OFF and any(letter in AXES for letter, _ in words):
        # with axis words G50 is no scaling's end but a coordinate setting (Fanuc lathes): not a move
        return ("coordinate system set by G50 with axis words (the origin given no longer holds)", number, "G50", ())
    return None


def keyword_region(keyword: str, number: int) -> tuple | None:
    """The region a Siemens statement starts (TRANSMIT, TRACYL: ended by TRAFOOF), if any.

    Parameters
    ----------
    keyword : str
        The statement, upper case.
    number : int
        Its line number.

    Returns
    -------
    tuple or None
        The region, or None for a statement that starts none.
    """
    if keyword in ("TRANSMIT", "TRACYL"):
        return (f"{keyword} transformation", number, keyword, ("TRAFOOF",))
    return None


def profile_region(cycle: str, p: float, q: float, number: int) -> tuple:
    """The region of a FANUC lathe cycle's profile (G71 / G72 / G73 P Q): the blocks from the
    cycle to the one numbered Q, which the cycle cuts (and the control runs no further).

    Parameters
    ----------
    cycle : str
        The cycle, for messages (``"G71 (FANUC lathe stock removal in turning)"``).
    p, q : float
        Its P and Q words: the sequence numbers of the profile's first and last block.
    number : int
        The cycle's line number.

    Returns
    -------
    tuple
        The region; it ends with the block numbered ``q``.
    """
    return (f"profile N{p:g} - N{q:g} of the {cycle}", number, "PROFILE", (q,))


def _ends(region: tuple, words: list[tuple[str, float]], gs: list[float], keyword: str) -> tuple | None:
    """The region after a block inside it: None if the block ends it."""
    what, first, name, ends = region
    if name == "PROFILE":
        return None if any(letter == "N" and v == ends[0] for letter, v in words) else region
    if keyword:
        return None if keyword in ends else region
    if name == f"G{CYLINDRICAL:g}":  # G7.1 C0 ends it
        done = CYLINDRICAL in gs and any(letter in AXES and v == 0 for letter, v in words)
        return None if done else region
    if name in {f"G{g:g}" for g in SHIFTS}:  # ``ends``: the axes still shifted
        if float(name[1:]) not in gs:
            return region
        shifted = set(ends)
        for letter, v in words:
            if letter in AXES:
                (shifted.add if v else shifted.discard)(letter)
        return (what, first, name, tuple(sorted(shifted))) if shifted else None
    return None if any(g in ends for g in gs) else region


def follow(regions: list[tuple], words: list[tuple[str, float]], keyword: str, number: int) -> list[tuple]:
    """The regions in force after a block read inside them.

    Parameters
    ----------
    regions : list of tuple
        The regions in force before the block (not empty), oldest first.
    words : list of (str, float)
        The block's words, (letter, value).
    keyword : str
        The Siemens statement the block is (upper case), or empty.
    number : int
        Its line number.

    Returns
    -------
    list of tuple
        The regions in force after it: those it does not end, then those it starts.
    """
    gs = [v for letter, v in words if letter == "G"]
    kept = [r for r in (_ends(r, words, gs, keyword) for r in regions) if r is not None]
    names = {r[2] for r in regions}
    started = [keyword_region(keyword, number)] if keyword else [region_of(g, words, number) for g in gs]
    return kept + [r for r in started if r is not None and r[2] not in names]
