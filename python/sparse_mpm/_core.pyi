"""Type stubs of the Rust extension ``sparse_mpm._core``. Every array argument is copied into
Rust. Arrays returned are new NumPy arrays, except the attributes of ``Particles``: read-only
arrays made on first access and returned again after (no memory is shared with Rust).

Array arguments are checked before they are copied: real numbers only (float; integer arrays
are converted to float64; complex, boolean, string and object arrays raise ``TypeError``
naming the argument), 1-D (``MpmError`` otherwise), one entry per particle (``MpmError``
naming both lengths). Per-particle values must be finite, masses and volumes positive
(``MpmError`` naming the argument, the particle and the value). Dicts (scenes, options,
bodies, shapes) are read at most 64 levels deep, with at most 2·10⁶ values and 16 MiB of
strings; one that contains itself, or a boundary's ``nodes`` list longer than the grid's node
count, raises ``MpmError`` naming the key path."""

from os import PathLike
from typing import Any, Dict, List, Literal, Mapping, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike
F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
ShapeName = Literal["linear", "quadratic_bspline", "cubic_bspline"]
#: A shape name or ``{"gimp": {"half_width": l}}``; None is linear.
ShapeSpec = Union[ShapeName, Mapping[str, Mapping[str, float]], None]
#: ``"lumped"``, ``"consistent"``, ``"cg"`` or a parametrised ``"blended:γ"``, ``"series:k"``, ``"cg:tol"``.
MassScheme = Union[Literal["lumped", "consistent", "cg"], str]
OperatorName = Literal["N", "Gx", "Gy"]
Plane = Literal["stress", "strain"]
NodeOrder = Literal["x_fastest", "y_fastest"]
PositionUpdate = Literal["grid_velocity", "trapezoidal"]
Path = Union[str, PathLike[str]]

class MpmError(ValueError):
    """An error of the library, with its message (naming the particle, node or key at fault)."""

class Grid:
    """Uniform grid: ``origin``, ``cell_size = (hx, hy)``, ``cells = (cx, cy)``; ``(cx+1)(cy+1)``
    nodes numbered x-fastest (``id = i + j (cx+1)``) or y-fastest (``id = j + i (cy+1)``)."""

    def __init__(
        self,
        origin: Tuple[float, float],
        cell_size: Tuple[float, float],
        cells: Tuple[int, int],
        node_order: NodeOrder = "x_fastest",
    ) -> None: ...
    @staticmethod
    def from_node_coordinates(x_g: ArrayLike, y_g: ArrayLike) -> Grid:
        """The grid whose node k is at ``(x_g[k], y_g[k])``, node order recovered from the lists
        (real, finite, at most 2²⁸ entries, checked before they are copied)."""
    @property
    def origin(self) -> Tuple[float, float]: ...
    @property
    def cell_size(self) -> Tuple[float, float]: ...
    @property
    def cells(self) -> Tuple[int, int]: ...
    @property
    def num_nodes(self) -> int: ...
    @property
    def node_order(self) -> NodeOrder: ...
    def node_x(self) -> F64: ...
    def node_y(self) -> F64: ...

class Particles:
    """Particle positions ``x, y``, masses ``m_p > 0``, volumes ``V_p > 0``, velocities, stresses,
    body forces (default 0) and bodies (default 0). Immutable; every attribute is a read-only
    array made on first access and returned again after.

    Every array as long as ``x`` (checked before it is copied), real (integers taken as floats,
    complex a ``TypeError``), finite, masses and volumes positive (``MpmError`` naming the
    particle, field and value); ``body`` whole numbers from 0."""

    def __init__(
        self,
        x: ArrayLike,
        y: ArrayLike,
        mass: ArrayLike,
        volume: ArrayLike,
        vx: Optional[ArrayLike] = None,
        vy: Optional[ArrayLike] = None,
        *,
        sxx: Optional[ArrayLike] = None,
        syy: Optional[ArrayLike] = None,
        sxy: Optional[ArrayLike] = None,
        bx: Optional[ArrayLike] = None,
        by: Optional[ArrayLike] = None,
        body: Optional[ArrayLike] = None,
    ) -> None: ...
    def __len__(self) -> int: ...
    def to_dict(self) -> Dict[str, np.ndarray]:
        """Every field as a new writeable array (float64; ``body``, ``id`` int64)."""
    @property
    def x(self) -> F64:
        """x coordinates."""
    @property
    def y(self) -> F64:
        """y coordinates."""
    @property
    def mass(self) -> F64:
        """Masses m_p > 0."""
    @property
    def volume(self) -> F64:
        """Volumes V_p > 0."""
    @property
    def vx(self) -> F64:
        """x velocities."""
    @property
    def vy(self) -> F64:
        """y velocities."""
    @property
    def sxx(self) -> F64:
        """Cauchy stress σxx."""
    @property
    def syy(self) -> F64:
        """Cauchy stress σyy."""
    @property
    def sxy(self) -> F64:
        """Cauchy stress σxy."""
    @property
    def bx(self) -> F64:
        """Body force per unit mass, x."""
    @property
    def by(self) -> F64:
        """Body force per unit mass, y."""
    @property
    def body(self) -> I64:
        """Index of each particle's body."""

class Operators:
    """``N_Ip = S_I(x_p)``, ``Gx_Ip = dS_I/dx (x_p)``, ``Gy_Ip = dS_I/dy (x_p)`` in CSC form."""

    @staticmethod
    def assemble(grid: Grid, particles: Particles, shape: ShapeSpec = None) -> Operators: ...
    @property
    def num_nodes(self) -> int: ...
    @property
    def num_particles(self) -> int: ...
    @property
    def nnz(self) -> int: ...
    @property
    def shape_function(self) -> str: ...
    def col_offsets(self) -> I64: ...
    def row_indices(self) -> I64: ...
    def values(self, op: OperatorName) -> F64: ...

def lumped_mass(ops: Operators, m: ArrayLike) -> F64:
    """``m_L = N m``; ``m`` one finite positive mass per particle."""

def consistent_mass_csc(
    ops: Operators, m: ArrayLike
) -> Tuple[I64, I64, F64, int]:
    """``M = N diag(m) N^T`` as ``(indptr, indices, data, num_nodes)``; ``m`` one finite positive
    mass per particle."""

Pair = Tuple[F64, F64]

def momentum(ops: Operators, m: ArrayLike, vx: ArrayLike, vy: ArrayLike) -> Pair:
    """``q = N (m ∘ v)`` as ``(qx, qy)``; finite values, ``m`` positive."""

def external_force(ops: Operators, m: ArrayLike, bx: ArrayLike, by: ArrayLike) -> Pair:
    """``f_ext = N (m ∘ b)`` as ``(fx, fy)``; finite values, ``m`` positive."""

def internal_force(ops: Operators, volume: ArrayLike, sxx: ArrayLike, syy: ArrayLike, sxy: ArrayLike) -> Pair:
    """``f_int,x = −(Gx (V ∘ σxx) + Gy (V ∘ σxy))``, ``f_int,y = −(Gx (V ∘ σxy) + Gy (V ∘ σyy))``;
    finite values, ``volume`` positive."""

def dispersion(
    shape: ShapeSpec,
    mass: MassScheme,
    acceleration_mass: Optional[MassScheme] = None,
    particles_per_cell: int = 2,
    samples: int = 64,
    cells: Optional[int] = None,
) -> Tuple[F64, F64]: ...
def mass_diagnostics(ops: Operators, m: ArrayLike, mass: MassScheme = "lumped") -> Dict[str, Union[int, float]]:
    """``MassDiagnostics::compute`` as a dict of its fields; ``m`` finite and positive."""

def critical_time_step(
    ops: Operators,
    m: ArrayLike,
    volume: ArrayLike,
    youngs_modulus: float,
    poisson_ratio: float,
    plane: Plane = "stress",
    mass: MassScheme = "lumped",
) -> float:
    """``Δt_crit = 2 / ω_max``, ``ω²_max = λ_max(M⁻¹ K)``; ``m``, ``volume`` finite and positive."""

def explicit_step(
    grid: Grid,
    particles: Particles,
    youngs_modulus: float,
    poisson_ratio: float,
    dt: float,
    plane: Plane = "stress",
    shape: ShapeSpec = None,
    mass: MassScheme = "lumped",
    position_update: PositionUpdate = "grid_velocity",
) -> Dict[str, Any]:
    """``step::explicit_step`` on a copy of ``particles``: every intermediate of its ``StepRecord``."""

def report_columns() -> List[str]: ...
def scene_operators(path: Union[str, PathLike[str]]) -> Tuple[Grid, Particles, Operators]: ...

class Simulation:
    @staticmethod
    def from_scene(path: Path, allow_large: bool = False, overrides: Optional[List[str]] = None) -> Simulation: ...
    @staticmethod
    def from_toml(
        text: str, base_dir: Optional[str] = None, allow_large: bool = False, overrides: Optional[List[str]] = None
    ) -> Simulation: ...
    @staticmethod
    def from_dict(scene: Dict[str, Any], base_dir: Optional[str] = None, allow_large: bool = False) -> Simulation:
        """Bounded: 64 levels, 2·10⁶ values, 16 MiB of strings, no self-reference, node lists
        no longer than the grid; errors name the key path."""
    @staticmethod
    def from_arrays(
        grid: Grid, particles: Particles, bodies: List[Dict[str, Any]], options: Optional[Dict[str, Any]] = None
    ) -> Simulation: ...
    @staticmethod
    def from_checkpoint(path: Path, end_time: Optional[float] = None, land_every: Optional[float] = None) -> Simulation: ...
    def write_checkpoint(self, path: Path) -> None: ...
    def write_snapshot(self, path: Path) -> None: ...
    @property
    def time(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def end_time(self) -> Optional[float]: ...
    @property
    def version(self) -> int:
        """Changes with every change of the state."""
    land_every: Optional[float]
    def scene_toml(self) -> str: ...
    def stable_time_step(self) -> float: ...
    def step(self, max_dt: Optional[float] = None) -> Dict[str, float]: ...
    def run_rows(self, until: float) -> Tuple[F64, int]:
        """Steps until ``until``: the reports as flat rows and their count. Ctrl-C raises
        ``KeyboardInterrupt`` between two steps (the steps taken stay taken)."""
    def particles(self) -> Dict[str, np.ndarray]: ...
    def set_particle_state(
        self, fields: Mapping[Literal["vx", "vy", "sxx", "syy", "sxy", "bx", "by"], ArrayLike]
    ) -> None:
        """One finite real value per particle in each array (complex: ``TypeError``)."""
    def grid(self) -> Grid: ...
    def operators(self) -> Operators: ...
    def lumped_mass(self) -> F64: ...
    def grid_velocity(self) -> Tuple[F64, F64]: ...
    def active_nodes(self) -> I64: ...

def study_plan(out: str, spec_toml: Optional[str] = None, quick: bool = False, parts: Optional[List[str]] = None) -> int:
    """Plans a study into ``out``; the number of runs (``sparse_mpm.study.plan``)."""

def study_run(dir: str, k: Optional[int] = None, n: Optional[int] = None, index: Optional[int] = None) -> Tuple[int, int, int, int]:
    """Runs shard ``k`` of ``n``, or plan ``index``, or every run; ``(taken, ran, skipped, failed)``."""

def study_merge(dir: str) -> Tuple[int, int, List[int]]:
    """Merges the complete runs; ``(merged, failed, missing plan indices)``."""
