"""Assembly of the coupled system into a fixed sparsity pattern, filled in place.

The coupled Jacobian of :class:`~xlotkit.sim.coupling.CoupledModel` (module docstring
there) has the blocks ``K`` (cluster tangents), ``G`` (pressure load), ``-f_w``, ``Cfu``
(skeleton volume change), ``dR/dk dk/du`` (crack permeability), the well's volume row and
the flow Jacobian. Their positions depend only on the mesh, the boundary conditions and
the set of cells whose crack permeability depends on the displacements (the failed
clusters). Without poroelastic coupling of the intact rock (Biot ``alpha = 0``) the ``G``
and ``Cfu`` entries of intact clusters are zero and are not stored at all: those blocks
then have columns / rows only for the failed clusters, which carry the fluid pressure on
their crack faces (coefficient 1) whatever ``alpha`` is. :class:`CoupledLayout` holds, once
per model, where every entry of every block goes; :meth:`CoupledLayout.pattern` turns that
into a CSR structure for one set of failed cells (:class:`CoupledPattern`, cached: it
changes only when clusters fail), with, for every block, the slot of each of its entries in the CSR data array. An evaluation then
sums the blocks' values into a zeroed data array (:func:`assemble_jacobian`): no sparse
matrix is built, sorted or checked per Newton iteration, and the linear solver can reuse
its ordering while the pattern object is the same (:mod:`xlotkit.sim.coupling.newton`).

The loops are private ``@njit(cache=True)`` kernels behind public functions that check
their inputs and allocate.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numba import njit

from xlotkit.errors import InputError

__all__ = ["CoupledLayout", "CoupledPattern", "add_crack_block", "assemble_jacobian",
           "cluster_forces", "hold_rows"]


#: Patterns a layout keeps (by their crack cells) besides the last one.
_RECENT_PATTERNS = 8


# --------------------------------------------------------------------------- kernels
@njit(cache=True)
def _scatter(data, slots, vals):  # pragma: no cover - compiled
    for i in range(slots.shape[0]):
        s = slots[i]
        if s >= 0:
            data[s] += vals[i]


@njit(cache=True)
def _crack_block(data, slots, dRk, cell, dkdu):  # pragma: no cover - compiled
    # (dR/dk dk/du): entry t of dR/dk (row r_t, cell c_t) times the six entries of
    # dk_c/du_c, summed into (r_t, dofs of c_t)
    for t in range(slots.shape[0]):
        v = dRk[t]
        if v == 0.0:
            continue
        c = cell[t]
        for k in range(6):
            s = slots[t, k]
            if s >= 0:
                data[s] += v * dkdu[c, k]


@njit(cache=True)
def _forces_kernel(dofs, du, failed, f_c, fc0, k_intact, coef, dp, g, n_dof, fint, fabs,
                   gdu):  # pragma: no cover - compiled
    nc = dofs.shape[0]
    duc = np.empty(6)
    df = np.empty(6)
    for c in range(nc):
        for i in range(6):
            duc[i] = du[dofs[c, i]]
        s = 0.0
        for i in range(6):
            s += g[c, i] * duc[i]
        gdu[c] = s
        if failed[c]:
            for i in range(6):
                df[i] = f_c[c, i] - fc0[c, i]
        else:
            # the exact incremental form of the intact (linear) cluster
            for i in range(6):
                v = 0.0
                for j in range(6):
                    v += k_intact[c, i, j] * duc[j]
                df[i] = v - coef[c] * dp[c] * g[c, i]
        for i in range(6):
            fint[dofs[c, i]] += df[i]
            fabs[dofs[c, i]] += abs(df[i])


# --------------------------------------------------------------------------- forces
def cluster_forces(dofs, du, failed, f_c, fc0, k_intact, coef, dp, g, n_dof: int):
    """Incremental internal forces of the coupled residual, assembled.

    Per cluster ``df_c = k_c du_c - coef_c dp_c g_c`` (intact: the exact incremental
    form of the linear cluster) or ``f_c - f_c^0`` (failed: difference of the contact
    law's absolute forces), summed into the global DOFs.

    Parameters
    ----------
    dofs : ndarray of int (n_c, 6)
    du : ndarray (n_dof,) [m]
        Displacement from the reference state.
    failed : ndarray of bool (n_c,)
    f_c, fc0 : ndarray (n_c, 6) [N/m]
        Cluster forces at the iterate and at the reference state.
    k_intact : ndarray (n_c, 6, 6) [N/m^2]
    coef : ndarray (n_c,)
        Pressure coefficient (Biot ``alpha`` intact).
    dp : ndarray (n_c,) [Pa]
        Pressure from the reference state.
    g : ndarray (n_c, 6) [m]
        Nodal force of a unit pressure.
    n_dof : int

    Returns
    -------
    fint : ndarray (n_dof,) [N/m]
        ``sum_c df_c``.
    fabs : ndarray (n_dof,) [N/m]
        ``sum_c |df_c|`` (the scale of the force rows).
    gdu : ndarray (n_c,) [m^2]
        ``g_c . du_c`` (``A_c eps_vol,c``).
    """
    dofs = np.ascontiguousarray(dofs, dtype=np.int64)
    nc = dofs.shape[0]
    du = np.ascontiguousarray(du, dtype=np.float64)
    if du.shape != (n_dof,) or (nc and (dofs.min() < 0 or dofs.max() >= n_dof)):
        raise InputError(f"du has shape {du.shape}, expected ({n_dof},) covering the DOFs",
                         key="du")
    arrs = []
    for name, a, shape in (("f_c", f_c, (nc, 6)), ("fc0", fc0, (nc, 6)),
                           ("k_intact", k_intact, (nc, 6, 6)), ("coef", coef, (nc,)),
                           ("dp", dp, (nc,)), ("g", g, (nc, 6))):
        a = np.ascontiguousarray(a, dtype=np.float64)
        if a.shape != shape:
            raise InputError(f"{name} has shape {a.shape}, expected {shape}", key=name)
        arrs.append(a)
    fl = np.ascontiguousarray(failed, dtype=np.bool_)
    if fl.shape != (nc,):
        raise InputError(f"failed has shape {fl.shape}, expected ({nc},)", key="failed")
    fint = np.zeros(n_dof)
    fabs = np.zeros(n_dof)
    gdu = np.empty(nc)
    _forces_kernel(dofs, du, fl, arrs[0], arrs[1], arrs[2], arrs[3], arrs[4], arrs[5],
                   n_dof, fint, fabs, gdu)
    return fint, fabs, gdu


# --------------------------------------------------------------------------- pattern
@dataclass(frozen=True, eq=False)
class CoupledPattern:
    """CSR structure of the coupled Jacobian for one set of crack cells, and the slot in
    its data array of every entry of every block (``-1``: entry not stored, a held DOF).

    Attributes
    ----------
    n : int
        Size of the system ``n_u + m + 1``.
    indptr, indices : ndarray of int32
        The CSR structure (sorted column indices, no duplicates).
    k_slots : ndarray (n_c * 36,)
        Cluster tangent blocks, in the order of ``blocks.ravel()`` (``(c, i, j)``).
    g_slots, gt_slots : ndarray (n_c * 6,)
        ``G`` (row: DOF ``i`` of cluster ``c``, column: cell ``c``) and ``Cfu`` (row: cell
        ``c``, column: DOF ``i``), in the order ``(c, i)``; ``-1`` for the intact cells of
        a model without Biot coupling (:attr:`CoupledLayout.biot_blocks` False).
    wcol_slots, wrow_slots : ndarray (n_w,)
        The ``-f_w`` column and the well row's ``f_w`` entries, in the order of
        :attr:`CoupledLayout.wall_rows`.
    flow_slots : ndarray
        The flow Jacobian's entries, in the order of ``FlowModel.jacobian_triplets``.
    crack_slots : ndarray (n_k, 6)
        ``dR/dk dk/du``: entry ``t`` of ``dR/dk`` (``FlowModel.permeability_triplets``)
        times DOF ``k`` of its cell; ``-1`` unless the cell is a crack cell.
    diag_slots : ndarray (n_u,)
        The diagonal of the displacement rows.
    crack_cells : ndarray of bool (m,)
        The cells whose ``dk/du`` columns the pattern holds.
    """

    n: int
    indptr: np.ndarray
    indices: np.ndarray
    k_slots: np.ndarray
    g_slots: np.ndarray
    gt_slots: np.ndarray
    wcol_slots: np.ndarray
    wrow_slots: np.ndarray
    flow_slots: np.ndarray
    crack_slots: np.ndarray
    diag_slots: np.ndarray
    crack_cells: np.ndarray
    _template: sp.csr_matrix = field(init=False, repr=False)

    def __post_init__(self) -> None:
        # a CSR matrix on the structure, built (and checked by SciPy) once: a matrix of
        # the pattern is a shallow copy of it with its own data (SciPy's constructor
        # checks the structure again at every call, ~0.1 ms, a tenth of an evaluation)
        object.__setattr__(self, "_template", sp.csr_matrix(
            (np.zeros(int(self.indptr[-1])), self.indices, self.indptr),
            shape=(self.n, self.n), copy=False))

    @property
    def nnz(self) -> int:
        """Stored entries."""
        return int(self.indptr[-1])

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """The CSR matrix (n, n) with this structure and the values ``data`` (nnz,),
        float64, used as they are (not copied)."""
        if data.shape != (self.nnz,) or data.dtype != np.float64:
            raise InputError(f"data has shape {data.shape} and dtype {data.dtype}, expected "
                             f"({self.nnz},) float64", key="data")
        J = copy.copy(self._template)
        J.data = data
        return J


class CoupledLayout:
    """Where every entry of every block of the coupled Jacobian goes (built once per
    model); :meth:`pattern` gives the CSR structure for a set of crack cells.

    Parameters
    ----------
    dofs : ndarray of int (n_c, 6)
        Global DOFs of each cluster.
    unknown : ndarray of int (n_dof,)
        Reduced unknown of each mechanics DOF (``-1``: held).
    n_u : int
        Displacement unknowns.
    wall : ndarray (n_u,)
        The wall-pressure load ``f_w`` on the displacement unknowns; its nonzero rows
        couple to the well pressure.
    flow_triplets, permeability_triplets : tuple of ndarray
        ``(rows, cols)`` of the flow Jacobian (unknowns ``m + 1``) and of ``dR/dk``
        (``m + 1`` x ``m``), in their fixed orders.
    well_row_permeability : bool
        Whether the well row depends on the permeabilities (rate-driven well).
    biot_blocks : bool
        Whether intact clusters carry pressure-coupling entries (``G`` and ``Cfu``: Biot
        ``alpha > 0``). False: only the failed clusters' entries are stored, per pattern.
    """

    def __init__(self, dofs, unknown, n_u: int, wall, flow_triplets, permeability_triplets,
                 well_row_permeability: bool, biot_blocks: bool = True) -> None:
        dofs = np.asarray(dofs, dtype=np.int64)
        unknown = np.asarray(unknown, dtype=np.int64)
        nc = dofs.shape[0]
        m = nc
        self.n_u = int(n_u)
        self.n_cells = m
        n = self.n_u + m + 1
        self.n = n
        nu = self.n_u
        red = unknown[dofs]                                   # (c, 6)
        self._red = red
        rk = np.repeat(red, 6, axis=1).ravel()
        ck = np.tile(red, (1, 6)).ravel()
        cells6 = np.repeat(np.arange(m, dtype=np.int64), 6)
        self.wall_rows = np.flatnonzero(np.asarray(wall) != 0.0)
        fr, fc = (np.asarray(v, dtype=np.int64) for v in flow_triplets)
        pr, pc = (np.asarray(v, dtype=np.int64) for v in permeability_triplets)
        if not well_row_permeability:
            pc = np.where(pr == m, -1, pc)           # no well-row entries
        self._perm_cell = np.where(pc >= 0, pc, 0)
        self._perm_valid = pc >= 0
        # every block's (row, col) in the full system; -1 where the entry is not stored
        blocks = {
            "k": (np.where((rk >= 0) & (ck >= 0), rk, -1), ck),
            "g": (red.ravel(), nu + cells6),
            "gt": (nu + cells6, red.ravel()),
            "wcol": (self.wall_rows, np.full(len(self.wall_rows), nu + m, dtype=np.int64)),
            "wrow": (np.full(len(self.wall_rows), nu + m, dtype=np.int64), self.wall_rows),
            "flow": (nu + fr, nu + fc),
        }
        self.biot_blocks = bool(biot_blocks)
        self._keys = {}
        for name, (r, c) in blocks.items():
            ok = (r >= 0) & (c >= 0)
            self._keys[name] = np.where(ok, r * np.int64(n) + c, -1)
        # the blocks every pattern stores; without Biot coupling G and Cfu are stored only
        # for the failed cells of a pattern (inserted with the crack entries)
        self._fixed = [k for k in self._keys if self.biot_blocks or k not in ("g", "gt")]
        self._per_cell = [k for k in ("g", "gt") if k not in self._fixed]
        base = np.concatenate([self._keys[k][self._keys[k] >= 0] for k in self._fixed])
        self._base = np.unique(base)
        # every block's slots in the base structure (shifted when crack entries are
        # inserted)
        self._base_slots = {}
        for name in self._fixed:
            k = self._keys[name]
            pos = np.searchsorted(self._base, np.where(k >= 0, k, 0))
            self._base_slots[name] = np.where(k >= 0, pos, -1).astype(np.int64)
        # crack block: entry t of dR/dk (row pr_t, cell pc_t) times DOF k of that cell
        cr = red[self._perm_cell]                                    # (n_k, 6)
        ok = (cr >= 0) & self._perm_valid[:, None]
        self._crack_keys = np.where(ok, (nu + pr)[:, None] * np.int64(n) + cr, -1)
        self._diag_keys = np.arange(nu, dtype=np.int64) * (n + 1)
        self._cached: CoupledPattern | None = None
        # the last few patterns by their crack cells (a step retried after a failure
        # round, or cut, goes back to the set before; building one costs ~2 ms)
        self._recent: dict[bytes, CoupledPattern] = {}

    @property
    def permeability_cells(self) -> np.ndarray:
        """Cell of each entry of ``dR/dk`` (0 where the entry is not used)."""
        return self._perm_cell

    def pattern(self, crack_cells: np.ndarray) -> CoupledPattern:
        """The CSR structure with the ``dk/du`` columns of ``crack_cells`` (bool, (m,)).

        The last patterns are cached: the same set gives the same object (what the linear
        solver's reuse of its ordering keys on)."""
        cc = np.asarray(crack_cells, dtype=bool)
        if cc.shape != (self.n_cells,):
            raise InputError(f"crack_cells has shape {cc.shape}, expected ({self.n_cells},)",
                             key="crack_cells")
        if self._cached is not None and np.array_equal(self._cached.crack_cells, cc):
            return self._cached
        key = np.packbits(cc).tobytes()
        pat = self._recent.get(key)
        if pat is not None:
            self._cached = pat
            return pat
        n = self.n
        base = self._base
        use = cc[self._perm_cell] & self._perm_valid
        ck = np.where(use[:, None], self._crack_keys, -1)
        # the pressure coupling of the failed cells when it is not in the base
        cell6 = np.repeat(cc, 6)
        pk = {name: np.where(cell6, self._keys[name], -1) for name in self._per_cell}
        extra = np.unique(np.concatenate([ck[ck >= 0]] + [v[v >= 0] for v in pk.values()]))
        # insert the crack entries not already in the base structure (both sorted)
        at = np.searchsorted(base, extra)
        new = extra[~((at < len(base)) & (base[np.minimum(at, len(base) - 1)] == extra))]
        keys = np.insert(base, np.searchsorted(base, new), new)
        moved = np.arange(len(base)) + np.searchsorted(new, base)   # base slot -> slot

        def shifted(name):
            if name in pk:
                k = pk[name]
                return np.where(k >= 0, np.searchsorted(keys, np.maximum(k, 0)), -1)
            bs = self._base_slots[name]
            return np.where(bs >= 0, moved[np.maximum(bs, 0)], -1)

        crack = np.searchsorted(keys, np.where(ck >= 0, ck, 0))
        rows = keys // n
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))])
        diag = np.searchsorted(keys, self._diag_keys)
        pat = CoupledPattern(
            n=n, indptr=indptr.astype(np.int32), indices=(keys % n).astype(np.int32),
            k_slots=shifted("k"), g_slots=shifted("g"), gt_slots=shifted("gt"),
            wcol_slots=shifted("wcol"), wrow_slots=shifted("wrow"),
            flow_slots=shifted("flow"), crack_slots=np.where(ck >= 0, crack, -1),
            diag_slots=diag.astype(np.int64), crack_cells=cc.copy())
        self._cached = pat
        if len(self._recent) >= _RECENT_PATTERNS:
            self._recent.pop(next(iter(self._recent)))
        self._recent[key] = pat
        return pat


def assemble_jacobian(pattern: CoupledPattern, *, blocks, g_values, gt_values, wall_column,
                      wall_row, flow_values, crack=None) -> sp.csr_matrix:
    """The coupled Jacobian as a CSR matrix on ``pattern``, its blocks summed in place.

    Parameters
    ----------
    pattern : CoupledPattern
    blocks : ndarray (n_c, 6, 6)
        Cluster tangents.
    g_values, gt_values : ndarray (n_c, 6)
        Entries of ``G`` and of ``Cfu`` (order ``(c, i)``).
    wall_column, wall_row : ndarray (n_w,)
        The ``-f_w`` column and the well row's volume entries on the wall DOFs.
    flow_values : ndarray
        The flow Jacobian's entries (``FlowResidual.jacobian_values``).
    crack : tuple ``(dRk, cell, dkdu)``, optional
        ``dR/dk`` entries (``FlowModel.permeability_derivative_values``), the cell of each
        (:attr:`CoupledLayout.permeability_cells`) and ``dk_c/du_c`` (m, 6); only the
        pattern's crack cells contribute.

    Returns
    -------
    scipy.sparse.csr_matrix (n, n)
    """
    p = pattern
    data = np.zeros(p.nnz)
    nc = len(p.g_slots) // 6
    for name, v, slots in (("blocks", blocks, p.k_slots), ("g_values", g_values, p.g_slots),
                           ("gt_values", gt_values, p.gt_slots),
                           ("wall_column", wall_column, p.wcol_slots),
                           ("wall_row", wall_row, p.wrow_slots),
                           ("flow_values", flow_values, p.flow_slots)):
        v = np.ascontiguousarray(v, dtype=np.float64).reshape(-1)
        if v.shape != slots.shape:
            raise InputError(f"{name} has {v.size} entries, the pattern {slots.size}", key=name)
        _scatter(data, slots, v)
    J = p.matrix(data)
    if crack is not None:
        add_crack_block(J, p, crack)
    return J


def add_crack_block(J: sp.csr_matrix, pattern: CoupledPattern, crack) -> None:
    """Add ``dR/dk dk/du`` to ``J`` (assembled on ``pattern``) in place; ``crack`` is
    ``(dRk, cell, dkdu)`` as in :func:`assemble_jacobian`."""
    p = pattern
    nc = len(p.g_slots) // 6
    dRk = np.ascontiguousarray(crack[0], dtype=np.float64)
    cell = np.ascontiguousarray(crack[1], dtype=np.int64)
    dkdu = np.ascontiguousarray(crack[2], dtype=np.float64)
    if (dRk.shape != (p.crack_slots.shape[0],) or cell.shape != dRk.shape
            or dkdu.shape != (nc, 6) or J.nnz != p.nnz):
        raise InputError("crack entries do not match the pattern", key="crack")
    _crack_block(J.data, p.crack_slots, dRk, cell, dkdu)


def hold_rows(J: sp.csr_matrix, pattern: CoupledPattern, rows, diagonal: float) -> None:
    """Replace rows of ``J`` (assembled on ``pattern``) by ``diagonal`` times the identity,
    in place: ``rows`` is a bool mask over the displacement unknowns (DOFs held for the
    step)."""
    r = np.flatnonzero(np.asarray(rows, dtype=bool))
    if r.size and r.max() >= len(pattern.diag_slots):
        raise InputError("rows beyond the displacement unknowns", key="rows")
    for i in r:
        J.data[pattern.indptr[i]:pattern.indptr[i + 1]] = 0.0
    J.data[pattern.diag_slots[r]] = float(diagonal)
