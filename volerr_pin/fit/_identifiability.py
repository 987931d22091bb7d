"""Which columns of a sensitivity matrix the data can tell apart, and which they cannot.

:func:`analyse` scales the columns to unit norm and finds, in a stated order:
columns with no effect (``zero``), columns exactly collinear with another (``collinear``),
and columns that are a linear combination of earlier ones (``combination``), keeping one
independent set. Protected columns (nuisance parameters such as an interferometer's zero)
are considered first, so the machine parameters they absorb are the ones reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..base import InputError


@dataclass(frozen=True)
class IdentifiabilityGroup:
    """Coefficients that the data cannot separate, and why.

    Attributes
    ----------
    kind : str
        "zero", "collinear" or "combination".
    parameters : tuple of str
        Column names: for "collinear" the representative (kept) column first, for
        "combination" the dependent column first, then the kept columns it combines.
    factors : tuple of float
        One per parameter, in the columns' own units: (1.0,) for "zero"; for "collinear"
        each column is its factor times the first's; for "combination" 1.0 and the negated
        factors of :func:`analyse`, so that the weighted sum of the columns has no effect.
    reason : str
        The reason, in words.
    """

    kind: str              # "zero", "collinear" or "combination"
    parameters: tuple[str, ...]
    factors: tuple[float, ...]
    reason: str

    def to_dict(self) -> dict:
        """The group as JSON fields.

        Returns
        -------
        dict
            ``kind``, ``parameters`` (list), ``factors`` (list) and ``reason``.
        """
        return {"kind": self.kind, "parameters": list(self.parameters),
                "factors": list(self.factors), "reason": self.reason}


@dataclass(frozen=True)
class Analysis:
    """Result of :func:`analyse`.

    ``kept``: indices of an independent set of columns (protected ones first, then in
    column order); ``dependent``: the others; ``groups``: why each dependent column is
    dependent; ``rank``: numerical rank; ``condition``: condition number of the kept,
    column-scaled matrix (2-norm); ``singular_values`` of that matrix.

    Attributes
    ----------
    kept : tuple of int
        Indices of an independent set of columns.
    dependent : tuple of int
        The other columns, sorted.
    groups : tuple of IdentifiabilityGroup
        Why each dependent column is dependent.
    rank : int
        Numerical rank (number of kept columns).
    condition : float
        Condition number of the kept, column-scaled matrix (inf when none is kept).
    singular_values : ndarray, shape (rank,)
        Singular values of that matrix, largest first.
    """

    kept: tuple[int, ...]
    dependent: tuple[int, ...]
    groups: tuple[IdentifiabilityGroup, ...]
    rank: int
    condition: float
    singular_values: np.ndarray


def analyse(A: np.ndarray, names, *, protected: int = 0, rtol: float = 1e-9,
            what: str = "the measured quantities", typical: np.ndarray | None = None,
            rows: int | None = None) -> Analysis:
    """Identifiability of the columns of ``A`` (rows: weighted observations).

    A column is ``zero`` when its norm is below ``rtol`` times the median column norm; two
    columns are ``collinear`` when the cosine of their angle is within ``rtol`` of +-1; a
    column is a ``combination`` when its component orthogonal to the kept columns is below
    ``sqrt(rtol)`` of its norm, or when the kept set, each column independent of those before
    it, is singular to rounding as a whole (its smallest singular value below ``min(rtol,
    eps * max(rows, n))`` of the largest: near-dependencies chained over several columns);
    then the last column with at least a tenth of the largest weight in that combination (the
    singular vector) goes. Factors: ``A_dependent = sum factor_k A_k`` over the listed
    kept columns (in the columns' own units), so the combination
    ``A_dependent - sum factor_k A_k`` has no effect.

    ``typical`` (one per column, default 1) is a typical size of each coefficient: the zero
    test compares the effects of typical changes (column norm x typical size), so a time
    constant in seconds, whose effect per second is tiny, is not taken for no effect.

    Parameters
    ----------
    A : array_like, shape (rows, n)
        Sensitivity matrix, one column per parameter.
    names : sequence of str
        Name of every column (n).
    protected : int, default 0
        The first ``protected`` columns (nuisance parameters) are considered first, so the
        parameters they absorb are the ones reported.
    rtol : float, default 1e-9
        Relative tolerance of the tests.
    what : str, default "the measured quantities"
        What the rows measure, for the reasons.
    typical : array_like, shape (n,), optional
        Typical size of each coefficient, in its unit.
    rows : int, optional
        Rows of the full design when ``A`` is its triangular factor (for the rounding level of
        the singular-value test); default ``A``'s rows.

    Returns
    -------
    Analysis
        The kept and dependent columns, the groups, the rank and the conditioning.

    Raises
    ------
    InputError
        If ``A`` is not a two-dimensional array of finite numbers, ``names`` does not name
        every column, ``protected`` is not between 0 and the number of columns, ``rtol`` is
        not between 0 and 1, or ``typical`` is not one positive finite size per column.
    """
    try:
        A = np.asarray(A, dtype=float)
    except (TypeError, ValueError):
        raise InputError("A must be a numeric array (rows x columns)", parameters=("A",)) from None
    if A.ndim != 2:
        raise InputError(f"A has shape {A.shape}; expected (rows, columns)", parameters=("A",))
    if not np.all(np.isfinite(A)):
        i, j = np.argwhere(~np.isfinite(A))[0]
        raise InputError(f"A[{i}, {j}] is {A[i, j]}: the sensitivities must be finite", parameters=("A",))
    names = list(names)
    n = A.shape[1]
    if len(names) != n:
        raise InputError(f"names: {len(names)} names for {n} columns", parameters=("names",))
    if not (isinstance(protected, (int, np.integer)) and 0 <= protected <= n):
        raise InputError(f"protected must be a whole number from 0 to {n}, got {protected!r}",
                         parameters=("protected",))
    if not 0.0 < rtol < 1.0:
        raise InputError(f"rtol must be between 0 and 1, got {rtol!r}", parameters=("rtol",))
    if rows is not None and not (isinstance(rows, (int, np.integer)) and rows >= 1):
        raise InputError(f"rows must be a whole number >= 1, got {rows!r}", parameters=("rows",))
    if typical is not None:
        typical = np.asarray(typical, dtype=float)
        if typical.shape != (n,) or not np.all(np.isfinite(typical) & (typical > 0)):
            raise InputError(f"typical must be one positive finite size per column ({n})", parameters=("typical",))
    norms = np.linalg.norm(A, axis=0)
    effect = norms if typical is None else norms * typical
    positive = effect[effect > 0]
    reference = float(np.median(positive)) if positive.size else 1.0
    zero = effect <= rtol * reference
    groups: list[IdentifiabilityGroup] = []
    for j in np.flatnonzero(zero):
        groups.append(IdentifiabilityGroup(
            "zero", (names[j],), (1.0,),
            f"no effect on {what} (e.g. a rotation about a line through the measured point, or a "
            "translation along an unmeasured direction)"))
    U = np.zeros_like(A)
    U[:, ~zero] = A[:, ~zero] / norms[~zero]
    order = [j for j in range(n) if not zero[j]]
    # collinear pairs (cosine +-1)
    parent = {j: j for j in order}

    def find(j):
        while parent[j] != j:
            parent[j] = parent[parent[j]]
            j = parent[j]
        return j

    live = np.array(order, dtype=int)
    if live.size:
        G = U[:, live].T @ U[:, live]
        for a, b in np.argwhere(np.triu(np.abs(np.abs(G) - 1.0) < rtol, k=1)):
            ra, rb = find(live[a]), find(live[b])
            if ra != rb:
                parent[max(ra, rb, key=lambda j: _rank_key(j, protected))] = min(
                    ra, rb, key=lambda j: _rank_key(j, protected))
    members: dict[int, list[int]] = {}
    for j in order:
        members.setdefault(find(j), []).append(j)
    dependent = set(np.flatnonzero(zero).tolist())
    for root, group in members.items():
        if len(group) < 2:
            continue
        group = sorted(group, key=lambda j: _rank_key(j, protected))
        first = group[0]
        factors = tuple(float(A[:, g] @ A[:, first] / (A[:, first] @ A[:, first])) for g in group)
        groups.append(IdentifiabilityGroup(
            "collinear", tuple(names[g] for g in group), factors,
            f"the same effect on {what}, up to the factors given (relative to {names[first]}): "
            "the same displacement reached through different terms or chains"))
        dependent.update(group[1:])
    # combinations: greedy Gram-Schmidt over the representatives, protected columns first
    candidates = sorted((j for j in order if j not in dependent), key=lambda j: _rank_key(j, protected))
    basis = np.zeros((A.shape[0], len(candidates)))   # orthonormal columns of the kept set
    kept: list[int] = []
    combinations: list[int] = []   # dependent columns, each on the kept ones before it
    for j in candidates:
        v = U[:, j].copy()
        B = basis[:, :len(kept)]
        for _ in range(2):  # twice: classical Gram-Schmidt with re-orthogonalisation
            v -= B @ (B.T @ v)
        residual = float(np.linalg.norm(v))
        if residual > math.sqrt(rtol):
            basis[:, len(kept)] = v / residual
            kept.append(j)
            continue
        combinations.append(j)
        dependent.add(j)
    # the test above looks at one column at a time: near-dependencies chained over several
    # columns (a robot's wrist, its axes meeting within a millimetre) can leave the kept set
    # singular to rounding although each column kept more than sqrt(rtol) of itself; the kept
    # set's own singular vectors then name the combination, and its last column (the protected
    # ones come first) among those with at least a tenth of the largest weight in it goes (at
    # rounding level of the full design, or below rtol of the largest singular value when rtol
    # asks for less: 1e-30 turns the analysis off)
    floor = min(rtol, np.finfo(float).eps * max(rows or A.shape[0], A.shape[1]))
    thinned: list[int] = []        # dependent columns, each on all the kept ones
    sv = np.zeros(0)
    while kept:
        _, sv, vt = np.linalg.svd(U[:, kept], full_matrices=False)
        if len(kept) == 1 or sv[-1] > sv[0] * floor:
            break
        weight = np.abs(vt[-1])
        j = max(c for c, w in zip(kept, weight) if w >= 0.1 * weight.max())
        kept.remove(j)
        thinned.append(j)
        dependent.add(j)
    # the factors of every combination, from one least-squares solve over the kept columns
    # (each column kept after a dependent one is independent of it: its factor comes out ~0)
    if combinations or thinned:
        coefs = np.linalg.lstsq(U[:, kept], U[:, combinations + thinned], rcond=None)[0]
        for j, coef in zip(combinations + thinned, coefs.T):
            over = [k for k, c in enumerate(kept)
                    if j in thinned or _rank_key(c, protected) < _rank_key(j, protected)]
            coef = coef[over]
            big = np.flatnonzero(np.abs(coef) > 1e-4 * np.abs(coef).max())
            factors = coef * norms[j] / norms[[kept[k] for k in over]]
            groups.append(IdentifiabilityGroup(
                "combination", (names[j],) + tuple(names[kept[over[k]]] for k in big),
                (1.0,) + tuple(float(-factors[k]) for k in big),
                f"the effect of {names[j]} on {what} equals a combination of the others listed: the "
                "weighted sum with these factors has no effect"))
    condition = float(sv[0] / sv[-1]) if kept else math.inf
    return Analysis(tuple(kept), tuple(sorted(dependent)), tuple(groups), len(kept), condition, sv)


def _rank_key(j: int, protected: int) -> tuple[int, int]:
    """Protected columns first, then column order."""
    return (0 if j < protected else 1, j)
