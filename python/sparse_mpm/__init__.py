"""sparse_mpm: the 2D Material Point Method in sparse-matrix form, from Python.

The shape functions and their gradients at the particles are sparse matrices, nodes × particles::

    N_Ip  = S_I(x_p)                 (shape function of node I at particle p)
    Gx_Ip = dS_I/dx (x_p),  Gy_Ip = dS_I/dy (x_p)

and the masses are products with them::

    m_L = N m                        (lumped mass, one entry per node)
    M   = N diag(m) N^T              (consistent mass, nodes × nodes; M 1 = m_L)

``Operators.assemble`` computes N, Gx, Gy in Rust and hands them over as
``scipy.sparse.csc_array``; ``Simulation`` runs the library's explicit time loop on a scene
(TOML file, TOML text or dict), on NumPy arrays (``Simulation.from_arrays``) or from a
checkpoint. Arrays are copied into Rust; the Rust side never holds on to a NumPy buffer.
What comes back is either a new array (functions such as ``lumped_mass``, ``to_dict()``) or a
cached **read-only** array (``Particles`` attributes, ``Operators.N``/``Gx``/``Gy`` and their
``data``/``indices``/``indptr``, ``Simulation.particles()``): a cached array cannot be written
into, so it cannot drift from the Rust state it was copied from; ``.copy()`` gives a writeable
one. Errors of the library are raised as ``MpmError`` (a ``ValueError``) with the library's
message, which names the particle, node or key at fault.

Inputs are checked before they are used. An array argument must hold real numbers: float
arrays are taken as they are, integer arrays (and lists of ints) are converted to float64, and
a complex array (even with a zero imaginary part), a boolean, string or object array is a
``TypeError`` naming the argument. It must be 1-D and as long as there are particles (checked
before it is copied; ``MpmError`` naming both lengths), and every value finite, masses and
volumes positive (``MpmError`` naming the argument, the particle and the value). A scene or
shape given as a dict is read at most 64 levels deep and with at most 2·10⁶ values and 16 MiB
of strings (a scene file's size); a dict or list that contains itself, and a boundary's
``nodes`` list longer than the grid's node count, are refused with an ``MpmError`` naming the
key path, before anything beyond the bound is read. ``Simulation.run`` stops at Ctrl-C
(``KeyboardInterrupt``) between two steps.
"""

import os as _os
import typing as _t

import numpy as _np
import numpy.typing as _npt
import scipy.sparse as _sp

from . import _core
from ._core import Grid, MpmError, Particles

# Pickled by reference to where users import it, so that the error crosses process pools
# (concurrent.futures, multiprocessing) as itself.
MpmError.__module__ = "sparse_mpm"

#: The package version (the extension crate's version, ``python/Cargo.toml``).
__version__: str = _core.__version__

#: Names of the shape functions (``shape=``); GIMP is given as ``{"gimp": {"half_width": l}}``.
ShapeName = _t.Literal["linear", "quadratic_bspline", "cubic_bspline"]
#: A shape function: a name, or ``{"gimp": {"half_width": l}}`` with ``0 < l <= 0.5``.
Shape = _t.Union[ShapeName, _t.Mapping[str, _t.Mapping[str, float]]]
#: Mass schemes without a parameter; ``"blended:γ"``, ``"series:k"`` and ``"cg:tol"`` are
#: strings of the same vocabulary (``MASS_SCHEMES``).
MassName = _t.Literal["lumped", "consistent", "cg"]
#: The three operators by name.
OperatorName = _t.Literal["N", "Gx", "Gy"]
#: Plane condition of linear elasticity.
Plane = _t.Literal["stress", "strain"]
#: Position rules of ``explicit_step``.
PositionUpdate = _t.Literal["grid_velocity", "trapezoidal"]
#: Particle fields ``Simulation.set_particle_state`` accepts.
SettableField = _t.Literal["vx", "vy", "sxx", "syy", "sxy", "bx", "by"]
_PathLike = _t.Union[str, "_os.PathLike[str]"]

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
    "scene_matrices",
    "__version__",
]

#: Mass scheme names accepted where a function takes ``mass=``: ``"lumped"``, ``"consistent"``,
#: ``"blended:γ"`` (``(1 − γ) M_L + γ M``), ``"series:k"`` (first k terms of the series of
#: ``M⁻¹``), ``"cg"`` or ``"cg:tol"`` (conjugate gradient on ``M``, default tolerance 1e-10).
MASS_SCHEMES = ("lumped", "consistent", "blended:γ", "series:k", "cg[:tol]")

#: Columns of the step report (``StepReport::COLUMNS``), in order. Outcomes are coded
#: 0 = solved, 1 = fell back to lumped, 2 = regularized; ``velocity_fallback_node`` is -1 when none.
REPORT_COLUMNS = tuple(_core.report_columns())

_INT_COLUMNS = ("step",)


def _freeze(m: "_sp.csc_array") -> "_sp.csc_array":
    """``m`` with its ``data``, ``indices`` and ``indptr`` made read-only (and its sorted,
    canonical form recorded, so that SciPy never sorts it in place)."""
    m.has_sorted_indices = True
    m.has_canonical_format = True
    for a in (m.data, m.indices, m.indptr):
        a.flags.writeable = False
    return m


class Operators:
    """N, Gx, Gy (nodes × particles) at the particles' positions.

    ``N[I, p] = S_I(x_p)``, ``Gx[I, p] = dS_I/dx (x_p)``, ``Gy[I, p] = dS_I/dy (x_p)``. The three
    matrices share one sparsity pattern: column p holds particle p's weights at the nodes of its
    support (4 entries for linear shape functions), row indices ascending in each column.

    ``.N``, ``.Gx``, ``.Gy`` are ``scipy.sparse.csc_array`` built once, on first access, from
    copies of the Rust compressed-column arrays, and cached **read-only**: their ``data``,
    ``indices`` and ``indptr`` are not writeable, so the cached matrix always equals the Rust
    operators (``ops.N.copy()`` gives a writeable matrix). ``col_offsets()``, ``row_indices()``
    and ``values()`` return new, writeable copies.
    """

    def __init__(self, core: "_core.Operators"):
        self._core = core
        self._cache: _t.Dict[str, _t.Any] = {}

    @classmethod
    def assemble(cls, grid: Grid, particles: Particles, shape: Shape = "linear") -> "Operators":
        """Assembles N, Gx, Gy for ``particles`` on ``grid``.

        ``shape``: ``"linear"``, ``"quadratic_bspline"``, ``"cubic_bspline"`` or
        ``{"gimp": {"half_width": l}}`` with ``0 < l <= 0.5`` (a dict is read as ``from_dict``
        reads a scene: bounded, no self-reference). A particle outside the region the shape
        function allows raises ``MpmError`` naming the particle.
        """
        return cls(_core.Operators.assemble(grid, particles, shape))

    @property
    def num_nodes(self) -> int:
        """Number of grid nodes (rows of N, Gx, Gy)."""
        return self._core.num_nodes

    @property
    def num_particles(self) -> int:
        """Number of particles (columns of N, Gx, Gy)."""
        return self._core.num_particles

    @property
    def nnz(self) -> int:
        """Stored entries of each operator (the shared pattern's size)."""
        return self._core.nnz

    @property
    def shape_function(self) -> str:
        """Name of the shape function the operators were assembled with."""
        return self._core.shape_function

    def col_offsets(self) -> "_np.ndarray":
        """CSC column offsets (length P + 1, int64), a new writeable copy."""
        return self._core.col_offsets()

    def row_indices(self) -> "_np.ndarray":
        """CSC row indices (node numbers, int64), a new writeable copy."""
        return self._core.row_indices()

    def values(self, op: OperatorName) -> "_np.ndarray":
        """CSC values of ``"N"``, ``"Gx"`` or ``"Gy"``, aligned with ``row_indices()``, a new
        writeable copy."""
        return self._core.values(op)

    def matrix(self, op: OperatorName) -> "_sp.csc_array":
        """``op`` (``"N"``, ``"Gx"``, ``"Gy"``) as a read-only ``scipy.sparse.csc_array``, nodes ×
        particles, built on first use and cached."""
        if op not in self._cache:
            if op not in ("N", "Gx", "Gy"):
                raise MpmError(f'operator {op!r}: expected "N", "Gx" or "Gy"')
            if "pattern" not in self._cache:
                self._cache["pattern"] = (self._core.col_offsets(), self._core.row_indices())
            indptr, indices = self._cache["pattern"]
            self._cache[op] = _freeze(
                _sp.csc_array(
                    (self._core.values(op), indices, indptr), shape=(self.num_nodes, self.num_particles)
                )
            )
        return self._cache[op]

    @property
    def N(self) -> "_sp.csc_array":
        """``N[I, p] = S_I(x_p)`` (nodes × particles), read-only, cached."""
        return self.matrix("N")

    @property
    def Gx(self) -> "_sp.csc_array":
        """``Gx[I, p] = dS_I/dx (x_p)`` (nodes × particles), read-only, cached."""
        return self.matrix("Gx")

    @property
    def Gy(self) -> "_sp.csc_array":
        """``Gy[I, p] = dS_I/dy (x_p)`` (nodes × particles), read-only, cached."""
        return self.matrix("Gy")

    def __repr__(self) -> str:
        return (
            f"Operators(nodes={self.num_nodes}, particles={self.num_particles}, nnz={self.nnz}, "
            f"shape={self.shape_function!r})"
        )


def _core_ops(ops: _t.Union[Operators, "_core.Operators"]) -> "_core.Operators":
    return ops._core if isinstance(ops, Operators) else ops


#: A 1-D array of real numbers (a list, a NumPy array …): float, or integers taken as floats;
#: complex, boolean, string and object arrays are refused (``TypeError`` naming the argument).
ArrayLike = _npt.ArrayLike


def lumped_mass(ops: Operators, m: ArrayLike) -> "_np.ndarray":
    """``m_L = N m``: the lumped (nodal) mass, one entry per node (the row sums of ``M``), a new
    array. ``m``: one finite positive mass per particle (integers are taken as floats; complex
    is a ``TypeError``, NaN, inf, zero or a negative mass an ``MpmError`` naming the particle)."""
    return _core.lumped_mass(_core_ops(ops), m)


def consistent_mass(ops: Operators, m: ArrayLike) -> "_sp.csc_array":
    """``M = N diag(m) N^T``: the consistent mass matrix, nodes × nodes, symmetric positive
    semi-definite, a 9-point stencil for linear shape functions; ``M @ ones = m_L``. A new
    (writeable) matrix. ``m`` is checked as in ``lumped_mass``."""
    indptr, indices, data, n = _core.consistent_mass_csc(_core_ops(ops), m)
    return _sp.csc_array((data, indices, indptr), shape=(n, n))


def momentum(ops: Operators, m: ArrayLike, vx: ArrayLike, vy: ArrayLike) -> _t.Tuple["_np.ndarray", "_np.ndarray"]:
    """Grid momentum ``q = N (m ∘ v)``: ``(qx, qy)`` with ``qx = N (m ∘ vx)``, ``qy = N (m ∘ vy)``,
    one entry per node (``transfer::momentum``). One value per particle each, finite (integers
    taken as floats, complex refused), ``m`` positive."""
    return _core.momentum(_core_ops(ops), m, vx, vy)


def external_force(
    ops: Operators, m: ArrayLike, bx: ArrayLike, by: ArrayLike
) -> _t.Tuple["_np.ndarray", "_np.ndarray"]:
    """External grid force from body forces per unit mass ``b``: ``f_ext = N (m ∘ b)``, as
    ``(fx, fy)`` (``transfer::external_force``). One value per particle each, finite (integers
    taken as floats, complex refused), ``m`` positive."""
    return _core.external_force(_core_ops(ops), m, bx, by)


def internal_force(
    ops: Operators, volume: ArrayLike, sxx: ArrayLike, syy: ArrayLike, sxy: ArrayLike
) -> _t.Tuple["_np.ndarray", "_np.ndarray"]:
    """Internal grid force, the divergence of stress (``transfer::internal_force``)::

        f_int,x = −( Gx (V ∘ σxx) + Gy (V ∘ σxy) )
        f_int,y = −( Gx (V ∘ σxy) + Gy (V ∘ σyy) )

    returned as ``(fx, fy)``, one entry per node; ``V``, ``σ`` have one entry per particle,
    finite (integers taken as floats, complex refused), ``V`` positive: a NaN, infinite or
    non-positive value is an ``MpmError`` naming the argument and the particle."""
    return _core.internal_force(_core_ops(ops), volume, sxx, syy, sxy)


def mass_diagnostics(ops: Operators, m: ArrayLike, mass: _t.Union[MassName, str] = "lumped") -> _t.Dict[str, _t.Any]:
    """``MassDiagnostics::compute`` for the scheme ``mass`` (see ``MASS_SCHEMES``), no constraints,
    as a dict: ``active_nodes``, ``min_nodal_mass``, ``max_nodal_mass``, ``tiny_mass_nodes``
    (``m_L < 1e-3 max m_L``), ``nullity_estimate`` (small Cholesky pivots of the Jacobi-scaled
    ``M_AA``), ``lambda_min_estimate`` (smallest eigenvalue of ``M_L⁻¹ M`` on the active nodes,
    Lanczos) and ``condition_number`` (of the matrix the scheme solves with; inf if singular).
    ``m`` is checked as in ``lumped_mass``."""
    return _core.mass_diagnostics(_core_ops(ops), m, mass)


def dispersion(
    shape: Shape = "linear",
    mass: _t.Union[MassName, str] = "lumped",
    acceleration_mass: _t.Optional[_t.Union[MassName, str]] = None,
    particles_per_cell: int = 2,
    samples: int = 64,
    cells: _t.Optional[int] = None,
) -> _t.Tuple["_np.ndarray", "_np.ndarray"]:
    """The discrete dispersion relation of the explicit update (``verification::dispersion``,
    ``mpm dispersion``): ``(theta, c_ratio)``, the wave speed ``c_h/c`` of a Fourier mode against
    ``θ = kh`` on a uniform periodic bar with ``particles_per_cell`` particles per cell, from the
    symbols of ``M_a⁻¹ K M_v⁻¹ M``. ``mass`` is the velocity projection's scheme (see
    ``MASS_SCHEMES``), ``acceleration_mass`` the acceleration solve's (default: ``mass``).
    Sampled at ``θ = π j / samples``, or with ``cells`` at the wavenumbers ``2π j / cells`` of a
    periodic bar of that many cells. NaN where a mass symbol vanishes."""
    return _core.dispersion(shape, mass, acceleration_mass, particles_per_cell, samples, cells)


def critical_time_step(
    ops: Operators,
    m: ArrayLike,
    volume: ArrayLike,
    youngs_modulus: float,
    poisson_ratio: float,
    plane: Plane = "stress",
    mass: _t.Union[MassName, str] = "lumped",
) -> float:
    """``Δt_crit = 2 / ω_max`` with ``ω²_max = λ_max(M⁻¹ K)`` (``stiffness::critical_time_step``):
    ``K`` the stiffness of linear elasticity (``plane`` ``"stress"`` or ``"strain"``) on the
    particle volumes, ``M`` the grid mass of scheme ``mass`` (see ``MASS_SCHEMES``, acceleration
    role, no constraints); ``inf`` when there is no stiffness. ``m`` and ``volume``: one finite
    positive value per particle (integers taken as floats, complex refused)."""
    return _core.critical_time_step(_core_ops(ops), m, volume, youngs_modulus, poisson_ratio, plane, mass)


def explicit_step(
    grid: Grid,
    particles: Particles,
    youngs_modulus: float,
    poisson_ratio: float,
    dt: float,
    plane: Plane = "stress",
    shape: Shape = "linear",
    mass: _t.Union[MassName, str] = "lumped",
    position_update: PositionUpdate = "grid_velocity",
) -> _t.Dict[str, _t.Any]:
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


def _as_particles(particles: _t.Union[Particles, _t.Mapping[str, ArrayLike]]) -> Particles:
    """``particles`` as ``Particles``: given, or made from a mapping of arrays (the keyword
    arguments of ``Particles``: x, y, mass, volume, vx, vy, sxx, syy, sxy, bx, by, body)."""
    if isinstance(particles, Particles):
        return particles
    if not isinstance(particles, _t.Mapping):
        raise MpmError(
            f"particles: expected Particles or a dict of arrays, found {type(particles).__name__}"
        )
    allowed = ("x", "y", "mass", "volume", "vx", "vy", "sxx", "syy", "sxy", "bx", "by", "body")
    for key in particles:
        if key not in allowed:
            raise MpmError(f"particles[{key!r}]: not a particle field (fields: {', '.join(allowed)})")
    for key in ("x", "y", "mass", "volume"):
        if key not in particles:
            raise MpmError(f"particles[{key!r}]: missing (x, y, mass and volume are required)")
    return Particles(**particles)


class Simulation:
    """The library's explicit MPM time loop.

    Make one from a scene with ``Simulation.from_scene(path)``, ``Simulation.from_toml(text)`` or
    ``Simulation.from_dict(d)`` (the keys of a scene file, docs/simulation.md; the scene's
    limits on memory, steps and output are checked as ``mpm run`` checks them,
    ``allow_large=True`` raises them); from NumPy arrays with ``Simulation.from_arrays``; or
    from a checkpoint file with ``Simulation.from_checkpoint``.

    Steps land on multiples of ``land_every`` (the scene's snapshot interval by default) and on
    the end time, exactly as ``mpm run`` lands on its snapshot times, so that ``run(end_time)``
    reproduces ``mpm run``'s ``report.csv`` bit for bit. Set ``land_every = None`` to take
    unconstrained steps.
    """

    def __init__(self, core: "_core.Simulation"):
        self._core = core
        self._particles: _t.Optional[_t.Tuple[int, _t.Dict[str, _np.ndarray]]] = None

    @classmethod
    def from_scene(
        cls, path: _PathLike, allow_large: bool = False, overrides: _t.Optional[_t.Sequence[str]] = None
    ) -> "Simulation":
        """The simulation of a scene file; relative particle files are read from its folder.

        ``overrides``: ``"KEY=VALUE"`` changes of the file's keys, as ``mpm run --set`` takes
        them (``["time.end=0.5", "bodies[0].material.youngs_modulus=2e7"]``), checked as an
        edit of the file would be."""
        sets = None if overrides is None else [str(o) for o in overrides]
        return cls(_core.Simulation.from_scene(_os.fspath(path), allow_large, sets))

    @classmethod
    def from_toml(
        cls,
        text: str,
        base_dir: _t.Optional[_PathLike] = None,
        allow_large: bool = False,
        overrides: _t.Optional[_t.Sequence[str]] = None,
    ) -> "Simulation":
        """The simulation of a scene given as TOML text; particle files relative to ``base_dir``;
        ``overrides`` as for ``from_scene``."""
        base = None if base_dir is None else _os.fspath(base_dir)
        sets = None if overrides is None else [str(o) for o in overrides]
        return cls(_core.Simulation.from_toml(text, base, allow_large, sets))

    @classmethod
    def from_dict(
        cls, scene: _t.Mapping[str, _t.Any], base_dir: _t.Optional[_PathLike] = None, allow_large: bool = False
    ) -> "Simulation":
        """The simulation of a scene given as a dict with the tables and keys of a scene file
        (NumPy scalars and arrays are taken as numbers and lists). An error names the key path
        at fault, e.g. ``bodies[0].material.youngs_modulus``. The dict is read at most 64 levels
        deep, with at most 2·10⁶ values and 16 MiB of strings (a scene file's size); a dict or
        list that contains itself, and a boundary's ``nodes`` list longer than the grid's node
        count, are refused (``MpmError`` naming the key path) before anything beyond the bound
        is read."""
        base = None if base_dir is None else _os.fspath(base_dir)
        return cls(_core.Simulation.from_dict(dict(scene), base, allow_large))

    @classmethod
    def from_arrays(
        cls,
        grid: Grid,
        particles: _t.Union[Particles, _t.Mapping[str, ArrayLike]],
        bodies: _t.Sequence[_t.Mapping[str, _t.Any]],
        options: _t.Optional[_t.Mapping[str, _t.Any]] = None,
    ) -> "Simulation":
        """The simulation of particles given as arrays, with no file on disk.

        ``grid``: a ``Grid``. ``particles``: a ``Particles`` or a dict of arrays with its
        keyword names (``x``, ``y``, ``mass``, ``volume`` required; ``vx``, ``vy``, ``sxx``,
        ``syy``, ``sxy``, ``bx``, ``by`` zero by default; ``body``, the index into ``bodies`` of
        each particle, 0 by default). ``bodies``: a list of dicts ``{"name": …, "material":
        {…}}`` as in a scene's ``[[bodies]]`` (the other body keys of a scene are particle
        arrays here). ``options``: a dict with the scene's other tables, ``time`` (required,
        with ``end``), ``schemes``, ``loads``, ``boundaries``, ``output``, ``execution``.

        The result is the simulation a scene whose bodies read these particles from a file
        builds, bit for bit. Errors name the key path (``bodies[0].material.poisson_ratio``,
        ``options.time``) or the field and particle. No resource limits are applied (the
        arrays are already in memory; nothing is written); ``scene_toml()`` is not available.
        ``bodies`` and ``options`` are read as ``from_dict`` reads a scene (depth, size,
        self-reference, node lists within ``grid``).
        """
        if options is not None and not isinstance(options, _t.Mapping):
            raise MpmError(f"options: expected a dict of scene tables, found {type(options).__name__}")
        if isinstance(bodies, _t.Mapping) or not isinstance(bodies, _t.Sequence):
            raise MpmError(f"bodies: expected a list of dicts, found {type(bodies).__name__}")
        return cls(
            _core.Simulation.from_arrays(
                grid, _as_particles(particles), list(bodies), None if options is None else dict(options)
            )
        )

    @classmethod
    def from_checkpoint(
        cls, path: _PathLike, end_time: _t.Optional[float] = None, land_every: _t.Optional[float] = None
    ) -> "Simulation":
        """The simulation saved by ``write_checkpoint`` (or ``mpm run --checkpoint``); its steps
        continue the saved run bit for bit when they land on the same times: pass the saved
        simulation's ``land_every``. ``end_time`` is the default end of ``run()``."""
        return cls(_core.Simulation.from_checkpoint(_os.fspath(path), end_time, land_every))

    @property
    def time(self) -> float:
        """Time reached."""
        return self._core.time

    @property
    def steps(self) -> int:
        """Steps taken."""
        return self._core.steps

    @property
    def end_time(self) -> _t.Optional[float]:
        """The default end of ``run()``: the scene's ``[time] end`` (``options["time"]["end"]``
        for ``from_arrays``; as given, or None, for ``from_checkpoint``)."""
        return self._core.end_time

    @property
    def land_every(self) -> _t.Optional[float]:
        """Steps land on multiples of this interval (the scene's snapshot interval), or None."""
        return self._core.land_every

    @land_every.setter
    def land_every(self, every: _t.Optional[float]) -> None:
        self._core.land_every = every

    def stable_time_step(self) -> float:
        """The stable time step for the current state:
        ``dt_stable = 1 / (1/dt_wave + max|v_p| / min(hx, hy))``, ``dt_wave`` from the largest
        frequency of the update with this simulation's masses (Lanczos)."""
        return self._core.stable_time_step()

    def step(self, max_dt: _t.Optional[float] = None) -> _t.Dict[str, float]:
        """Advances one step (no longer than ``max_dt``) and returns its report as a dict with
        the keys of ``REPORT_COLUMNS``."""
        report = self._core.step(max_dt)
        for k in _INT_COLUMNS:
            report[k] = int(report[k])
        return report

    def run(self, until: _t.Optional[float] = None) -> _t.Dict[str, "_np.ndarray"]:
        """Steps until time ``until`` (default: ``end_time``; the last step is shortened to land
        on it) and returns the per-step report as a dict of float64 arrays, one per column of
        ``REPORT_COLUMNS``. A library error raises ``MpmError``; the steps taken before it stay
        taken. Ctrl-C (SIGINT) stops the run between two whole steps with ``KeyboardInterrupt``
        (within about 50 ms or one step): the steps taken stay taken, the simulation can go on,
        and their reports are not returned."""
        if until is None:
            until = self.end_time
            if until is None:
                raise MpmError("until: this simulation has no end time (read from a checkpoint without one); give until")
        flat, rows = self._core.run_rows(float(until))
        table = flat.reshape(rows, len(REPORT_COLUMNS))
        return {name: _np.ascontiguousarray(table[:, k]) for k, name in enumerate(REPORT_COLUMNS)}

    def particles(self) -> _t.Dict[str, "_np.ndarray"]:
        """The particle state as a dict of **read-only** arrays: x, y, vx, vy, mass, volume, sxx,
        syy, sxy, bx, by, fxx, fxy, fyx, fyy (float64), body, id (int64), in the current
        particle order (the library re-sorts particles by cell; ``id`` is the permanent number).
        The arrays are copied once per state (after a step or ``set_particle_state``) and
        handed out again until the state changes; ``.copy()`` gives writeable ones."""
        version = self._core.version
        if self._particles is None or self._particles[0] != version:
            arrays = self._core.particles()
            for a in arrays.values():
                a.flags.writeable = False
            self._particles = (version, arrays)
        return dict(self._particles[1])

    def set_particle_state(self, **fields: ArrayLike) -> None:
        """Sets particle fields, each an array in the order of ``particles()``: ``vx``, ``vy``
        (velocity), ``sxx``, ``syy``, ``sxy`` (stress), ``bx``, ``by`` (body force per unit
        mass, besides gravity). Each array needs one finite value per particle (integers are
        taken as floats; a complex array is a ``TypeError``); an error names the field and the
        particle. Before the first step the simulation is rebuilt with them (as
        if built from them: its first stable step sees them); between steps they are set in place
        (``Simulation::set_velocity``, ``set_stress``, ``set_body_force``), and the next step's CFL
        term sees the new speeds."""
        self._core.set_particle_state(fields)

    def grid(self) -> Grid:
        """The background grid."""
        return self._core.grid()

    def operators(self) -> Operators:
        """N, Gx, Gy at the current particle positions (a copy)."""
        return Operators(self._core.operators())

    def lumped_mass(self) -> "_np.ndarray":
        """The lumped mass ``m_L = N m`` of the last step, one entry per node (a new array)."""
        return self._core.lumped_mass()

    def grid_velocity(self) -> _t.Tuple["_np.ndarray", "_np.ndarray"]:
        """The updated grid velocity ``w = v + Δt a`` of the last step (after the boundary
        conditions), ``(vx, vy)`` per node (new arrays)."""
        return self._core.grid_velocity()

    def active_nodes(self) -> "_np.ndarray":
        """The active nodes of the last step (nodes with mass), ascending (a new int64 array)."""
        return self._core.active_nodes()

    def grid_fields(self) -> _t.Dict[str, "_np.ndarray"]:
        """The grid fields of the last step as new arrays: ``mass`` (``m_L``), ``velocity_x``,
        ``velocity_y`` (the updated grid velocity ``w``), ``momentum_x``, ``momentum_y``
        (``m_L ∘ w``, the momentum the lumped mass gives ``w``), and ``active_nodes``."""
        m = self.lumped_mass()
        wx, wy = self.grid_velocity()
        return {
            "mass": m,
            "velocity_x": wx,
            "velocity_y": wy,
            "momentum_x": m * wx,
            "momentum_y": m * wy,
            "active_nodes": self.active_nodes(),
        }

    def write_snapshot(self, path: _PathLike) -> None:
        """Writes the particles to a VTK ``.vtp`` file as ``mpm run`` writes its snapshots (id,
        body, mass, volume, velocity, stress, pressure, deformation gradient, J)."""
        self._core.write_snapshot(_os.fspath(path))

    def write_checkpoint(self, path: _PathLike) -> None:
        """Writes the whole simulation to a checkpoint file (written atomically):
        ``Simulation.from_checkpoint(path, land_every=sim.land_every)`` continues it bit for bit."""
        self._core.write_checkpoint(_os.fspath(path))

    def scene_toml(self) -> str:
        """The scene as TOML text (simulations from a scene file, TOML text or dict)."""
        return self._core.scene_toml()

    def __repr__(self) -> str:
        return f"Simulation(time={self.time!r}, steps={self.steps})"


def scene_matrices(path: _PathLike) -> _t.Dict[str, _t.Any]:
    """N, Gx, Gy, M and m_L of a scene file's initial configuration, as ``mpm matrices`` writes
    them: a dict with ``grid``, ``particles``, ``operators``, ``N``, ``Gx``, ``Gy`` (read-only
    csc_array), ``M`` (csc_array) and ``mL`` (array)."""
    grid, particles, core = _core.scene_operators(_os.fspath(path))
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
