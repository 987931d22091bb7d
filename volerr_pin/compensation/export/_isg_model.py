"""The serial kinematic model of TF5280 Volumetric Compensation (Beckhoff TwinCAT CNC / ISG
kernel), as this product reads its manual, and the compensation it computes.

The kernel describes a machine as a serial chain of precisely three linear axes X, Y, Z and
up to three rotary axes A, B, C (TF5280 "Overview"; P-VOLC-00007 ``chain``), listed from the
workpiece to the tool, with the tool's zero position P0X..P0Z and zero orientation N0X..N0Z
and each rotary axis' centre of rotation PXA..PZC (TF5280 "List of parameters supported").
Every axis carries its ISO 230-1 component errors as tables over its own position (ISG CSV
files; mm and rad; arguments in mm and deg; linear interpolation with ``interpolation GRID``)
and its position errors as constants. Reading of that model (the manual pages found do not
spell out the matrices, so this is stated, not quoted):

- all frames coincide with the workpiece (machine) frame when every axis is at zero;
- a linear axis k moves its successors by ``u_k q_k``; its errors act after the motion, as a
  small rigid motion about the origin it carries: translation (EX?, EY?, EZ?), rotation
  (EA?, EB?, EC?) in that frame;
- a rotary axis k turns its successors by ``q_k`` about ``u_k`` through its centre ``o_k``;
  its errors act before the rotation (in the frame that does not turn with the axis, as
  ISO 230-1 states rotary-axis error motions), the rotations about the centre;
- errors are motions of the tool relative to the workpiece: every axis is declared on the
  tool side (``workpiece_axes 0``) and the chain lists workpiece-side axes from the workpiece
  outwards, then tool-side axes from the bed outwards, which is the order in which the
  relative motion composes (TF5280 "Workpiece axes": an axis the measurement treats as
  tool-side is configured tool-side);
- the kernel corrects the tool *position* only, by moving the linear axes (TF5280
  "Overview": "only compensates for tool position"): set-point correction
  ``-M^-1 d(q)``, ``d`` the model's tool-point deviation at the commanded position and ``M``
  the linear axes' directions.

A table value means the same thing in this model as in the machine's own only where their
reference points agree; the fit (:mod:`volerr_pin.compensation.export`) chooses the values that make
the kernel's model reproduce the machine, so differences of convention end up in the values,
not in the residual.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from ...model import Machine, component_values
from .._points import MachineInputs
from ._protocol import Compensation
from ._tables import interpolation_weights

__all__ = ["VolumetricModel", "rotation"]

#: ISO 230-1 error directions of the six columns of a component table
DIRECTIONS = ("X", "Y", "Z", "A", "B", "C")


def rotation(vectors: np.ndarray) -> np.ndarray:
    """Rotation matrices of rotation vectors (Rodrigues).

    Parameters
    ----------
    vectors : ndarray, shape (N, 3)
        Rotation vectors [rad].

    Returns
    -------
    ndarray, shape (N, 3, 3)
        Rotations.
    """
    theta = np.linalg.norm(vectors, axis=1)
    small = theta < 1e-12
    k = np.where(small[:, None], 0.0, vectors / np.where(small, 1.0, theta)[:, None])
    K = np.zeros((len(vectors), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    s, c = np.sin(theta)[:, None, None], np.cos(theta)[:, None, None]
    return np.eye(3) + s * K + (1 - c) * K @ K


def _skew(v: np.ndarray) -> np.ndarray:
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


@dataclass(frozen=True, eq=False)
class VolumetricModel(Compensation):
    """TF5280's serial model with component tables, and the correction the kernel computes.

    Attributes
    ----------
    chain : tuple of int
        Machine axis indices from the workpiece to the tool.
    names : tuple of str
        Their names (``"Y"``, ``"X"``, ``"Z"``, ...).
    rotary : tuple of bool
        Which are rotary.
    directions : ndarray, shape (n, 3)
        Unit direction of motion (linear) or rotation axis (rotary) at zero.
    centres : ndarray, shape (n, 3)
        Centres of rotation at zero [m] (zero for linear axes).
    p0 : ndarray, shape (3,)
        Tool point at zero [m].
    n0 : ndarray, shape (3,)
        Tool axis at zero (unit, from the tool point into the spindle).
    nodes : tuple of ndarray
        Each axis' table arguments [m, rad], strictly increasing.
    tables : tuple of ndarray
        Each axis' component errors at its nodes, shape (n_k, 6): EX?, EY?, EZ? [m], EA?,
        EB?, EC? [rad].
    positions : ndarray, shape (n, 6)
        Each axis' position errors (X0?, ... C0?), constant [m, rad].
    n_axes : int
        Number of machine axes.
    kind : str
        ``"volumetric"``.
    notes : tuple of str
        Facts for the report.

    Notes
    -----
    The methods of :class:`~volerr_pin.compensation.export.Compensation` (documented there) do
    here:

    - ``values``: all component table values, axis after axis, node-major (ndarray of shape
      (P,), SI).
    - ``with_values``: a copy with other component table values (as :attr:`values` orders them).
    - ``correction``: set-point corrections the kernel computes: the linear axes moved by
      ``-M^-1 d(q)``.
    - ``basis``: d correction / d table values, first order at the nominal chain (the kernel's
      correction is linear in its tables up to products of errors: about 1e-3 um on a 4 m gantry
      with 10 arcsec of location errors; the fit iterates on the exact correction).
    - ``naive``: the tables filled with the machine's own component errors at the nodes (other
      axes at mid travel, the mean of both directions), position errors as they are.
    - ``contents``: chain, geometry, nodes, tables and position errors: everything the files
      say.
    - ``axis_nodes``: the nodes of each machine axis' component table (None for axes not in the
      chain).
    - ``describe``: one line per axis: its component table and the largest errors it holds.
    """

    chain: tuple[int, ...]
    names: tuple[str, ...]
    rotary: tuple[bool, ...]
    directions: np.ndarray
    centres: np.ndarray
    p0: np.ndarray
    n0: np.ndarray
    nodes: tuple[np.ndarray, ...]
    tables: tuple[np.ndarray, ...]
    positions: np.ndarray
    n_axes: int
    kind: str = "volumetric"
    notes: tuple[str, ...] = field(default=())

    # ------------------------------------------------------------------ values
    @property
    def values(self) -> np.ndarray:
        return np.concatenate([t.ravel() for t in self.tables])

    def with_values(self, values: np.ndarray) -> "VolumetricModel":
        values = np.asarray(values, dtype=float)
        out, start = [], 0
        for t in self.tables:
            out.append(values[start:start + t.size].reshape(t.shape))
            start += t.size
        return replace(self, tables=tuple(out))

    def _linear_axes(self) -> tuple[list[int], np.ndarray]:
        lin = [k for k, r in enumerate(self.rotary) if not r]
        return [self.chain[k] for k in lin], self.directions[lin].T       # columns u_X, u_Y, u_Z

    # ------------------------------------------------------------------ kinematics
    def _errors(self, q: np.ndarray) -> list[np.ndarray]:
        """(N, 6) error motion of each chain axis at the commanded positions."""
        out = []
        for k, j in enumerate(self.chain):
            idx, w = interpolation_weights(self.nodes[k], q[:, j])
            table = self.tables[k]
            out.append(w[:, :1] * table[idx[:, 0]] + w[:, 1:] * table[idx[:, 1]] + self.positions[k])
        return out

    def _passes(self, q: np.ndarray, tool: np.ndarray, errors: list[np.ndarray] | None):
        """Frames where each axis' error acts (R (N,3,3), t (N,3)) and the tool point in them."""
        n = len(q)
        R, t = np.tile(np.eye(3), (n, 1, 1)), np.zeros((n, 3))
        frames, posts = [], []
        for k, j in enumerate(self.chain):
            u, o = self.directions[k], self.centres[k]
            if self.rotary[k]:
                t = t + R @ o                                        # to the centre
                post = rotation(u[None, :] * q[:, j:j + 1])          # turn, then back from the centre
            else:
                t = t + (R @ u) * q[:, j:j + 1]
                post = None
            frames.append((R.copy(), t.copy()))
            if errors is not None:
                e = errors[k]
                t = t + np.einsum("nij,nj->ni", R, e[:, :3])
                R = R @ rotation(e[:, 3:])
            if post is not None:
                R = R @ post
                t = t - np.einsum("nij,j->ni", R, o)
            posts.append(post)
        tip_local = self.p0[None, :] - tool[:, None] * self.n0[None, :]
        return frames, posts, R, t, tip_local

    def tool_points(self, q: np.ndarray, tool: np.ndarray, with_errors: bool = True) -> np.ndarray:
        """Tool points the model predicts, in the workpiece frame.

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Commanded positions [m, rad].
        tool : ndarray, shape (N,)
            Tool extensions [m].
        with_errors : bool, default True
            Include the component and position errors (else the nominal chain).

        Returns
        -------
        ndarray, shape (N, 3)
            [m].
        """
        _, _, R, t, tip = self._passes(q, tool, self._errors(q) if with_errors else None)
        return t + np.einsum("nij,nj->ni", R, tip)

    def deviation(self, q: np.ndarray, tool: np.ndarray) -> np.ndarray:
        """The model's tool-point deviation at the commanded positions (exact chain).

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Commanded positions [m, rad].
        tool : ndarray, shape (N,)
            Tool extensions [m].

        Returns
        -------
        ndarray, shape (N, 3)
            Actual minus nominal tool point of the model [m].
        """
        return self.tool_points(q, tool) - self.tool_points(q, tool, with_errors=False)

    def sensitivities(self, q: np.ndarray, tool: np.ndarray) -> list[np.ndarray]:
        """d deviation / d (error motion of each axis), first order at the nominal chain.

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Commanded positions [m, rad].
        tool : ndarray, shape (N,)
            Tool extensions [m].

        Returns
        -------
        list of ndarray, shape (N, 3, 6)
            One per chain axis: columns for the translations (m per m) and rotations (m per rad).
        """
        frames, posts, _, _, tip = self._passes(q, tool, None)
        point = tip.copy()                                     # tool point in the frame after the chain
        out = [None] * len(self.chain)
        for k in range(len(self.chain) - 1, -1, -1):
            R, _ = frames[k]
            if posts[k] is not None:
                o = self.centres[k]
                g = np.einsum("nij,nj->ni", posts[k], point - o)
            else:
                g = point
            S = np.empty((len(q), 3, 6))
            S[:, :, :3] = R
            S[:, :, 3:] = -R @ _skew(g)
            out[k] = S
            # the point in the frame before axis k
            if posts[k] is not None:
                point = g + self.centres[k]
            else:
                point = g + self.directions[k][None, :] * q[:, self.chain[k]:self.chain[k] + 1]
        return out

    # ------------------------------------------------------------------ the kernel's correction
    def correction(self, q: np.ndarray, directions: np.ndarray, tool: np.ndarray) -> np.ndarray:
        axes, M = self._linear_axes()
        out = np.zeros((len(q), self.n_axes))
        out[:, axes] = -np.linalg.solve(M, self.deviation(q, tool).T).T
        return out

    def basis(self, q: np.ndarray, directions: np.ndarray, tool: np.ndarray) -> sp.csr_matrix:
        n = len(q)
        axes, M = self._linear_axes()
        Minv = np.linalg.inv(M)
        rows, cols, data = [], [], []
        offset = 0
        for k, S in enumerate(self.sensitivities(q, tool)):
            idx, w = interpolation_weights(self.nodes[k], q[:, self.chain[k]])
            G = -np.einsum("jr,nrc->njc", Minv, S)                            # (N, 3 linear, 6)
            for a, axis in enumerate(axes):
                for side in range(2):
                    for c in range(6):
                        rows.append(np.arange(n) * self.n_axes + axis)
                        cols.append(offset + idx[:, side] * 6 + c)
                        data.append(G[:, a, c] * w[:, side])
            offset += self.tables[k].size
        return sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(n * self.n_axes, offset))

    # ------------------------------------------------------------------ protocol
    def naive(self, machine: Machine) -> "VolumetricModel":
        inputs = MachineInputs(machine)
        tables = []
        for k, j in enumerate(self.chain):
            q = np.tile(machine.mid_travel, (len(self.nodes[k]), 1))
            q[:, j] = self.nodes[k]
            values = np.zeros((len(q), 6))
            every = None
            for c, d in enumerate(DIRECTIONS):
                name = f"E{d}{self.names[k]}"
                if name in machine.components:
                    if every is None:
                        every = component_values(inputs.model, q, inputs.theta, inputs.covariates(len(q)))
                    values[:, c] = every[:, machine.components.index(name)]
            tables.append(values)
        return replace(self, tables=tuple(tables))

    def contents(self) -> tuple:
        return (self.chain, self.rotary, self.directions, self.centres, self.p0, self.n0, self.nodes, self.tables,
                self.positions)

    def axis_nodes(self) -> list[np.ndarray | None]:
        out: list[np.ndarray | None] = [None] * self.n_axes
        for k, j in enumerate(self.chain):
            out[j] = self.nodes[k]
        return out

    def describe(self, machine: Machine) -> list[str]:
        lines = [f"chain {''.join(self.names)} (workpiece to tool), every axis tool-side"]
        for k, name in enumerate(self.names):
            t = self.tables[k]
            lines.append(f"{name}: {len(self.nodes[k])} nodes, E?{name} translations up to "
                         f"{np.abs(t[:, :3]).max() * 1e6:.3f} um, rotations up to "
                         f"{np.abs(t[:, 3:]).max() * 1e6:.3f} urad")
        return lines
