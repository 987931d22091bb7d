"""Time series: numeric columns of one or more files (batches), rows in time order, as
sensor loggers write them (``volerr thermal-fit`` reads them). Every column must be a finite
number; the files of one series share their header.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base import InputError, same_file
from ._table import MeasurementError, read_table

__all__ = ["SeriesData", "read_series"]


@dataclass(frozen=True)
class SeriesData:
    """Numeric columns of one or more files, rows in time order; ``batch`` (n,) file index.

    Attributes
    ----------
    sources : tuple of str
        The files, in order.
    columns : dict of str to ndarray
        Column name -> values, shape (n,), in the file's units.
    batch : ndarray of int, shape (n,)
        Index (into ``sources``) of the file of each row.
    """

    sources: tuple[str, ...]
    columns: dict
    batch: np.ndarray

    @property
    def n(self) -> int:
        """Number of rows (int)."""
        return len(self.batch)


def read_series(paths) -> SeriesData:
    """Read numeric CSV files with the same header (a byte-order mark is tolerated).

    Parameters
    ----------
    paths : str, Path or iterable of them
        The files, in time order.

    Returns
    -------
    SeriesData
        The rows of all files, stacked.

    Raises
    ------
    InputError
        If no file is given.
    MeasurementError
        If a file is given twice, a file cannot be read, a value is not a finite number or beyond +-1e15 (no reading
        in any unit reaches it; docs/measurements.md), or the headers differ.
    """
    paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
    if not paths:
        raise InputError("no data files")
    for i, path in enumerate(paths):
        for earlier in paths[:i]:
            if same_file(path, earlier):
                raise MeasurementError(f"{path}: given twice (as {earlier}); each batch is one file, read once")
    header, blocks, batch = None, [], []
    for i, path in enumerate(paths):
        table = read_table(path)
        if header is None:
            header = table.header
        elif table.header != header:
            raise MeasurementError(f"{table.path}:{table.header_line}: columns differ from {paths[0]}")
        blocks.append(np.column_stack([table.column(c, limit="reading") for c in range(len(header))]))
        batch.append(np.full(len(table.rows), i))
    values = np.vstack(blocks)
    return SeriesData(tuple(str(p) for p in paths), {h: values[:, j] for j, h in enumerate(header)},
                      np.concatenate(batch))
