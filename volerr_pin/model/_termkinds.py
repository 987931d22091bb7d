"""The registry of error-term kinds: which :class:`~volerr_pin.model.Term` class reads a spec
table of each ``kind`` (and ``driver``).

Every class reads its own table (``from_spec``) and writes it back (``to_spec``); this
module only maps names to classes and checks what all tables share (the kind, the prefix,
the keys, where a kind may be used). A new kind is a class with ``keys``, ``from_spec`` and
``to_spec`` and one line here.
"""

from __future__ import annotations

import numpy as np

from ._effects import EFFECTS
from ..base import SpecError
from ._speckeys import NAME_RE, TermSite, check_keys, text
from ._terms import Constant, Polynomial, Table, Term

#: kinds of geometric terms (functions of the axis position only)
GEOMETRIC = {"constant": Constant, "legendre": Polynomial, "monomial": Polynomial, "table": Table}
#: every kind, in the order messages list them
KINDS = tuple(GEOMETRIC) + tuple(dict.fromkeys(kind for kind, _ in EFFECTS))
#: kinds that need a ``driver``
DRIVEN = tuple(dict.fromkeys(kind for kind, driver in EFFECTS if driver is not None))


def term_class(table: dict, where: str) -> type[Term]:
    """The class that reads ``table``, by its ``kind`` (and ``driver``).

    Parameters
    ----------
    table : dict
        A term's spec table.
    where : str
        Where the table is in the spec (for messages).

    Returns
    -------
    type of Term
        A class of :data:`GEOMETRIC` or :data:`~volerr_pin.model.EFFECTS`.

    Raises
    ------
    SpecError
        When the kind is unknown, or a driven kind's ``driver`` is not "time" or "temperature".
    """
    kind = table.get("kind")
    if kind not in KINDS:
        raise SpecError(f"{where}: 'kind' must be one of {', '.join(KINDS)}, got {kind!r}")
    if kind in GEOMETRIC:
        return GEOMETRIC[kind]
    driver = table.get("driver") if kind in DRIVEN else None
    if kind in DRIVEN and driver not in ("time", "temperature"):
        raise SpecError(f"{where}: {kind} needs driver = 'time' or 'temperature', got {driver!r}")
    return EFFECTS[(kind, driver)]


def read_term(table: dict, site: TermSite) -> tuple[str, Term, np.ndarray]:
    """Read one term of a component error.

    Parameters
    ----------
    table : dict
        The term's spec table (``kind``, ``prefix`` and the kind's keys).
    site : TermSite
        Where it is and what it is an error of.

    Returns
    -------
    prefix : str
        The prefix of its coefficient names ("" for none).
    term : Term
    coefficients : ndarray, shape (term.size,)
        SI values.
    """
    where = site.where
    if not isinstance(table, dict):
        raise SpecError(f"{where}: expected a table, got {table!r}")
    cls = term_class(table, where)
    prefix = text(table, "prefix", where, default="")
    if prefix and not NAME_RE.match(prefix):
        raise SpecError(f"{where}: prefix {prefix!r} is not a plain name")
    kind, driver = table["kind"], table.get("driver")
    what = f" for {kind}" + (f" driven by {driver}" if kind in DRIVEN else "")
    check_keys(table, cls.keys | {"kind", "prefix"}, where, what)
    if cls.axis_only and not site.owner_is_axis:
        raise SpecError(f"{where}: a {kind} term belongs to a component error of an axis")
    if cls.linear_length_only and (site.quantity != "length" or site.position_quantity != "length"):
        raise SpecError(f"{where}: a {kind} term is a length error of a linear axis")
    term, coefficients = cls.from_spec(table, site)
    return prefix, term, coefficients
