"""Error maps: the quasi-static error at the nodes of a workspace grid (seed 002, eqs. 7-14).

The workspace of three linear axes is divided into hexahedral elements; inside an element the
error is interpolated from its nodes with serendipity shape functions in natural coordinates
(xi, eta, zeta) in [-1, 1]^3:

- 8 nodes (linear): ``N = (1 + xi xi_i)(1 + eta eta_i)(1 + zeta zeta_i) / 8`` (trilinear, what
  controllers' compensation tables use);
- 20 nodes (quadratic): corners ``N = (1+xi xi_i)(1+eta eta_i)(1+zeta zeta_i)
  (xi xi_i + eta eta_i + zeta zeta_i - 2) / 8``; mid-edge nodes (xi_i = 0)
  ``N = (1 - xi^2)(1 + eta eta_i)(1 + zeta zeta_i) / 4`` and its permutations;
- 32 nodes (cubic): corners ``N = (1+xi xi_i)(1+eta eta_i)(1+zeta zeta_i)
  (9 (xi^2 + eta^2 + zeta^2) - 19) / 64``; edge nodes at xi_i = +-1/3
  ``N = 9 (1 - xi^2)(1 + 9 xi xi_i)(1 + eta eta_i)(1 + zeta zeta_i) / 64`` and permutations.

Each family is a partition of unity, interpolates its nodal values and reproduces complete
polynomials of its order (tests check all three).
"""

from __future__ import annotations

import csv
import itertools
import math
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base import (AXIS_UNIT, InputError, axis_scale, check_output_folder, check_outputs, counts, integer, replacing,
                    require_memory, transaction)
from ..model import Machine, check_covariates, check_q, component_values, tool_poses, volumetric_error

NODES_PER_ORDER = {1: 8, 2: 20, 3: 32}
#: memory of one evaluated point beyond its own arrays (the kinematics' working set) [bytes]
EVALUATION_BYTES = 300
#: nodes of a compensation table compensated and written at once
TABLE_CHUNK = 32768
#: points interpolated at once
INTERPOLATION_CHUNK = 65536


def natural_nodes(order: int) -> np.ndarray:
    """Natural coordinates of the nodes of an element.

    Parameters
    ----------
    order : int
        1 (8 nodes), 2 (20 nodes) or 3 (32 nodes).

    Returns
    -------
    ndarray, shape (n_nodes, 3)
        Node coordinates in [-1, 1]^3: the 8 corners first, then the edge nodes (edges along
        xi, then eta, then zeta).

    Raises
    ------
    InputError
        If ``order`` is not 1, 2 or 3.
    """
    if order not in NODES_PER_ORDER:
        raise InputError(f"order must be 1 (8 nodes), 2 (20 nodes) or 3 (32 nodes), got {order!r}",
                         parameters=("order",))
    corners = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
    if order == 1:
        return corners
    inner = (0.0,) if order == 2 else (-1.0 / 3.0, 1.0 / 3.0)
    edges = []
    for axis in range(3):
        others = [a for a in range(3) if a != axis]
        for s1, s2 in itertools.product((-1.0, 1.0), repeat=2):
            for v in inner:
                node = np.zeros(3)
                node[axis], node[others[0]], node[others[1]] = v, s1, s2
                edges.append(node)
    return np.vstack([corners, np.array(edges)])


def shape_functions(order: int, xi: np.ndarray) -> np.ndarray:
    """Values of the shape functions at natural coordinates ``xi``.

    Parameters
    ----------
    order : int
        Element order: 1, 2 or 3 (see the module docstring).
    xi : array_like, shape (M, 3) or (3,)
        Natural coordinates (xi, eta, zeta), in [-1, 1] inside the element.

    Returns
    -------
    ndarray, shape (M, n_nodes)
        Shape function of every node (order of :func:`natural_nodes`) at every point.

    Raises
    ------
    InputError
        If ``order`` is not 1, 2 or 3, or ``xi`` is not (M, 3).
    """
    nodes = natural_nodes(order)
    xi = np.atleast_2d(np.asarray(xi, dtype=float))
    if xi.ndim != 2 or xi.shape[1] != 3:
        raise InputError(f"xi has shape {xi.shape}; expected (M, 3) natural coordinates", parameters=("xi",))
    x, y, z = (xi[:, k:k + 1] for k in range(3))
    nx, ny, nz = (nodes[None, :, k] for k in range(3))
    N = np.empty((len(xi), len(nodes)))
    corner = (np.abs(nx) == 1) & (np.abs(ny) == 1) & (np.abs(nz) == 1)
    lin = (1 + x * nx) * (1 + y * ny) * (1 + z * nz)
    if order == 1:
        return lin / 8.0
    if order == 2:
        N[:] = np.where(corner, lin * (x * nx + y * ny + z * nz - 2) / 8.0, 0.0)
        for axis, (a, na), (b, nb), (c, nc) in ((0, (x, nx), (y, ny), (z, nz)),
                                                 (1, (y, ny), (x, nx), (z, nz)),
                                                 (2, (z, nz), (x, nx), (y, ny))):
            mask = ~corner & (na == 0)
            N = np.where(mask, (1 - a * a) * (1 + b * nb) * (1 + c * nc) / 4.0, N)
        return N
    r2 = x * x + y * y + z * z
    N[:] = np.where(corner, lin * (9 * r2 - 19) / 64.0, 0.0)
    for (a, na), (b, nb), (c, nc) in (((x, nx), (y, ny), (z, nz)), ((y, ny), (x, nx), (z, nz)),
                                      ((z, nz), (x, nx), (y, ny))):
        mask = ~corner & (np.abs(na) < 1)
        N = np.where(mask, 9 * (1 - a * a) * (1 + 9 * a * na) * (1 + b * nb) * (1 + c * nc) / 64.0, N)
    return N


def _map_axes(machine: Machine, config: dict | None, what: str) -> tuple[list[int], np.ndarray]:
    """The three linear axes a map spans, and the positions (SI) of every axis: mid travel
    (0 for endless axes), overridden by ``config`` (axis name -> SI value)."""
    lin = [j for j, k in enumerate(machine.axis_kinds) if k == "linear"]
    if len(lin) != 3:
        raise InputError(f"{machine.name}: {what} needs exactly three linear axes "
                         f"(it has {len(lin)}: {', '.join(machine.axes[j] for j in lin) or 'none'})")
    fixed = machine.mid_travel
    for name, value in (config or {}).items():
        if name not in machine.axes:
            raise InputError(f"config: {machine.name} has no axis {name!r} (axes: {', '.join(machine.axes)})",
                             parameters=("config",))
        j = machine.axes.index(name)
        lo, hi = machine.travel[j]
        if not lo <= float(value) <= hi:  # NaN too
            raise InputError(f"config: {name} = {float(value):.6g} {'m' if machine.axis_kinds[j] == 'linear' else 'rad'} "
                             f"is outside its travel [{lo:.6g}, {hi:.6g}]", parameters=("config",))
        if j in lin:
            raise InputError(f"config: {name} is one of the axes {what} spans, not a fixed one",
                             parameters=("config",))
        fixed[j] = float(value)
    return lin, fixed


@dataclass
class ErrorMap:
    """Nodal errors of a machine over a grid of hexahedral elements.

    ``axes``: indices of the three linear machine axes spanned; ``fixed``: the positions of
    the other axes (SI). ``edges``: per spanned axis, the element boundaries (m).
    ``values``: (n_elements, n_nodes, 6) volumetric error at the element nodes (m, rad).

    Attributes
    ----------
    machine : Machine
        The machine mapped.
    order : int
        Element order: 1, 2 or 3 (8, 20 or 32 nodes per element).
    axes : tuple of int (3,)
        Indices of the three linear machine axes spanned.
    edges : tuple of 3 ndarray
        Per spanned axis, the element boundaries, shape (n_elements_along + 1,) [m].
    fixed : ndarray, shape (n_axes,)
        NC positions of all axes [m, rad]; those of the axes not spanned hold.
    values : ndarray, shape (n_elements, n_nodes, 6)
        Volumetric error at the element nodes: dx, dy, dz [m], rx, ry, rz [rad]. Elements
        are numbered with the last spanned axis fastest.
    """

    machine: Machine
    order: int
    axes: tuple[int, int, int]
    edges: tuple[np.ndarray, np.ndarray, np.ndarray]
    fixed: np.ndarray
    values: np.ndarray

    @classmethod
    def build(cls, machine: Machine, elements=(4, 4, 4), order: int = 2, config: dict | None = None) -> ErrorMap:
        """Evaluate the model at the nodes of the elements over the travel of the machine's linear axes.

        A machine with time-, temperature- or load-dependent terms is mapped in one state:
        ``ErrorMap.build(machine.with_state(t=3600))``.

        Parameters
        ----------
        machine : Machine
            A machine with exactly three linear axes.
        elements : sequence of 3 int, default (4, 4, 4)
            Elements along each linear axis.
        order : int, default 2
            Element order: 1, 2 or 3.
        config : dict, optional
            Positions of the other axes, axis name -> SI value [m, rad] (default the middle of
            their travel, or 0 for endless axes).

        Returns
        -------
        ErrorMap
            The map.

        Raises
        ------
        InputError
            If the machine does not have exactly three linear axes, ``config`` names an unknown
            axis, a spanned one or a position outside the travel, ``elements`` is not three
            whole numbers >= 1 or the map would not fit in the free memory, or ``order`` is not
            1, 2 or 3.
        """
        lin, fixed = _map_axes(machine, config, "an error map")
        elements = counts("elements", elements, 1)
        npe = len(natural_nodes(order))
        count = math.prod(elements) * npe
        # nodal values, node positions and configurations, and their evaluation
        require_memory(count * (8 * (6 + 2 * 3 + len(machine.axes)) + EVALUATION_BYTES),
                       f"an error map of {' x '.join(map(str, elements))} hexahedra ({count:,} element nodes)", ("elements",))
        travel = machine.travel
        edges = tuple(np.linspace(travel[j, 0], travel[j, 1], n + 1) for j, n in zip(lin, elements))
        emap = cls(machine, order, tuple(lin), edges, fixed, np.empty((0, 0, 6)))
        nodes = natural_nodes(order)
        lows = np.array(list(itertools.product(*(e[:-1] for e in edges))))
        sizes = np.array(list(itertools.product(*(np.diff(e) for e in edges))))
        pts = lows[:, None, :] + (nodes[None, :, :] + 1) / 2 * sizes[:, None, :]
        q = np.tile(fixed, (pts.shape[0] * pts.shape[1], 1))
        q[:, list(lin)] = pts.reshape(-1, 3)
        emap.values = _errors(machine, q).reshape(pts.shape[0], pts.shape[1], 6)
        return emap

    @property
    def n_nodes(self) -> int:
        """Distinct nodes (shared between elements), int."""
        pts = self._node_points().reshape(-1, 3)
        return len(np.unique(np.round(pts, 12), axis=0))

    def _node_points(self) -> np.ndarray:
        nodes = natural_nodes(self.order)
        lows = np.array(list(itertools.product(*(e[:-1] for e in self.edges))))
        sizes = np.array(list(itertools.product(*(np.diff(e) for e in self.edges))))
        return lows[:, None, :] + (nodes[None, :, :] + 1) / 2 * sizes[:, None, :]

    def locate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Element index and natural coordinates of points in the map's axes.

        Parameters
        ----------
        x : array_like, shape (M, 3)
            Positions of the three spanned axes [m].

        Returns
        -------
        element : ndarray of int, shape (M,)
            Element index (numbering of :attr:`values`).
        xi : ndarray, shape (M, 3)
            Natural coordinates in the element, in [-1, 1].

        Raises
        ------
        InputError
            If ``x`` is not (M, 3) finite positions, or a point lies outside the map (beyond
            rounding).
        """
        x = np.atleast_2d(np.asarray(x, dtype=float))
        if x.ndim != 2 or x.shape[1] != 3:
            raise InputError(f"x has shape {x.shape}; expected (M, 3): positions of the three mapped axes")
        if not np.all(np.isfinite(x)):
            i, k = np.argwhere(~np.isfinite(x))[0]
            raise InputError(f"x[{i}, {k}] is {x[i, k]}: positions must be finite")
        idx = []
        xi = np.empty_like(x)
        for k, e in enumerate(self.edges):
            tol = 1e-12 * max(1.0, e[-1] - e[0])
            if np.any(x[:, k] < e[0] - tol) or np.any(x[:, k] > e[-1] + tol):
                name = self.machine.axes[self.axes[k]]
                raise InputError(f"position outside the error map along {name} [{e[0]:.6g}, {e[-1]:.6g}] m")
            i = np.clip(np.searchsorted(e, x[:, k], side="right") - 1, 0, len(e) - 2)
            xi[:, k] = 2 * (x[:, k] - e[i]) / (e[i + 1] - e[i]) - 1
            idx.append(i)
        n = [len(e) - 1 for e in self.edges]
        element = (idx[0] * n[1] + idx[1]) * n[2] + idx[2]
        return element, xi

    def interpolate(self, q) -> np.ndarray:
        """Interpolated volumetric error at NC positions ``q``.

        The axes outside the map must sit where the map was built.

        Parameters
        ----------
        q : array_like, shape (M, n_axes)
            NC positions [m, rad], within the travel.

        Returns
        -------
        ndarray, shape (M, 6)
            dx, dy, dz [m], rx, ry, rz [rad].

        Raises
        ------
        InputError
            If ``q`` is invalid, an axis outside the map differs from its fixed position, or a
            point lies outside the map.
        """
        q = check_q(self.machine.model, q)
        others = [j for j in range(q.shape[1]) if j not in self.axes]
        if others and not np.allclose(q[:, others], self.fixed[others], atol=1e-12):
            raise InputError("the error map was built with " + ", ".join(
                f"{self.machine.axes[j]}={self.fixed[j]:.6g}" for j in others) + "; q differs there")
        element, xi = self.locate(q[:, list(self.axes)])
        # in chunks: the shape functions and gathered nodal values take ~14 x nodes floats a point
        out = np.empty((len(q), 6))
        for start in range(0, len(q), INTERPOLATION_CHUNK):
            part = slice(start, start + INTERPOLATION_CHUNK)
            N = shape_functions(self.order, xi[part])
            out[part] = np.einsum("mn,mnc->mc", N, self.values[element[part]])
        return out

    def interpolation_error(self, points: int = 2000, seed: int = 0) -> dict:
        """Interpolated vs direct model at ``points`` seeded random points.

        Parameters
        ----------
        points : int, default 2000
            Number of uniformly random points in the map.
        seed : int, default 0
            Seed of the points (>= 0).

        Returns
        -------
        dict
            ``order``, ``nodes_per_element``, ``elements`` (per axis), ``nodes``, ``points``,
            ``max_um`` and ``rms_um`` (position error of the interpolation) [um],
            ``error_rms_um`` (RMS of the position error itself) [um] and ``relative`` (the
            interpolation's RMS over the error's RMS).

        Raises
        ------
        InputError
            If ``points`` is not a whole number >= 1 or would not fit in the free memory, or
            ``seed`` is negative.
        """
        n = integer("points", points, 1)
        seed = integer("seed", seed, 0)
        npe = NODES_PER_ORDER[self.order]
        # positions, shape functions and gathered nodal values of every point, and its evaluation
        require_memory(n * (8 * (3 * len(self.fixed) + 14 * npe + 30) + EVALUATION_BYTES),
                       f"an interpolation test at {n:,} random positions", ("points",))
        rng = np.random.default_rng(seed)
        q = np.tile(self.fixed, (n, 1))
        for k, j in enumerate(self.axes):
            e = self.edges[k]
            q[:, j] = e[0] + rng.random(n) * (e[-1] - e[0])
        direct = _errors(self.machine, q)[:, :3]
        diff = np.linalg.norm(self.interpolate(q)[:, :3] - direct, axis=1)
        size = np.linalg.norm(direct, axis=1)
        return {"order": self.order, "nodes_per_element": NODES_PER_ORDER[self.order],
                "elements": [len(e) - 1 for e in self.edges], "nodes": self.n_nodes, "points": n,
                "max_um": float(diff.max() * 1e6), "rms_um": float(np.sqrt(np.mean(diff**2)) * 1e6),
                "error_rms_um": float(np.sqrt(np.mean(size**2)) * 1e6),
                "relative": float(np.sqrt(np.mean(diff**2)) / max(np.sqrt(np.mean(size**2)), 1e-300))}


def _errors(machine: Machine, q: np.ndarray) -> np.ndarray:
    """The volumetric errors at positions the library laid out within the travel, in the
    machine's state (checked here, where it enters)."""
    model = machine.model
    return volumetric_error(model, q, machine.theta, check_covariates(model, len(q), None, machine.state))


def compensation_table(machine: Machine, path: str | Path, nodes=(11, 11, 11), config: dict | None = None) -> dict:
    """Write a controller compensation table (CSV) on a regular node grid.

    Columns: node position of the three linear axes (mm) and the correction to add to each
    commanded axis (um for linear axes, urad for rotary ones), computed by exact point
    compensation of positions at the node (the tool axis is not corrected). Between nodes a
    controller interpolates trilinearly; the header says so.

    The table is computed and written in chunks of :data:`TABLE_CHUNK` nodes, whatever its
    size, through a temporary file beside ``path`` that replaces it only when the table is
    complete; a table the folder's disk cannot hold is refused before any work.

    Parameters
    ----------
    machine : Machine
        A machine with exactly three linear axes.
    path : str or Path
        The CSV file to write.
    nodes : sequence of 3 int, default (11, 11, 11)
        Nodes along each linear axis (at least 2), ends of the travel included.
    config : dict, optional
        Positions of the other axes, axis name -> SI value [m, rad] (default mid travel, 0
        for endless axes).

    Returns
    -------
    dict
        A summary with the trilinear interpolation error of the table against exact
        compensation at 500 seeded random points: ``file``, ``nodes``, ``rows``,
        ``max_correction_um``, ``trilinear_max_um``, ``residual_with_table_max_um`` and
        ``residual_with_table_rms_um`` [um].

    Raises
    ------
    InputError
        If ``path`` cannot be written (see :func:`~volerr_pin.base.check_outputs`), the
        machine does not have exactly three linear axes, ``config`` names an unknown axis, a
        spanned one or a position outside the travel, ``nodes`` is not three whole numbers
        >= 2, or the table would not fit on the disk of ``path``'s folder.
    """
    from ._points import MachineInputs, compensate_checked

    path = check_outputs({"path": path})["path"]
    lin, fixed = _map_axes(machine, config, "a compensation table")
    nodes = counts("nodes", nodes, 2)
    require_memory(8 * sum(nodes), f"node positions of {' x '.join(map(str, nodes))} nodes", ("nodes",))
    travel = machine.travel
    grids = [np.linspace(travel[j, 0], travel[j, 1], n) for j, n in zip(lin, nodes)]
    rows = math.prod(nodes)
    names = [machine.axes[j] for j in lin]

    def configurations(flat: np.ndarray) -> np.ndarray:
        """The configurations of nodes by flat index (the last axis fastest)."""
        index = np.unravel_index(flat, nodes)
        q = np.tile(fixed, (len(flat), 1))
        for k, j in enumerate(lin):
            q[:, j] = grids[k][index[k]]
        return q

    inputs = MachineInputs(machine)

    def corrections(q: np.ndarray) -> np.ndarray:
        """Exact point compensation (:func:`~volerr_pin.compensation.compensate_points` with its
        defaults, the tool axis not corrected) of nodes laid out within the travel."""
        return compensate_checked(inputs.model, inputs.theta, q, inputs.covariates(len(q))).q - q

    row_format = ",".join(["%.4f"] * (3 + len(machine.axes))) + "\n"

    def lines(q: np.ndarray, corr: np.ndarray) -> str:
        return "".join(row_format % tuple(row) for row in np.hstack([q[:, lin] * 1e3, corr * 1e6]).tolist())

    path = Path(path)
    header = (f"# volerr_pin compensation table for {machine.name}\n"
              f"# nodes: {' x '.join(str(n) for n in nodes)} over the travel of {', '.join(names)}"
              + "".join(f"; {machine.axes[j]} = {fixed[j]:.6g}" for j in range(len(fixed)) if j not in lin) + "\n"
              "# correction = value to ADD to the commanded axis position at the node "
              "(exact point compensation of the model)\n"
              "# between nodes interpolate trilinearly in the node grid (as controllers do)\n"
              + ",".join([f"{a}_mm" for a in names] + [
                  f"d{a}_{'um' if machine.axis_kinds[j] == 'linear' else 'urad'}" for j, a in enumerate(machine.axes)])
              + "\n")
    # the size on disk, from the longest row at the corners and a sample of nodes, with room
    # for a larger correction elsewhere
    probe = np.unique(np.r_[np.ravel_multi_index(np.array(list(itertools.product(*[(0, n - 1) for n in nodes]))).T,
                                                 nodes),
                            np.random.default_rng(0).integers(0, rows, 56)])
    q_probe = configurations(probe)
    longest = max(len(line) for line in lines(q_probe, corrections(q_probe)).splitlines()) + 1
    needed = len(header) + rows * (longest + 2 * len(machine.axes))
    free = shutil.disk_usage(path.parent if str(path.parent) else ".").free
    if needed > free:
        raise InputError(f"nodes: a table of {' x '.join(map(str, nodes))} = {rows:,} nodes takes about "
                         f"{needed / 1e9:.3g} GB, more than the {free / 1e9:.3g} GB free on the disk of "
                         f"{path.parent}; reduce nodes", parameters=("nodes",))
    largest = 0.0
    with replacing(path) as tmp, open(tmp, "w", newline="") as fh:
        fh.write(header)
        for start in range(0, rows, TABLE_CHUNK):
            q = configurations(np.arange(start, min(start + TABLE_CHUNK, rows)))
            corr = corrections(q)
            largest = max(largest, float(np.abs(corr[:, lin]).max()))
            fh.write(lines(q, corr))
    # how well trilinear interpolation of the table reproduces exact compensation: the
    # corrections at the corners of the cells of 500 seeded points (the same per node as in
    # the table: each point is compensated on its own)
    rng = np.random.default_rng(0)
    test = np.tile(fixed, (500, 1))
    for k, j in enumerate(lin):
        test[:, j] = grids[k][0] + rng.random(500) * (grids[k][-1] - grids[k][0])
    exact = corrections(test)
    cells, frac = [], []
    for k, g in enumerate(grids):
        i = np.clip(np.searchsorted(g, test[:, lin[k]], side="right") - 1, 0, len(g) - 2)
        cells.append(i)
        frac.append((test[:, lin[k]] - g[i]) / (g[i + 1] - g[i]))
    corners = list(itertools.product((0, 1), repeat=3))
    flat = np.stack([np.ravel_multi_index(tuple(cells[k] + c[k] for k in range(3)), nodes) for c in corners])
    used, where = np.unique(flat, return_inverse=True)
    at_nodes = corrections(configurations(used))[where.reshape(flat.shape)]   # (8, 500, n_axes)
    tri = 0.0
    for corner, values in zip(corners, at_nodes):
        w = np.ones(len(test))
        for k, c in enumerate(corner):
            w = w * (frac[k] if c else 1 - frac[k])
        tri = tri + w[:, None] * values
    err = np.abs(tri - exact)[:, lin].max(axis=1)
    commanded = test + tri
    _, p_cmd = tool_poses(inputs.model, commanded, inputs.theta, inputs.covariates(len(commanded)))
    _, p_d = tool_poses(inputs.model, test, nominal=True)
    resid = np.linalg.norm(p_cmd - p_d, axis=1)
    return {"file": str(path), "nodes": list(nodes), "rows": rows,
            "max_correction_um": largest * 1e6,
            "trilinear_max_um": float(err.max() * 1e6),
            "residual_with_table_max_um": float(resid.max() * 1e6),
            "residual_with_table_rms_um": float(np.sqrt(np.mean(resid**2)) * 1e6)}


def axis_tables(machine: Machine, directory: str | Path, points: int = 21) -> list[str]:
    """ISO 230-1-named per-axis tables of the component errors.

    For each axis, its component errors (EXX, EYX, ...) at ``points`` positions over its
    travel (one turn, 0 to 2 pi, for an endless axis), with the other axes at mid-travel.
    Linear errors in um, angular in urad, positions in mm / deg; one CSV per axis that has
    components, named ``<machine>_<axis>.csv``.

    Parameters
    ----------
    machine : Machine
        The machine.
    directory : str or Path
        Folder to write to (created if missing).
    points : int, default 21
        Positions per axis, ends included (>= 2).

    Returns
    -------
    list of str
        The files written (each through a temporary file renamed over it when complete).

    Raises
    ------
    InputError
        If ``points`` is not a whole number >= 2 or the tables would not fit in the free
        memory, or ``directory`` is not a folder that can be made.
    """
    points = integer("points", points, 2)
    require_memory(points * (8 * 3 * (len(machine.axes) + len(machine.components)) + EVALUATION_BYTES),
                   f"axis tables at {points:,} positions", ("points",))
    directory = check_output_folder("directory", directory)
    travel = machine.travel
    mid = machine.mid_travel
    theta, state = machine.theta, machine.state
    info = {t["component"]: t["owner"] for t in machine.model.term_info()}
    files = []
    with transaction() as tx:
        tx.folder(directory)
        for j, axis in enumerate(machine.axes):
            comps = [c for c in machine.components if info.get(c) == axis]
            if not comps:
                continue
            lo, hi = travel[j] if np.isfinite(travel[j]).all() else (0.0, 2 * np.pi)
            q = np.tile(mid, (points, 1))
            q[:, j] = np.linspace(lo, hi, points)
            vals = component_values(machine.model, q, theta, check_covariates(machine.model, points, None, state))
            cols = [machine.components.index(c) for c in comps]
            path = directory / f"{machine.name}_{axis}.csv"
            with open(tx.path(path), "w", newline="") as fh:
                fh.write(f"# volerr_pin ISO 230-1 component errors of axis {axis} ({machine.name}); "
                         "errors as motions of the tool relative to the workpiece\n")
                w = csv.writer(fh, lineterminator="\n")
                w.writerow([f"{axis}_{AXIS_UNIT[machine.axis_kinds[j]]}"] + [
                    f"{c}_{'urad' if c[1] in 'ABC' else 'um'}" for c in comps])
                for row, pos in zip(vals[:, cols], q[:, j]):
                    w.writerow([f"{pos / axis_scale(machine.axis_kinds[j]):.4f}"]
                               + [f"{v * 1e6:.4f}" for v in row])
            files.append(str(path))
    return files
