"""sparse_mpm: the 2D Material Point Method in sparse-matrix form, from Python.

The shape functions and their gradients at the particles are sparse matrices, nodes × particles::

    N_Ip  = S_I(x_p)                 (shape function of node I at particle p)
    Gx_Ip = dS_I/dx (x_p),  Gy_Ip = dS_I/dy (x_p)

and the masses are products with them::

    m_L = N m                        (lumped mass, one entry per node)
    M   = N diag(m) N^T              (consistent mass, nodes × nodes; M 1 = m_L)

``Operators.assemble`` computes N, Gx, Gy in Rust and hands them over as
``scipy.sparse.csc_array``; ``Simulation`` runs the library's explicit time loop on a scene
(TOML file, TOML text or dict). Every array crossing the boundary is copied, in both
directions: changing a returned matrix or array does not change the Rust state, and the Rust
side never holds on to a NumPy buffer. Errors of the library are raised as ``MpmError``
(a ``ValueError``) with the library's message, which names the particle, node or key at fault.
"""

from __future__ import annotations

import os
from typing import Any, Dict, Mapping, Optional, Tuple, Union

import numpy as np
import scipy.sparse as sp

from . import _core
from ._core import Grid, MpmError, Particles

__all__ = [
    "Grid",
    "Particles",
    "Operators",
    "Simulation",
    "MpmError",
    "lumped_mass",
    "consistent_mass",
    "REPORT_COLUMNS",
    "momentum",
    "external_force",
    "internal_force",
    "mass_diagnostics",
    "dispersion",
    "critical_time_step",
    "explicit_step",
    "MASS_SCHEMES",
]

#: Mass scheme names accepted where a function takes ``mass=``: ``"lumped"``, ``"consistent"``,
#: ``"blended:γ"`` (``(1 − γ) M_L + γ M``), ``"series:k"`` (first k terms of the series of
#: ``M⁻¹``), ``"cg"`` or ``"cg:tol"`` (conjugate gradient on ``M``, default tolerance 1e-10).
MASS_SCHEMES = ("lumped", "consistent", "blended:γ", "series:k", "cg[:tol]")

#: Columns of the step report (``StepReport::COLUMNS``), in order. Outcomes are coded
#: 0 = solved, 1 = fell back to lumped, 2 = regularized; ``velocity_fallback_node`` is -1 when none.
REPORT_COLUMNS = tuple(_core.report_columns())

_INT_COLUMNS = ("step",)


class Operators:
    """N, Gx, Gy (nodes × particles) at the particles' positions.

    ``N[I, p] = S_I(x_p)``, ``Gx[I, p] = dS_I/dx (x_p)``, ``Gy[I, p] = dS_I/dy (x_p)``. The three
    matrices share one sparsity pattern: column p holds particle p's weights at the nodes of its
    support (4 entries for linear shape functions), row indices ascending in each column.

    ``.N``, ``.Gx``, ``.Gy`` are ``scipy.sparse.csc_array`` built (once, on first access) from
    copies of the Rust compressed-column arrays.
    """

    def __init__(self, core: "_core.Operators"):
        self._core = core
        self._cache: Dict[str, sp.csc_array] = {}

    @classmethod
    def assemble(cls, grid: Grid, particles: Particles, shape: Union[str, Mapping[str, Any]] = "linear") -> "Operators":
        """Assembles N, Gx, Gy for ``particles`` on ``grid``.

        ``shape``: ``"linear"``, ``"quadratic_bspline"``, ``"cubic_bspline"`` or
        ``{"gimp": {"half_width": l}}`` with ``0 < l <= 0.5``. A particle outside the region the
        shape function allows raises ``MpmError`` naming the particle.
        """
        return cls(_core.Operators.assemble(grid, particles, shape))

    @property
    def num_nodes(self) -> int:
        return self._core.num_nodes

    @property
    def num_particles(self) -> int:
        return self._core.num_particles

    @property
    def nnz(self) -> int:
        return self._core.nnz

    @property
    def shape_function(self) -> str:
        return self._core.shape_function

    def col_offsets(self) -> np.ndarray:
        """CSC column offsets (length P + 1, int64), a copy."""
        return self._core.col_offsets()

    def row_indices(self) -> np.ndarray:
        """CSC row indices (node numbers, int64), a copy."""
        return self._core.row_indices()

    def values(self, op: str) -> np.ndarray:
        """CSC values of ``"N"``, ``"Gx"`` or ``"Gy"``, aligned with ``row_indices()``, a copy."""
        return self._core.values(op)

    def matrix(self, op: str) -> sp.csc_array:
        """``op`` (``"N"``, ``"Gx"``, ``"Gy"``) as a ``scipy.sparse.csc_array``, nodes × particles."""
        if op not in self._cache:
            if op not in ("N", "Gx", "Gy"):
                raise MpmError(f'operator {op!r}: expected "N", "Gx" or "Gy"')
            if "pattern" not in self._cache:
                self._cache["pattern"] = (self._core.col_offsets(), self._core.row_indices())
            indptr, indices = self._cache["pattern"]
            self._cache[op] = sp.csc_array(
                (self._core.values(op), indices, indptr), shape=(self.num_nodes, self.num_particles)
            )
        return self._cache[op]

    @property
    def N(self) -> sp.csc_array:
        """``N[I, p] = S_I(x_p)`` (nodes × particles)."""
        return self.matrix("N")

    @property
    def Gx(self) -> sp.csc_array:
        """``Gx[I, p] = dS_I/dx (x_p)`` (nodes × particles)."""
        return self.matrix("Gx")

    @property
    def Gy(self) -> sp.csc_array:
        """``Gy[I, p] = dS_I/dy (x_p)`` (nodes × particles)."""
        return self.matrix("Gy")

    def __repr__(self) -> str:
        return (
            f"Operators(nodes={self.num_nodes}, particles={self.num_particles}, nnz={self.nnz}, "
            f"shape={self.shape_function!r})"
        )


def _core_ops(ops: Union[Operators, "_core.Operators"]) -> "_core.Operators":
    return ops._core if isinstance(ops, Operators) else ops


def lumped_mass(ops: Operators, m) -> np.ndarray:
    """``m_L = N m``: the lumped (nodal) mass, one entry per node (the row sums of ``M``)."""
    return _core.lumped_mass(_core_ops(ops), m)


def consistent_mass(ops: Operators, m) -> sp.csc_array:
    """``M = N diag(m) N^T``: the consistent mass matrix, nodes × nodes, symmetric positive
    semi-definite, a 9-point stencil for linear shape functions; ``M @ ones = m_L``."""
    indptr, indices, data, n = _core.consistent_mass_csc(_core_ops(ops), m)
    return sp.csc_array((data, indices, indptr), shape=(n, n))


def momentum(ops: Operators, m, vx, vy) -> Tuple[np.ndarray, np.ndarray]:
    """Grid momentum ``q = N (m ∘ v)``: ``(qx, qy)`` with ``qx = N (m ∘ vx)``, ``qy = N (m ∘ vy)``,
    one entry per node (``transfer::momentum``)."""
    return _core.momentum(_core_ops(ops), m, vx, vy)


def external_force(ops: Operators, m, bx, by) -> Tuple[np.ndarray, np.ndarray]:
    """External grid force from body forces per unit mass ``b``: ``f_ext = N (m ∘ b)``, as
    ``(fx, fy)`` (``transfer::external_force``)."""
    return _core.external_force(_core_ops(ops), m, bx, by)


def internal_force(ops: Operators, volume, sxx, syy, sxy) -> Tuple[np.ndarray, np.ndarray]:
    """Internal grid force, the divergence of stress (``transfer::internal_force``)::

        f_int,x = −( Gx (V ∘ σxx) + Gy (V ∘ σxy) )
        f_int,y = −( Gx (V ∘ σxy) + Gy (V ∘ σyy) )

    returned as ``(fx, fy)``, one entry per node; ``V``, ``σ`` have one entry per particle."""
    return _core.internal_force(_core_ops(ops), volume, sxx, syy, sxy)


def mass_diagnostics(ops: Operators, m, mass: str = "lumped") -> Dict[str, Any]:
    """``MassDiagnostics::compute`` for the scheme ``mass`` (see ``MASS_SCHEMES``), no constraints,
    as a dict: ``active_nodes``, ``min_nodal_mass``, ``max_nodal_mass``, ``tiny_mass_nodes``
    (``m_L < 1e-3 max m_L``), ``nullity_estimate`` (small Cholesky pivots of the Jacobi-scaled
    ``M_AA``), ``lambda_min_estimate`` (smallest eigenvalue of ``M_L⁻¹ M`` on the active nodes,
    Lanczos) and ``condition_number`` (of the matrix the scheme solves with; inf if singular)."""
    return _core.mass_diagnostics(_core_ops(ops), m, mass)


def dispersion(
    shape: Union[str, Mapping[str, Any]] = "linear",
    mass: str = "lumped",
    acceleration_mass: Optional[str] = None,
    particles_per_cell: int = 2,
    samples: int = 64,
    cells: Optional[int] = None,
) -> Tuple[np.ndarray, np.ndarray]:
    """The discrete dispersion relation of the explicit update (``verification::dispersion``,
    ``mpm dispersion``): ``(theta, c_ratio)``, the wave speed ``c_h/c`` of a Fourier mode against
    ``θ = kh`` on a uniform periodic bar with ``particles_per_cell`` particles per cell, from the
    symbols of ``M_a⁻¹ K M_v⁻¹ M``. ``mass`` is the velocity projection's scheme (see
    ``MASS_SCHEMES``), ``acceleration_mass`` the acceleration solve's (default: ``mass``).
    Sampled at ``θ = π j / samples``, or with ``cells`` at the wavenumbers ``2π j / cells`` of a
    periodic bar of that many cells. NaN where a mass symbol vanishes."""
    return _core.dispersion(shape, mass, acceleration_mass, particles_per_cell, samples, cells)


def critical_time_step(
    ops: Operators, m, volume, youngs_modulus: float, poisson_ratio: float, plane: str = "stress", mass: str = "lumped"
) -> float:
    """``Δt_crit = 2 / ω_max`` with ``ω²_max = λ_max(M⁻¹ K)`` (``stiffness::critical_time_step``):
    ``K`` the stiffness of linear elasticity (``plane`` ``"stress"`` or ``"strain"``) on the
    particle volumes, ``M`` the grid mass of scheme ``mass`` (see ``MASS_SCHEMES``, acceleration
    role, no constraints); ``inf`` when there is no stiffness."""
    return _core.critical_time_step(_core_ops(ops), m, volume, youngs_modulus, poisson_ratio, plane, mass)


def explicit_step(
    grid: Grid,
    particles: Particles,
    youngs_modulus: float,
    poisson_ratio: float,
    dt: float,
    plane: str = "stress",
    shape: Union[str, Mapping[str, Any]] = "linear",
    mass: str = "lumped",
    position_update: str = "grid_velocity",
) -> Dict[str, Any]:
    """One explicit MPM step (``step::explicit_step``, update-stress-last with a FLIP velocity
    update) of ``particles`` (unchanged: the step runs on a copy) with linear elasticity::

        (1) N, Gx, Gy              (2) m_L = N m, active nodes, M if the scheme needs it
        (3) q = N (m ∘ v)          (4) f_ext = N (m ∘ b)
        (5) f_int = −(Gx (V∘σxx) + Gy (V∘σxy), Gx (V∘σxy) + Gy (V∘σyy))
        (6) v̄ = M⁻¹ q              (7) a = M⁻¹ (f_ext + f_int)
        (8) v̄' = v̄ + Δt a (massless nodes in a support: mean particle velocity)
        (9) x ← x + Δt Nᵀ v̄' ("grid_velocity") or x + Δt/2 (v_p + Nᵀ v̄') ("trapezoidal")
        (10) v ← v + Δt Nᵀ a       (11) L = (Gxᵀ v̄', Gyᵀ v̄'), ε̇ = sym L
        (12) σ ← σ + C : (ε̇ Δt)    (13) V ← V det(I + Δt L)

    ``mass`` (see ``MASS_SCHEMES``) is used for both (6) and (7). Returns a dict of every
    intermediate of the ``StepRecord``: ``operators`` (``Operators``), ``lumped_mass``,
    ``active_nodes``; ``momentum_x/_y``, ``external_force_x/_y``, ``internal_force_x/_y``,
    ``acceleration_x/_y``, ``grid_velocity_x/_y``, ``updated_grid_velocity_x/_y`` (nodal);
    ``velocity_gradient_xx/_xy/_yx/_yy``, ``strain_rate_xx/_yy/_xy`` (per particle);
    ``velocity_report``, ``acceleration_report`` (dicts: scheme, outcome, node, iterations,
    relative_residual); and ``particles``, the ``Particles`` after the step."""
    record = _core.explicit_step(
        grid, particles, youngs_modulus, poisson_ratio, dt, plane, shape, mass, position_update
    )
    record["operators"] = Operators(record["operators"])
    return record


class Simulation:
    """The library's explicit MPM time loop on a scene.

    Make one with ``Simulation.from_scene(path)``, ``Simulation.from_toml(text)`` or
    ``Simulation.from_dict(d)`` (the keys of a scene file, docs/simulation.md). The scene's
    limits on memory, steps and output are checked as ``mpm run`` checks them
    (``allow_large=True`` raises them).

    Steps land on multiples of ``land_every`` (the scene's snapshot interval by default) and on
    the end time, exactly as ``mpm run`` lands on its snapshot times, so that ``run(end_time)``
    reproduces ``mpm run``'s ``report.csv`` bit for bit. Set ``land_every = None`` to take
    unconstrained steps.
    """

    def __init__(self, core: "_core.Simulation"):
        self._core = core

    @classmethod
    def from_scene(cls, path: Union[str, os.PathLike], allow_large: bool = False) -> "Simulation":
        """The simulation of a scene file; relative particle files are read from its folder."""
        return cls(_core.Simulation.from_scene(os.fspath(path), allow_large))

    @classmethod
    def from_toml(
        cls, text: str, base_dir: Optional[Union[str, os.PathLike]] = None, allow_large: bool = False
    ) -> "Simulation":
        """The simulation of a scene given as TOML text; particle files relative to ``base_dir``."""
        base = None if base_dir is None else os.fspath(base_dir)
        return cls(_core.Simulation.from_toml(text, base, allow_large))

    @classmethod
    def from_dict(
        cls, scene: Mapping[str, Any], base_dir: Optional[Union[str, os.PathLike]] = None, allow_large: bool = False
    ) -> "Simulation":
        """The simulation of a scene given as a dict with the tables and keys of a scene file."""
        base = None if base_dir is None else os.fspath(base_dir)
        return cls(_core.Simulation.from_dict(dict(scene), base, allow_large))

    @property
    def time(self) -> float:
        """Time reached."""
        return self._core.time

    @property
    def steps(self) -> int:
        """Steps taken."""
        return self._core.steps

    @property
    def end_time(self) -> float:
        """The scene's ``[time] end``."""
        return self._core.end_time

    @property
    def land_every(self) -> Optional[float]:
        """Steps land on multiples of this interval (the scene's snapshot interval), or None."""
        return self._core.land_every

    @land_every.setter
    def land_every(self, every: Optional[float]) -> None:
        self._core.land_every = every

    def stable_time_step(self) -> float:
        """The stable time step for the current state:
        ``dt_stable = 1 / (1/dt_wave + max|v_p| / min(hx, hy))``, ``dt_wave`` from the largest
        frequency of the update with this simulation's masses (Lanczos)."""
        return self._core.stable_time_step()

    def step(self, max_dt: Optional[float] = None) -> Dict[str, float]:
        """Advances one step (no longer than ``max_dt``) and returns its report as a dict with
        the keys of ``REPORT_COLUMNS``."""
        report = self._core.step(max_dt)
        for k in _INT_COLUMNS:
            report[k] = int(report[k])
        return report

    def run(self, until: Optional[float] = None) -> Dict[str, np.ndarray]:
        """Steps until time ``until`` (default: the scene's end time; the last step is shortened
        to land on it) and returns the per-step report as a dict of float64 arrays, one per
        column of ``REPORT_COLUMNS``. A library error raises ``MpmError``; the steps taken before
        it stay taken."""
        if until is None:
            until = self.end_time
        flat, rows = self._core.run_rows(float(until))
        table = flat.reshape(rows, len(REPORT_COLUMNS))
        return {name: np.ascontiguousarray(table[:, k]) for k, name in enumerate(REPORT_COLUMNS)}

    def particles(self) -> Dict[str, np.ndarray]:
        """The particle state as a dict of new arrays: x, y, vx, vy, mass, volume, sxx, syy, sxy,
        bx, by, fxx, fxy, fyx, fyy (float64), body, id (int64)."""
        return self._core.particles()

    def grid(self) -> Grid:
        """The background grid."""
        return self._core.grid()

    def operators(self) -> Operators:
        """N, Gx, Gy at the current particle positions (a copy)."""
        return Operators(self._core.operators())

    def lumped_mass(self) -> np.ndarray:
        """The lumped mass ``m_L = N m`` of the last step (a copy)."""
        return self._core.lumped_mass()

    def scene_toml(self) -> str:
        """The scene as TOML text."""
        return self._core.scene_toml()

    def __repr__(self) -> str:
        return f"Simulation(time={self.time!r}, steps={self.steps})"


def scene_matrices(path: Union[str, os.PathLike]) -> Dict[str, Any]:
    """N, Gx, Gy, M and m_L of a scene file's initial configuration, as ``mpm matrices`` writes
    them: a dict with ``grid``, ``operators``, ``N``, ``Gx``, ``Gy`` (csc_array), ``M`` (csc_array)
    and ``mL`` (array)."""
    grid, particles, core = _core.scene_operators(os.fspath(path))
    ops = Operators(core)
    m = particles.mass
    return {
        "grid": grid,
        "particles": particles,
        "operators": ops,
        "N": ops.N,
        "Gx": ops.Gx,
        "Gy": ops.Gy,
        "M": consistent_mass(ops, m),
        "mL": lumped_mass(ops, m),
    }


__all__.append("scene_matrices")
