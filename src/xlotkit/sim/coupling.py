"""Monolithic implicit poroelastic step: nodal displacements, cell pressures, well pressure.

First increment of the fully coupled hydro-mechanics (SPEC §5, coupling strategy
``monolithic``): intact rock only (no cluster failure, no fracture aperture yet). See
``docs/coupling.md`` for the derivation and what is verified.

Unknowns ``x = (u_f, p, p_w)``: the free nodal displacements ``u_f`` (the mechanics' free
DOFs minus any extra constraints given here), one pressure per triangle and the borehole
pressure. Residuals, for a step ``t_n -> t_{n+1} = t_n + dt`` (backward Euler):

Mechanics, per unit thickness [N/m], exact for intact (linear elastic) clusters::

    R_u = K (u - u_0) + G (p - p_0) - f_w (p_w - p_w0) - L(t_{n+1})

``K`` is the mechanics' tangent (:meth:`MechanicsModel.tangent`), ``G`` the assembled
pressure-load operator (:meth:`MechanicsModel.pressure_load`: column ``c`` holds the nodal
forces ``-alpha A_c B_c^T (1, 1, 0)`` of a unit pressure in cluster ``c``), ``f_w`` the nodal
load of a unit wall pressure (``MechanicsModel.f_wall``), ``L`` an extra external load
(nodal forces, e.g. a surface load step) and index 0 the initial equilibrium
(:meth:`MechanicsModel.initial_state`). Because intact clusters are linear, this incremental
form *is* the mechanics' residual ``f_int - f_ext`` relative to the initial equilibrium.

Flow, per cell [kg/s]: :meth:`FlowModel.residual_and_jacobian` with the extra pore volume
supplied by the skeleton (Biot)::

    V^x_c = alpha h A_c eps_vol,c = -h (G^T (u - u_0))_c

(``eps_vol = eps_xx + eps_yy``, tension positive; plane strain). The two couplings use the
same operator ``G``, which is what makes the discrete Biot system consistent (the work of
the pore pressure on the skeleton equals ``p dV^x``).

Storage (no double counting): the flow's stored mass is
``rho(p) (phi(p) V + V^x)`` with ``phi(p) = phi_ref (1 + c_r (p - p_ref))``. The drained
skeleton's pore-volume change is entirely in ``V^x`` (``alpha eps_vol``), so ``c_r`` must
hold only the grain term of the Biot modulus,
``phi c_r = (alpha - phi) / K_s = (alpha - phi)(1 - alpha) / K`` (``K`` drained bulk modulus,
``K_s = K / (1 - alpha)``), giving ``1/M = phi c_f + (alpha - phi)/K_s``. Use
:func:`grain_pore_compressibility`; :class:`CoupledModel` refuses a larger ``c_r`` (that would
count the drained pore compressibility twice) unless ``check_storage=False``.

Jacobian (derivation in docs/coupling.md)::

    [ dR_u/du  dR_u/dp  dR_u/dp_w ]   [  K                       G     -f_w ]
    [ dR_f/du  dR_f/dp  dR_f/dp_w ] = [ -diag(rho/dt) h G^T      J_flow     ]

with ``J_flow`` the flow Jacobian (storage + TPFA fluxes + well row). Linear solves use
SciPy's SuperLU on the row- and column-equilibrated matrix (the blocks differ by ~20 orders
of magnitude in SI units).

Sign convention: displacements as in the mechanics (from the pre-drilling state);
stresses returned by :meth:`CoupledModel.stress` are compression positive.

Not yet here (see docs/coupling.md): failed clusters (aperture, fracture permeability and
porosity, contact active set in the same Newton, failure checks and their step control),
the hole's volume change in the well storage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from xlotkit.errors import InputError
from xlotkit.sim.flow import FlowModel, FlowState
from xlotkit.sim.mechanics import MechanicsModel, MechanicsState
from xlotkit.sim.mechanics.assembly import edge_traction_load
from xlotkit.sim.mechanics.mdem import cst_b_matrix
from xlotkit.sim.mesh import Mesh

__all__ = [
    "CoupledControl",
    "CoupledCounters",
    "CoupledModel",
    "CoupledResidual",
    "CoupledState",
    "CoupledStepper",
    "StepResult",
    "biot_modulus",
    "boundary_load",
    "grain_pore_compressibility",
]

LoadFunction = Callable[[float], np.ndarray]


# --------------------------------------------------------------------------- helpers
def drained_bulk_modulus(young: float, poisson: float) -> float:
    """Drained (3D) bulk modulus ``K = E / (3 (1 - 2 nu))`` [Pa]."""
    return young / (3.0 * (1.0 - 2.0 * poisson))


def grain_pore_compressibility(biot: float, porosity, young: float, poisson: float):
    """Pore compressibility ``c_r`` [1/Pa] to give the flow model when the skeleton's
    volume change is coupled: only the grain term, ``phi c_r = (alpha - phi) / K_s`` with
    ``K_s = K / (1 - alpha)`` the grain bulk modulus.

    Returns 0 for ``alpha = 1`` (incompressible grains). Raises if ``alpha < phi`` (no
    admissible grain modulus).
    """
    phi = np.asarray(porosity, dtype=float)
    if np.any(biot < phi):
        raise InputError(f"Biot coefficient {biot} is below the porosity", key="rock.biot",
                         expected=">= porosity")
    K = drained_bulk_modulus(young, poisson)
    c = (biot - phi) * (1.0 - biot) / (phi * K)
    return float(c) if np.ndim(c) == 0 else c


def biot_modulus(biot: float, porosity: float, fluid_compressibility: float, young: float,
                 poisson: float) -> float:
    """Biot modulus ``M`` [Pa]: ``1/M = phi c_f + (alpha - phi)/K_s``, ``K_s = K/(1-alpha)``."""
    K = drained_bulk_modulus(young, poisson)
    inv = porosity * fluid_compressibility + (biot - porosity) * (1.0 - biot) / K
    return 1.0 / inv


def boundary_load(mesh: Mesh, tags, stress) -> np.ndarray:
    """Consistent nodal forces [N/m] (shape ``(2 n,)``) of a uniform *compression-positive*
    stress change ``stress`` (2x2, or a scalar for ``s I``) acting on the boundary edges with
    the given tags (a surface load step: ``stress = q`` on ``TOP``)."""
    s = np.asarray(stress, dtype=float)
    S = s * np.eye(2) if s.ndim == 0 else s
    if S.shape != (2, 2):
        raise InputError("stress must be a scalar or 2x2", key="stress")
    sel = np.isin(mesh.boundary_tags, np.atleast_1d(np.asarray(tags, dtype=np.int64)))
    return edge_traction_load(mesh.nodes, mesh.boundary_edges[sel], -S)


# --------------------------------------------------------------------------- state
def _ro(a) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class CoupledState:
    """State of the coupled model at one time (read-only arrays).

    Attributes
    ----------
    displacement : ndarray (n_nodes, 2) [m]
        From the pre-drilling state (as :class:`MechanicsState`).
    flow : FlowState
        Time, cell pressures, well pressure and the skeleton's extra pore volume.
    applied_load : ndarray (2 n_nodes,) [N/m]
        Extra external nodal load the state is in equilibrium with.
    """

    displacement: np.ndarray
    flow: FlowState
    applied_load: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "displacement", _ro(self.displacement))
        object.__setattr__(self, "applied_load", _ro(self.applied_load))

    @property
    def t(self) -> float:
        return self.flow.t

    @property
    def p(self) -> np.ndarray:
        return self.flow.p

    @property
    def p_w(self) -> float:
        return self.flow.p_w


@dataclass(frozen=True, eq=False)
class CoupledResidual:
    """Residual and Jacobian of the coupled system at one iterate.

    Attributes
    ----------
    residual : ndarray (n_u + m + 1,)
        ``(R_u [N/m], R_f [kg/s], R_w [kg/s])``.
    jacobian : scipy.sparse.csr_matrix
    force_scale : float
        Scale of the mechanical terms [N/m] for the relative tolerance.
    mass_scale : float
        Scale of the step's mass rates [kg/s]: the flow throughput plus the gross storage
        terms (skeleton volume change and fluid/grain compression, which cancel in an
        undrained step).
    flow : FlowResidual
        The flow part with its mass diagnostics.
    state : CoupledState
        The iterate as a state.
    """

    residual: np.ndarray
    jacobian: sp.csr_matrix
    force_scale: float
    mass_scale: float
    flow: object
    state: CoupledState


# --------------------------------------------------------------------------- model
class CoupledModel:
    """Biot-coupled intact rock: a :class:`MechanicsModel` and a :class:`FlowModel` on the
    same mesh, solved together.

    Parameters
    ----------
    mechanics : MechanicsModel
    flow : FlowModel
        Its ``rock.pore_compressibility`` must hold only the grain term
        (:func:`grain_pore_compressibility`); its ``height`` is the segment height ``h``.
    fixed_dofs : array of int, optional
        Displacement DOFs (``2 k`` = x, ``2 k + 1`` = y of node ``k``) held at their initial
        value in addition to the mechanics' boundary conditions (e.g. rollers on the right
        side of an oedometer column).
    load : ndarray (2 n,) or callable ``t -> ndarray``, optional
        Extra external nodal load [N/m] (relative to the in-situ state); a constant array
        applies for all ``t`` (use :meth:`CoupledStepper.step_undrained` to apply it at
        ``t = 0``).
    check_storage : bool
        Refuse a pore compressibility above the grain term (double counting).
    """

    def __init__(self, mechanics: MechanicsModel, flow: FlowModel, *, fixed_dofs=None,
                 load: np.ndarray | LoadFunction | None = None,
                 check_storage: bool = True) -> None:
        if not isinstance(mechanics, MechanicsModel):
            raise InputError("expected a MechanicsModel", key="mechanics")
        if not isinstance(flow, FlowModel):
            raise InputError("expected a FlowModel", key="flow")
        mesh = mechanics.mesh
        if (flow.mesh.n_triangles != mesh.n_triangles or flow.mesh.n_nodes != mesh.n_nodes
                or not np.array_equal(flow.mesh.triangles, mesh.triangles)
                or not np.allclose(flow.mesh.nodes, mesh.nodes, rtol=0, atol=1e-12)):
            raise InputError("mechanics and flow must use the same mesh", key="flow.mesh")
        self.mechanics = mechanics
        self.flow = flow
        self.mesh = mesh
        self.height = float(flow.height)
        self.biot = float(mechanics.rock.biot)
        rock = mechanics.rock
        if check_storage:
            phi = np.asarray(flow.porosity)
            if np.any(self.biot < phi):
                raise InputError("Biot coefficient below the porosity", key="rock.biot",
                                 expected=">= porosity")
            c_max = np.min(grain_pore_compressibility(self.biot, phi, rock.young,
                                                      rock.poisson))
            cr = flow.rock.pore_compressibility
            if cr > c_max * (1.0 + 1e-9) + 1e-30:
                raise InputError(
                    f"pore compressibility {cr:g} 1/Pa exceeds the grain term {c_max:g} 1/Pa: "
                    "the drained pore compressibility is already in alpha*eps_vol "
                    "(double counting)", key="flow.rock.pore_compressibility",
                    expected=f"<= {c_max:g} (grain_pore_compressibility)")
        n_dof = mechanics.n_dof
        free = np.array(mechanics.free, dtype=bool)
        mech_index = np.cumsum(free) - 1      # reduced index of the mechanics' free DOFs
        if fixed_dofs is not None:
            fd = np.unique(np.asarray(fixed_dofs, dtype=np.int64))
            if fd.size and (fd.min() < 0 or fd.max() >= n_dof):
                raise InputError("DOF index out of range", key="fixed_dofs")
            free[fd] = False
        self.free = free
        self.free_dofs = np.flatnonzero(free)
        self._sel = mech_index[self.free_dofs]   # rows/cols of the mechanics' reduced K
        self.n_u = len(self.free_dofs)
        self.n_cells = mesh.n_triangles
        self.n_unknowns = self.n_u + self.n_cells + 1
        if callable(load):
            self._load = load
        else:
            f = np.zeros(n_dof) if load is None else np.asarray(load, dtype=float)
            if f.shape != (n_dof,):
                raise InputError(f"load must have shape ({n_dof},)", key="load")
            self._load = lambda t, _f=f: _f
        self.mech_state0: MechanicsState | None = None
        self._B = cst_b_matrix(mesh.nodes, mesh.triangles)

    # ---------------------------------------------------------------- setup
    def _operators(self, mstate: MechanicsState) -> None:
        m = self.mechanics
        K = m.tangent(mstate).tocsr()
        self.K = K[self._sel][:, self._sel].tocsr()
        vec, dofs = m.pressure_load(mstate)
        nc = self.n_cells
        G = sp.csr_matrix((np.asarray(vec).ravel(),
                           (np.asarray(dofs).ravel(), np.repeat(np.arange(nc), 6))),
                          shape=(m.n_dof, nc))
        self.G_full = G
        self.G = G[self.free_dofs].tocsr()
        self.f_wall = np.asarray(m.f_wall, dtype=float)[self.free_dofs]
        # fluid volume change per unit displacement (free DOFs): dV^x/du = -h G^T
        self.dV_du = (-self.height * self.G.T).tocsr()

    def initial_state(self, mechanics_state: MechanicsState | None = None,
                      p_w: float | None = None, t: float = 0.0) -> CoupledState:
        """Coupled state at the in-situ equilibrium (drilled hole, uniform ``p0``).

        The mechanics' initial equilibrium (:meth:`MechanicsModel.initial_state`, or the one
        given) is the reference state ``(u_0, p_0, p_w0)`` of the incremental residual.
        """
        ms = (self.mechanics.initial_state(p_w) if mechanics_state is None
              else mechanics_state)
        if np.any(np.asarray(ms.cluster_state) != 0):
            raise InputError("this increment handles intact rock only",
                             key="mechanics_state.cluster_state")
        self.mech_state0 = ms
        self._operators(ms)
        self.u0 = np.asarray(ms.displacement, dtype=float).reshape(-1).copy()
        self.p0 = np.asarray(ms.pore_pressure, dtype=float).copy()
        self.pw0 = float(ms.wall_pressure)
        fs = self.flow.initial_state(self.p0, p_w=self.pw0, t=t)
        return CoupledState(self.u0.reshape(-1, 2), fs, np.zeros(self.mechanics.n_dof))

    def _require_init(self) -> None:
        if self.mech_state0 is None:
            raise RuntimeError("call initial_state() first")

    # ---------------------------------------------------------------- vectors
    def x_of(self, state: CoupledState) -> np.ndarray:
        """Unknown vector ``(u_f, p, p_w)`` of a state."""
        u = np.asarray(state.displacement).reshape(-1)[self.free_dofs]
        return np.concatenate([u, state.p, [state.p_w]])

    def load_at(self, t: float) -> np.ndarray:
        """Extra external nodal load at ``t`` [N/m], shape (2 n,)."""
        f = np.asarray(self._load(t), dtype=float)
        if f.shape != (self.mechanics.n_dof,):
            raise InputError(f"load(t) must have shape ({self.mechanics.n_dof},)", key="load")
        return f

    def state_of(self, x: np.ndarray, t: float, load: np.ndarray) -> CoupledState:
        """State of an unknown vector ``x`` at time ``t`` with the applied ``load``."""
        self._require_init()
        nu, m = self.n_u, self.n_cells
        u = self.u0.copy()
        u[self.free_dofs] = x[:nu]
        vx = self.dV_du @ (x[:nu] - self.u0[self.free_dofs])
        fs = FlowState(t, x[nu:nu + m], x[nu + m], vx)
        return CoupledState(u.reshape(-1, 2), fs, load)

    # ---------------------------------------------------------------- residual
    def residual_and_jacobian(self, x: np.ndarray, old: CoupledState, dt: float,
                              undrained: bool = False) -> CoupledResidual:
        """Residual and Jacobian at the iterate ``x`` for the step from ``old``.

        Parameters
        ----------
        x : ndarray (n_u + m + 1,)
        old : CoupledState
            Converged state at ``t_n``.
        dt : float
            Step [s]. With ``undrained=True`` the step is instantaneous: no flow between
            cells, across the boundary or from the well (``t`` unchanged), and ``dt``
            only scales the rows.
        undrained : bool
        """
        self._require_init()
        nu, m = self.n_u, self.n_cells
        t_new = old.t if undrained else old.t + dt
        load = self.load_at(t_new)
        st = self.state_of(x, t_new, load)
        du = x[:nu] - self.u0[self.free_dofs]
        dp = x[nu:nu + m] - self.p0
        dpw = x[nu + m] - self.pw0
        Lf = load[self.free_dofs]
        Ku = self.K @ du
        Gp = self.G @ dp
        Ru = Ku + Gp - self.f_wall * dpw - Lf
        force_scale = max(float(np.max(np.abs(Ku), initial=0.0)),
                          float(np.max(np.abs(Gp), initial=0.0)),
                          float(np.max(np.abs(self.f_wall), initial=0.0)) * abs(dpw),
                          float(np.max(np.abs(Lf), initial=0.0)), 1e-300)
        kw = {}
        if undrained:
            kw = dict(permeability=np.zeros(m), well_rate=0.0)
        fr = self.flow.residual_and_jacobian(st.flow, old.flow, dt, **kw)
        rho_dt = np.asarray(fr.d_residual_d_extra_volume)
        Cfu = sp.vstack([sp.diags(rho_dt) @ self.dV_du, sp.csr_matrix((1, nu))])
        Kp = sp.hstack([self.G, sp.csr_matrix(-self.f_wall.reshape(-1, 1))])
        J = sp.bmat([[self.K, Kp], [Cfu, fr.jacobian]], format="csr")
        R = np.concatenate([Ru, fr.residual])
        mass_scale = fr.throughput + self._gross_storage(st, old) / dt
        return CoupledResidual(R, J, force_scale, mass_scale, fr, st)

    def _gross_storage(self, st: CoupledState, old: CoupledState) -> float:
        """Sum of the magnitudes of the separate storage terms of a step [kg]."""
        f = self.flow
        rho_o = f.fluid.rho(old.p)
        dp = st.p - old.p
        comp = f.volumes * rho_o * (f.porosity * f.fluid.compressibility
                                    + f.porosity * f.rock.pore_compressibility) * np.abs(dp)
        skel = rho_o * np.abs(st.flow.extra_pore_volume - old.flow.extra_pore_volume)
        return float(np.sum(comp) + np.sum(skel))

    # ---------------------------------------------------------------- post-processing
    def volumetric_strain(self, state: CoupledState) -> np.ndarray:
        """Cluster volumetric strain change from the initial state (tension positive)."""
        self._require_init()
        du = np.asarray(state.displacement).reshape(-1) - self.u0
        return -(self.G_full.T @ du) / (self.biot * self.mesh.areas)

    def stress(self, state: CoupledState) -> np.ndarray:
        """Cluster total stress ``(sxx, syy, sxy)`` [Pa], compression positive.

        Intact clusters: ``sigma = sigma0 - alpha p0 I - C eps(u) + alpha p I`` (the
        mechanics' in-situ state plus the CST/MDEM response; ``u`` from pre-drilling).
        """
        mech = self.mechanics
        u = np.asarray(state.displacement).reshape(-1)[mech.dofs]
        eps = np.einsum("cij,cj->ci", self._B, u)
        iso = np.array([1.0, 1.0, 0.0])
        p0 = mech.in_situ.pore_pressure
        s0 = mech.sigma0 - self.biot * p0 * iso
        return s0[None, :] - eps @ np.asarray(mech.C).T + self.biot * np.outer(state.p, iso)


# --------------------------------------------------------------------------- stepper
@dataclass(frozen=True)
class CoupledControl:
    """Newton settings of the coupled step.

    Attributes
    ----------
    max_newton : int
    force_rtol : float
        ``max |R_u| <= force_rtol * force_scale``.
    mass_rtol : float
        ``sum |R_f| <= mass_rtol * mass_scale`` (mass rates; as the flow stepper).
    stagnation_rtol : float
        Mass residual accepted when Newton stagnates at round-off.
    mass_balance_tol : float
        A converged step whose relative mass-balance error exceeds this is rejected.
    """

    max_newton: int = 15
    force_rtol: float = 1e-10
    mass_rtol: float = 1e-11
    stagnation_rtol: float = 1e-8
    mass_balance_tol: float = 1e-8

    def __post_init__(self) -> None:
        if int(self.max_newton) < 1:
            raise InputError("must be >= 1", key="coupling.max_newton")
        for k in ("force_rtol", "mass_rtol", "stagnation_rtol", "mass_balance_tol"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float)) and 0 < v < 1):
                raise InputError(f"must be in (0, 1), got {v!r}", key=f"coupling.{k}")


@dataclass
class CoupledCounters:
    """Cumulative work counters of a :class:`CoupledStepper`."""

    steps: int = 0
    failed_steps: int = 0
    newton_iterations: int = 0
    linear_solves: int = 0
    residual_evaluations: int = 0


@dataclass(frozen=True)
class StepResult:
    """Outcome of one attempted coupled step.

    Attributes
    ----------
    success : bool
    reason : str
        ``"converged"``, ``"newton: no convergence"``, ``"newton: singular"``,
        ``"newton: non-finite"`` or ``"mass balance"``.
    newton_iterations, linear_solves : int
    dt : float
        Step [s] (0 for an undrained step).
    t : float
        Time after the step (unchanged on failure).
    max_dp : float
        Largest change of a cell or well pressure [Pa].
    injected_mass, outflow_mass, stored_mass_change : float [kg]
    mass_balance_error : float
        ``injected - stored change - outflow`` [kg].
    relative_mass_balance_error : float
        ``|error|`` over the step's gross mass scale.
    force_residual : float
        ``max |R_u|`` over the force scale at the end.
    """

    success: bool
    reason: str
    newton_iterations: int
    linear_solves: int
    dt: float
    t: float
    max_dp: float = float("nan")
    injected_mass: float = float("nan")
    outflow_mass: float = float("nan")
    stored_mass_change: float = float("nan")
    mass_balance_error: float = float("nan")
    relative_mass_balance_error: float = float("nan")
    force_residual: float = float("nan")


def _equilibrated_solve(J: sp.csr_matrix, rhs: np.ndarray) -> np.ndarray:
    """Solve ``J x = rhs`` with row then column scaling by the largest entries."""
    A = J.tocsr()
    r = np.asarray(abs(A).max(axis=1).toarray()).ravel()
    r = np.where(r > 0, 1.0 / r, 1.0)
    A = sp.diags(r) @ A
    c = np.asarray(abs(A).max(axis=0).toarray()).ravel()
    c = np.where(c > 0, 1.0 / c, 1.0)
    A = (A @ sp.diags(c)).tocsc()
    y = spla.splu(A).solve(r * rhs)
    return c * y


class CoupledStepper:
    """Implicit (backward-Euler) monolithic steps of a :class:`CoupledModel`.

    Parameters
    ----------
    model : CoupledModel
    state : CoupledState, optional
        Start; default ``model.initial_state()``.
    control : CoupledControl, optional

    Attributes
    ----------
    state : CoupledState
        Last accepted state.
    counters : CoupledCounters
    history : list of StepResult
        Accepted and failed steps, in order.
    """

    def __init__(self, model: CoupledModel, state: CoupledState | None = None,
                 control: CoupledControl | None = None) -> None:
        self.model = model
        self.state = model.initial_state() if state is None else state
        self.control = control or CoupledControl()
        self.counters = CoupledCounters()
        self.history: list[StepResult] = []

    def step(self, dt: float) -> StepResult:
        """Advance by ``dt`` [s] (load and well schedule at the step end / midpoint)."""
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise InputError(f"time step must be > 0, got {dt!r}", key="dt")
        return self._solve(float(dt), undrained=False)

    def step_undrained(self) -> StepResult:
        """Instantaneous (undrained) response to the load at the current time: no flow
        anywhere, ``t`` unchanged. Use it to apply a load step at ``t = 0``."""
        return self._solve(1.0, undrained=True)

    def _solve(self, dt: float, undrained: bool) -> StepResult:
        model, ctl = self.model, self.control
        old = self.state
        x = model.x_of(old)
        nu = model.n_u
        its = solves = 0
        prev = math.inf
        reason = "newton: no convergence"
        ok = False
        res = None
        while True:
            res = model.residual_and_jacobian(x, old, dt, undrained=undrained)
            self.counters.residual_evaluations += 1
            R = res.residual
            if not np.all(np.isfinite(R)):
                reason = "newton: non-finite"
                break
            ru = float(np.max(np.abs(R[:nu]), initial=0.0)) / res.force_scale
            rf = float(np.sum(np.abs(R[nu:])))
            atol = 1e-18 * float(np.sum(model.flow.cell_mass(res.state.flow))) / dt
            u_ok = ru <= ctl.force_rtol
            if u_ok and rf <= ctl.mass_rtol * res.mass_scale + atol:
                ok, reason = True, "converged"
                break
            if (its > 0 and u_ok and rf <= ctl.stagnation_rtol * res.mass_scale + atol
                    and rf > 0.5 * prev):
                ok, reason = True, "converged"
                break
            if its >= ctl.max_newton:
                break
            prev = rf
            try:
                dx = _equilibrated_solve(res.jacobian, -R)
            except RuntimeError:
                reason = "newton: singular"
                break
            solves += 1
            if not np.all(np.isfinite(dx)):
                reason = "newton: non-finite"
                break
            x = x + dx
            its += 1
        self.counters.newton_iterations += its
        self.counters.linear_solves += solves
        t_new = old.t if undrained else old.t + dt
        step_dt = 0.0 if undrained else dt
        if not ok:
            self.counters.failed_steps += 1
            r = StepResult(False, reason, its, solves, step_dt, old.t)
            self.history.append(r)
            return r
        fr = res.flow
        injected = fr.injection_rate * dt
        stored = (float(np.sum(fr.storage_rate_cells)) + fr.storage_rate_well) * dt
        out = fr.boundary_rate * dt
        err = injected - stored - out
        rel = abs(err) / max(res.mass_scale * dt, 1e-300)
        new = res.state
        max_dp = float(np.max(np.abs(np.append(new.p - old.p, new.p_w - old.p_w))))
        ru = float(np.max(np.abs(res.residual[:nu]), initial=0.0)) / res.force_scale
        if rel > ctl.mass_balance_tol:
            self.counters.failed_steps += 1
            r = StepResult(False, "mass balance", its, solves, step_dt, old.t, max_dp,
                           injected, out, stored, err, rel, ru)
            self.history.append(r)
            return r
        self.state = new
        self.counters.steps += 1
        r = StepResult(True, reason, its, solves, step_dt, t_new, max_dp, injected, out,
                       stored, err, rel, ru)
        self.history.append(r)
        return r

    def run_to(self, t_end: float, dt: float, growth: float = 1.0,
               dt_max: float = math.inf, cut: float = 0.25, dt_min: float = 1e-9
               ) -> list[StepResult]:
        """Step to exactly ``t_end`` starting with ``dt``, growing by ``growth`` after each
        accepted step (capped at ``dt_max``), cutting by ``cut`` after a failed one.

        Returns the accepted steps. Raises RuntimeError below ``dt_min``.
        """
        out: list[StepResult] = []
        h = float(dt)
        while self.state.t < t_end * (1.0 - 1e-14):
            h_try = min(h, t_end - self.state.t)
            r = self.step(h_try)
            if r.success:
                out.append(r)
                h = min(h * growth, dt_max)
            else:
                h = h_try * cut
                if h < dt_min:
                    raise RuntimeError(f"coupled step failed at t = {self.state.t:g} s: "
                                       f"{r.reason}")
        return out
