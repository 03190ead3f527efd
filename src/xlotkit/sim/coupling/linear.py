"""Linear solves of the coupled Newton: equilibrated sparse LU with its ordering and its
factor reused.

The coupled Jacobian's rows mix forces [N/m per m] and mass rates [kg/s per Pa] over many
decades, so it is equilibrated (rows by their largest entry, then columns by theirs, as
:func:`~xlotkit.sim.coupling.newton.equilibrated_solve` always did) and factored by
SuperLU. Two things are reused:

* **the ordering**: the fill-reducing column ordering (minimum degree on ``A + A^T``,
  diagonal pivots preferred; the coupled matrix is structurally symmetric) depends only on
  the sparsity pattern, which stays the same object while no cluster fails
  (:class:`~xlotkit.sim.coupling.assembly.CoupledPattern`). It is the column ordering
  SuperLU computes at the first factorisation on a pattern (a function of the structure
  alone) and every later factorisation on the pattern factors the symmetrically permuted
  matrix in its natural order; SciPy's SuperLU does not expose its symbolic analysis, so
  this is how the ordering is reused;
* **the numeric factor**: while the pattern holds and the contact statuses (the active
  set) the Jacobian was linearised with are the same or nearly (a few contacts changed),
  the next solves, in this Newton iteration and the next steps, use GMRES
  right-preconditioned by the last factor (:class:`LinearSolver`); within an active set the
  Jacobian changes only smoothly (fluid density, crack permeability, the step length), so
  a few Krylov iterations reach the accuracy the Newton asks for. When GMRES does not
  converge within its budget, or is converging too slowly to, the matrix is factored
  afresh. What the solver remembers (orderings, the factored matrix) is part of the
  engine's checkpoint (:meth:`LinearSolver.state`), so a resumed run repeats an
  uninterrupted one bit for bit.

Safeguards kept from the direct solve: a solve is accepted only with a scaled residual
``|A y - b| <= 1e-10 |b|``; otherwise SuperLU's default column ordering with partial
pivoting is the fallback.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numba import njit

from xlotkit.errors import InputError

__all__ = ["LinearSolver", "LinearStats", "equilibrate", "scaled_matvec"]

#: Relative scaled residual a solve must reach (the direct solve's acceptance test).
SOLVE_RTOL = 1e-10

_LU_OPTIONS = dict(diag_pivot_thresh=0.1, options={"SymmetricMode": True})


@njit(cache=True)
def _equilibrate_kernel(data, indices, indptr, out, r, c):  # pragma: no cover - compiled
    n = indptr.shape[0] - 1
    for i in range(r.shape[0]):
        r[i] = 0.0
    for j in range(n):
        for k in range(indptr[j], indptr[j + 1]):
            a = abs(data[k])
            if a > r[indices[k]]:
                r[indices[k]] = a
    for i in range(r.shape[0]):
        r[i] = 1.0 / r[i] if r[i] > 0.0 else 1.0
    for j in range(n):
        cm = 0.0
        for k in range(indptr[j], indptr[j + 1]):
            a = abs(data[k] * r[indices[k]])
            if a > cm:
                cm = a
        c[j] = 1.0 / cm if cm > 0.0 else 1.0
        for k in range(indptr[j], indptr[j + 1]):
            out[k] = data[k] * r[indices[k]] * c[j]


@njit(cache=True)
def _permuted_csc_kernel(indptr, indices, q, pos, out_map, out_indices, out_indptr):  # pragma: no cover - compiled
    # CSC of P A P^T from the CSR of A: column counts, then rows visited in their new
    # order so that every column's rows come out sorted
    n = q.shape[0]
    for j in range(n + 1):
        out_indptr[j] = 0
    for e in range(indptr[n]):
        out_indptr[pos[indices[e]] + 1] += 1
    for j in range(n):
        out_indptr[j + 1] += out_indptr[j]
    nxt = out_indptr[:n].copy()
    for i in range(n):
        r = q[i]
        for e in range(indptr[r], indptr[r + 1]):
            c = pos[indices[e]]
            k = nxt[c]
            out_map[k] = e
            out_indices[k] = i
            nxt[c] = k + 1


@njit(cache=True)
def _scaled_matvec_kernel(indptr, indices, data, x, r, out):  # pragma: no cover - compiled
    # out = r * (A @ x) for the CSR A: each row summed from 0 in the order of its stored
    # entries, as SciPy's csr_matvec does, so the result is the same to the bit (the
    # column index read unsigned: no negative-index wraparound in the inner loop, which
    # otherwise makes it ~1.5x slower than SciPy's)
    a = np.int64(indptr[0])
    for i in range(indptr.shape[0] - 1):
        b = np.int64(indptr[i + 1])
        s = 0.0
        for k in range(a, b):
            s += data[k] * x[np.uint64(indices[k])]
        out[i] = r[i] * s
        a = b


@njit(cache=True)
def _precondition_in_kernel(v, r, q, out):  # pragma: no cover - compiled
    # the right-hand side the factor solves for R^{-1} v: (r * (v / r))[q], the same
    # operations as _Factor.apply on v / r (q empty: no permutation)
    n = v.shape[0]
    if q.shape[0] == 0:
        for i in range(n):
            out[i] = r[i] * (v[i] / r[i])
    else:
        for k in range(n):
            i = q[k]
            out[k] = r[i] * (v[i] / r[i])


@njit(cache=True)
def _precondition_out_kernel(y, c, q, out):  # pragma: no cover - compiled
    # c * (y scattered back to the unpermuted numbering)
    n = y.shape[0]
    if q.shape[0] == 0:
        for i in range(n):
            out[i] = c[i] * y[i]
    else:
        for k in range(n):
            i = q[k]
            out[i] = c[i] * y[k]


def scaled_matvec(A: sp.csr_matrix, x: np.ndarray, r: np.ndarray,
                  out: np.ndarray | None = None) -> np.ndarray:
    """``r * (A @ x)`` for a CSR matrix ``A`` (n, n), the same to the bit as SciPy's
    product (each row's sum in the order of its stored entries).

    Parameters
    ----------
    A : scipy.sparse.csr_matrix (n, n)
    x, r : ndarray (n,)
    out : ndarray (n,), optional
        Where to write the result.

    Returns
    -------
    ndarray (n,)
    """
    if not sp.issparse(A) or A.format != "csr":
        raise InputError("expected a CSR matrix", key="A")
    n = A.shape[0]
    x = np.ascontiguousarray(x, dtype=np.float64)
    r = np.ascontiguousarray(r, dtype=np.float64)
    if x.shape != (A.shape[1],) or r.shape != (n,):
        raise InputError(f"x {x.shape} and r {r.shape} do not match A {A.shape}", key="x")
    if A.nnz and (int(A.indices.min()) < 0 or int(A.indices.max()) >= A.shape[1]):
        raise InputError("A has column indices out of range", key="A")
    if out is None:
        out = np.empty(n)
    elif out.shape != (n,) or out.dtype != np.float64:
        raise InputError("out must be a float64 array of shape (n,)", key="out")
    _scaled_matvec_kernel(A.indptr, A.indices, np.ascontiguousarray(A.data, np.float64),
                          x, r, out)
    return out


def equilibrate(A: sp.csc_matrix) -> tuple[sp.csc_matrix, np.ndarray, np.ndarray]:
    """Row then column equilibration of a square CSC matrix (no duplicate entries).

    Returns ``(R A C, r, c)`` with ``r_i = 1 / max_j |a_ij|`` and ``c_j = 1 / max_i |r_i
    a_ij|`` (1 for an empty row or column).
    """
    if not sp.issparse(A) or A.format != "csc" or A.shape[0] != A.shape[1]:
        raise InputError("expected a square CSC matrix", key="A")
    n = A.shape[0]
    out = np.empty_like(A.data, dtype=np.float64)
    r = np.empty(n)
    c = np.empty(n)
    _equilibrate_kernel(np.ascontiguousarray(A.data, dtype=np.float64),
                        A.indices.astype(np.int64), A.indptr.astype(np.int64), out, r, c)
    return sp.csc_matrix((out, A.indices, A.indptr), shape=A.shape), r, c


@dataclass
class LinearStats:
    """Work of a :class:`LinearSolver`.

    Attributes
    ----------
    solves : int
        Linear systems solved.
    factorisations : int
        Numeric LU factorisations (each solve that did not reuse a factor).
    orderings : int
        Fill-reducing orderings computed (one per new sparsity pattern).
    krylov_solves : int
        Solves done by GMRES with a reused factor.
    krylov_iterations : int
        Their GMRES iterations (one triangular solve each).
    krylov_failures : int
        GMRES attempts abandoned for a fresh factorisation.
    fallbacks : int
        Factorisations redone with SuperLU's default ordering and partial pivoting.
    factor_time, krylov_time : float
        Wall time [s] in factorisations (orderings included) and in the GMRES solves.
    """

    solves: int = 0
    factorisations: int = 0
    orderings: int = 0
    krylov_solves: int = 0
    krylov_iterations: int = 0
    krylov_failures: int = 0
    fallbacks: int = 0
    factor_time: float = 0.0
    krylov_time: float = 0.0


class _Ordering:
    """The symmetric permutation of one sparsity pattern (from the minimum-degree column
    ordering SuperLU computed for it: a function of the structure alone) and the map from
    the CSR data of a matrix on the pattern to the CSC data of the permuted matrix."""

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, n: int,
                 perm_c: np.ndarray) -> None:
        q = np.argsort(perm_c)               # new position k holds old unknown q[k]
        self.q = q
        pos = np.empty(n, dtype=np.int64)
        pos[q] = np.arange(n)
        nnz = int(indptr[-1])
        self.map = np.empty(nnz, dtype=np.int64)         # CSC data = CSR data[map]
        ind = np.empty(nnz, dtype=np.int64)
        ptr = np.empty(n + 1, dtype=np.int64)
        _permuted_csc_kernel(np.asarray(indptr, dtype=np.int64),
                             np.asarray(indices, dtype=np.int64), q.astype(np.int64), pos,
                             self.map, ind, ptr)
        self.indices = ind.astype(np.int32)
        self.indptr = ptr.astype(np.int32)
        self.nnz = nnz


class _Factor:
    """An equilibrated LU of a (permuted) matrix and how to apply its inverse."""

    def __init__(self, lu, A: sp.csc_matrix, r: np.ndarray, c: np.ndarray,
                 q: np.ndarray | None, key: bytes, status, variant, spec: str) -> None:
        self.lu, self.A, self.key, self.spec = lu, A, key, spec
        self.status, self.variant = status, variant
        self.q = q
        self._q = np.zeros(0, np.int64) if q is None else np.asarray(q, dtype=np.int64)
        self.r_factored, self.c_factored = r, c
        if q is None:
            self.r, self.c = r, c
        else:
            # scalings in the unpermuted numbering
            self.r = np.empty_like(r)
            self.c = np.empty_like(c)
            self.r[q] = r
            self.c[q] = c

    def apply(self, v: np.ndarray) -> np.ndarray:
        """``J_f^{-1} v`` for the factored matrix ``J_f``."""
        b = self.r * v
        if self.q is None:
            return self.c * self.lu.solve(b)
        y = self.lu.solve(b[self.q])
        out = np.empty_like(y)
        out[self.q] = y
        return self.c * out

    def apply_scaled(self, v: np.ndarray, work: np.ndarray, out: np.ndarray) -> None:
        """``out = J_f^{-1} (v / r)`` with ``r`` the factor's row scaling: what
        ``apply(v / self.r)`` gives, to the bit, without its temporaries (``work``: a
        scratch vector (n,))."""
        _precondition_in_kernel(v, self.r, self._q, work)
        _precondition_out_kernel(self.lu.solve(work), self.c, self._q, out)


class LinearSolver:
    """Solves of the coupled Jacobian with its ordering and its factor reused (module
    docstring).

    Parameters
    ----------
    krylov_iterations : int
        GMRES iterations allowed with a reused factor before factoring afresh; 0 never
        reuses the factor (every solve factors).
    krylov_rtol : float
        Scaled residual GMRES must reach by default (:data:`SOLVE_RTOL`, the direct
        solve's).
    max_changes : int
        Contacts whose status may differ from the factored Jacobian's for the factor to
        be tried: each changes the tangent by a rank-2 term, which GMRES resolves in about
        two iterations.
    max_orderings : int
        Orderings kept (by pattern).

    Attributes
    ----------
    stats : LinearStats

    Notes
    -----
    What a solve does depends on what was solved before (the factor and the orderings
    kept), never on anything else: :meth:`state` and :meth:`restore` carry that across a
    checkpoint, so a resumed run repeats an uninterrupted one bit for bit.
    """

    def __init__(self, krylov_iterations: int = 12, krylov_rtol: float = SOLVE_RTOL,
                 max_changes: int = 4, max_orderings: int = 4) -> None:
        if int(krylov_iterations) < 0:
            raise InputError("must be >= 0", key="krylov_iterations")
        if not 0 < krylov_rtol < 1:
            raise InputError("must be in (0, 1)", key="krylov_rtol")
        if int(max_changes) < 0:
            raise InputError("must be >= 0", key="max_changes")
        self.krylov_iterations = int(krylov_iterations)
        self.krylov_rtol = float(krylov_rtol)
        self.max_changes = int(max_changes)
        self.max_orderings = int(max_orderings)
        self.stats = LinearStats()
        self._orderings: dict[bytes, tuple[np.ndarray, _Ordering]] = {}
        self._factor: _Factor | None = None

    def reset(self) -> None:
        """Forget the factor and the orderings: the next solves are those of a new
        solver."""
        self._factor = None
        self._orderings = {}

    @staticmethod
    def _key(pattern) -> bytes:
        # a pattern is a function of its crack cells (and the model): they identify it
        return pattern.crack_cells.tobytes() + np.int64(pattern.nnz).tobytes()

    # ------------------------------------------------------------------ solve
    def solve(self, J: sp.spmatrix, rhs: np.ndarray, pattern=None, status=None,
              variant=None, rtol: float | None = None) -> np.ndarray:
        """Solve ``J x = rhs``.

        Parameters
        ----------
        J : sparse matrix (n, n)
        rhs : ndarray (n,)
        pattern : CoupledPattern, optional
            The pattern ``J`` is assembled on (CSR, its structure): enables the ordering
            and factor reuse. Without it the solve is a plain equilibrated LU.
        status : ndarray, optional
            The contact statuses ``J`` was linearised with: the factor is reused while at
            most ``max_changes`` of them differ from the factored matrix's.
        variant : hashable, optional
            Anything else the linearisation depends on (softened contacts): the factor
            is reused only for the same variant.
        rtol : float, optional
            Scaled residual a GMRES solve must reach (default ``krylov_rtol``): an
            inexact Newton step far from the solution needs no more than a fraction of
            the residual it corrects. A factorisation solves to round-off regardless.

        Raises
        ------
        RuntimeError
            If the matrix is singular.
        """
        rhs = np.asarray(rhs, dtype=float)
        if J.shape[0] != J.shape[1] or rhs.shape != (J.shape[0],):
            raise InputError(f"J {J.shape} and rhs {rhs.shape} do not match", key="rhs")
        self.stats.solves += 1
        f = self._factor
        key = None if pattern is None else self._key(pattern)
        if (f is not None and self.krylov_iterations > 0 and key is not None
                and f.key == key and f.variant == variant and self._close(f.status, status)):
            x = self._gmres(J, rhs, f, self.krylov_rtol if rtol is None
                            else min(max(float(rtol), self.krylov_rtol), 1e-2))
            if x is not None:
                return x
        return self._factor_and_solve(J, rhs, pattern, key, status, variant)

    def _close(self, a, b) -> bool:
        if a is None or b is None:
            return a is None and b is None
        return a.shape == b.shape and int(np.count_nonzero(a != b)) <= self.max_changes

    def _factor_and_solve(self, J, rhs, pattern, key, status, variant) -> np.ndarray:
        t0 = time.perf_counter()
        try:
            o = None if key is None else self._orderings.get(key, (None, None))[1]
            if o is not None:
                # the pattern's ordering: factor the permuted matrix as it stands
                Jc = J if J.format == "csr" else J.tocsr()
                if Jc.nnz != o.nnz:
                    raise InputError("J is not on its pattern", key="J")
                P = sp.csc_matrix((Jc.data[o.map], o.indices, o.indptr), shape=J.shape)
                spec = "NATURAL"
            else:
                P = J.tocsc(copy=True)
                P.sum_duplicates()
                # minimum degree on A + A^T with diagonal pivots preferred: the coupled
                # matrix is structurally symmetric (about half the fill of the default)
                spec = "MMD_AT_PLUS_A"
            A, r, c = equilibrate(P)
            q = None if o is None else o.q
            b = r * (rhs if q is None else rhs[q])
            self.stats.factorisations += 1
            try:
                lu = spla.splu(A, permc_spec=spec, **_LU_OPTIONS)
                y = lu.solve(b)
                ok = bool(np.all(np.isfinite(y))) and (
                    np.linalg.norm(A @ y - b) <= SOLVE_RTOL * max(np.linalg.norm(b), 1e-300))
            except RuntimeError:
                lu, ok = None, False
            if key is not None and lu is not None and o is None:
                # the ordering SuperLU computed for the pattern (structure only)
                self._remember(key, pattern.crack_cells,
                               _Ordering(pattern.indptr, pattern.indices, pattern.n,
                                         lu.perm_c))
            if not ok:
                # the diagonal pivots were poor: default ordering, partial pivoting
                self.stats.fallbacks += 1
                spec = "DEFAULT"
                lu = spla.splu(A)
                y = lu.solve(b)
            if key is not None:
                self._factor = _Factor(lu, A, r, c, q, key, status, variant, spec)
            x = c * y
            if q is not None:
                out = np.empty_like(x)
                out[q] = x
                x = out
            return x
        finally:
            self.stats.factor_time += time.perf_counter() - t0

    def _remember(self, key: bytes, crack_cells: np.ndarray, o: _Ordering) -> None:
        self.stats.orderings += 1
        if len(self._orderings) >= self.max_orderings:
            self._orderings.pop(next(iter(self._orderings)))
        self._orderings[key] = (np.array(crack_cells, dtype=bool), o)

    # ------------------------------------------------------------------ checkpoint
    def state(self) -> dict[str, np.ndarray]:
        """The solver's memory as arrays (a checkpoint): the orderings kept (their
        patterns' crack cells and permutations) and the factored matrix with what it was
        linearised with. :meth:`restore` rebuilds the same factor from them."""
        out: dict[str, np.ndarray] = {"n_orderings": np.array(len(self._orderings))}
        for i, (cells, o) in enumerate(self._orderings.values()):
            out[f"ordering{i}.cells"] = cells
            out[f"ordering{i}.q"] = o.q
            out[f"ordering{i}.nnz"] = np.array(o.nnz)
        f = self._factor
        if f is not None:
            out.update({
                "factor.key": np.frombuffer(f.key, dtype=np.uint8).copy(),
                "factor.data": f.A.data, "factor.indices": f.A.indices,
                "factor.indptr": f.A.indptr,
                "factor.r": f.r_factored, "factor.c": f.c_factored,
                "factor.q": np.zeros(0, np.int64) if f.q is None else f.q,
                "factor.has_q": np.array(f.q is not None),
                "factor.spec": np.array(["NATURAL", "MMD_AT_PLUS_A", "DEFAULT"].index(f.spec)),
                "factor.has_status": np.array(f.status is not None),
                "factor.status": np.zeros(0, np.int64) if f.status is None else f.status,
                "factor.variant": (np.zeros(0, np.uint8) if f.variant is None
                                   else np.frombuffer(f.variant, dtype=np.uint8).copy()),
                "factor.has_variant": np.array(f.variant is not None)})
        return out

    def restore(self, state, pattern_of) -> None:
        """Continue from :meth:`state`; ``pattern_of(crack_cells)`` gives the pattern of
        a set of crack cells (``CoupledLayout.pattern``)."""
        self.reset()
        for i in range(int(state["n_orderings"])):
            cells = np.asarray(state[f"ordering{i}.cells"], dtype=bool)
            pat = pattern_of(cells)
            if pat.nnz != int(state[f"ordering{i}.nnz"]):
                raise InputError("the checkpoint's solver state does not fit the model",
                                 key="checkpoint")
            q = np.asarray(state[f"ordering{i}.q"], dtype=np.int64)
            perm_c = np.empty_like(q)
            perm_c[q] = np.arange(len(q))
            o = _Ordering(pat.indptr, pat.indices, pat.n, perm_c)
            self._orderings[self._key(pat)] = (cells.copy(), o)
        if "factor.data" not in state:
            return
        A = sp.csc_matrix((np.asarray(state["factor.data"], dtype=float),
                           np.asarray(state["factor.indices"]),
                           np.asarray(state["factor.indptr"])))
        spec = ["NATURAL", "MMD_AT_PLUS_A", "DEFAULT"][int(state["factor.spec"])]
        lu = spla.splu(A) if spec == "DEFAULT" else spla.splu(A, permc_spec=spec,
                                                               **_LU_OPTIONS)
        q = (np.asarray(state["factor.q"], dtype=np.int64)
             if bool(state["factor.has_q"]) else None)
        self._factor = _Factor(
            lu, A, np.asarray(state["factor.r"], dtype=float),
            np.asarray(state["factor.c"], dtype=float), q,
            np.asarray(state["factor.key"], dtype=np.uint8).tobytes(),
            np.asarray(state["factor.status"], dtype=np.int64)
            if bool(state["factor.has_status"]) else None,
            np.asarray(state["factor.variant"], dtype=np.uint8).tobytes()
            if bool(state["factor.has_variant"]) else None, spec)

    def _gmres(self, J, rhs, f: _Factor, rtol: float) -> np.ndarray | None:
        """GMRES on the row-scaled system ``R J x = R rhs``, right-preconditioned by the
        factor ``f`` (``x = J_f^{-1} R^{-1} w``); None when it does not reach the
        tolerance within the budget (or is converging too slowly to).

        Modified Gram-Schmidt Arnoldi with Givens rotations; the products with ``J`` and
        the preconditioner run in compiled kernels into preallocated arrays, every
        floating-point operation the same as the plain NumPy loop's."""
        t0 = time.perf_counter()
        try:
            r = f.r
            Jc = J if J.format == "csr" else J.tocsr()
            b = r * rhs
            beta = math.sqrt(float(b.dot(b)))
            if beta == 0.0:
                return np.zeros_like(rhs)
            kmax = self.krylov_iterations
            tol = rtol * beta
            n = len(rhs)
            V = np.empty((kmax + 1, n))
            Z = np.empty((kmax, n))
            H = np.zeros((kmax + 1, kmax))
            cs = [0.0] * kmax
            sn = [0.0] * kmax
            g = np.zeros(kmax + 1)
            g[0] = beta
            np.divide(b, beta, out=V[0])
            w = np.empty(n)
            work = np.empty(n)
            indptr, indices = Jc.indptr, Jc.indices
            data = np.ascontiguousarray(Jc.data, dtype=np.float64)
            limit = 100.0 * rtol
            k = 0
            for j in range(kmax):
                zj = Z[j]
                f.apply_scaled(V[j], work, zj)
                _scaled_matvec_kernel(indptr, indices, data, zj, r, w)
                hj = [0.0] * (j + 2)
                for i in range(j + 1):           # modified Gram-Schmidt
                    vi = V[i]
                    h = float(vi.dot(w))
                    hj[i] = h
                    w -= h * vi
                hn = math.sqrt(float(w.dot(w)))
                hj[j + 1] = hn
                for i in range(j):               # the earlier Givens rotations
                    t = cs[i] * hj[i] + sn[i] * hj[i + 1]
                    hj[i + 1] = -sn[i] * hj[i] + cs[i] * hj[i + 1]
                    hj[i] = t
                d = float(np.hypot(hj[j], hj[j + 1]))
                H[:j + 2, j] = hj
                if d == 0.0:
                    break
                cs[j], sn[j] = hj[j] / d, hj[j + 1] / d
                H[j, j] = d
                H[j + 1, j] = 0.0
                gj = float(g[j])
                g[j + 1] = -sn[j] * gj
                g[j] = cs[j] * gj
                k = j + 1
                self.stats.krylov_iterations += 1
                res = abs(float(g[j + 1]))
                if res <= tol or hn == 0.0:
                    break
                # converging too slowly to reach the tolerance within the budget (at
                # its rate so far, with a margin of 100): the factor is stale
                if j >= 2 and (res / beta) ** (kmax / (j + 1)) > limit:
                    break
                np.divide(w, hn, out=V[j + 1])
            if k == 0:
                self.stats.krylov_failures += 1
                return None
            # H[:k, :k] is upper triangular as it stands: the rotations zeroed each
            # subdiagonal entry and nothing below it was ever written
            y = np.linalg.solve(H[:k, :k], g[:k])
            x = Z[:k].T @ y
            # the true scaled residual decides (the recurrence drifts near 1e-10)
            if np.all(np.isfinite(x)):
                _scaled_matvec_kernel(indptr, indices, data, x, r, w)
                e = b - w
                if math.sqrt(float(e.dot(e))) <= tol:
                    self.stats.krylov_solves += 1
                    return x
            self.stats.krylov_failures += 1
            return None
        finally:
            self.stats.krylov_time += time.perf_counter() - t0
