"""Type stubs of the Rust extension ``sparse_mpm._core``. Every array argument is copied into
Rust; every array returned is a new NumPy array (no memory is shared)."""

from os import PathLike
from typing import Any, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
ShapeSpec = Union[str, Mapping[str, Any], None]

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
        node_order: str = "x_fastest",
    ) -> None: ...
    @staticmethod
    def from_node_coordinates(x_g: ArrayLike, y_g: ArrayLike) -> Grid:
        """The grid whose node k is at ``(x_g[k], y_g[k])``, node order recovered from the lists."""
    @property
    def origin(self) -> Tuple[float, float]: ...
    @property
    def cell_size(self) -> Tuple[float, float]: ...
    @property
    def cells(self) -> Tuple[int, int]: ...
    @property
    def num_nodes(self) -> int: ...
    @property
    def node_order(self) -> str: ...
    def node_x(self) -> npt.NDArray[np.float64]: ...
    def node_y(self) -> npt.NDArray[np.float64]: ...

class Particles:
    """Particle positions ``x, y``, masses ``m_p > 0``, volumes ``V_p > 0``, velocities (default 0)."""

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
    ) -> None: ...
    def __len__(self) -> int: ...
    def to_dict(self) -> Dict[str, np.ndarray]: ...
    @property
    def x(self) -> npt.NDArray[np.float64]: ...
    @property
    def y(self) -> npt.NDArray[np.float64]: ...
    @property
    def mass(self) -> npt.NDArray[np.float64]: ...
    @property
    def volume(self) -> npt.NDArray[np.float64]: ...
    @property
    def vx(self) -> npt.NDArray[np.float64]: ...
    @property
    def vy(self) -> npt.NDArray[np.float64]: ...
    @property
    def sxx(self) -> npt.NDArray[np.float64]: ...
    @property
    def syy(self) -> npt.NDArray[np.float64]: ...
    @property
    def sxy(self) -> npt.NDArray[np.float64]: ...
    @property
    def bx(self) -> npt.NDArray[np.float64]: ...
    @property
    def by(self) -> npt.NDArray[np.float64]: ...

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
    def col_offsets(self) -> npt.NDArray[np.int64]: ...
    def row_indices(self) -> npt.NDArray[np.int64]: ...
    def values(self, op: str) -> npt.NDArray[np.float64]: ...

def lumped_mass(ops: Operators, m: ArrayLike) -> npt.NDArray[np.float64]:
    """``m_L = N m``."""

def consistent_mass_csc(
    ops: Operators, m: ArrayLike
) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64], int]:
    """``M = N diag(m) N^T`` as ``(indptr, indices, data, num_nodes)``."""

Pair = Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]

def momentum(ops: Operators, m: ArrayLike, vx: ArrayLike, vy: ArrayLike) -> Pair:
    """``q = N (m ∘ v)`` as ``(qx, qy)``."""

def external_force(ops: Operators, m: ArrayLike, bx: ArrayLike, by: ArrayLike) -> Pair:
    """``f_ext = N (m ∘ b)`` as ``(fx, fy)``."""

def internal_force(ops: Operators, volume: ArrayLike, sxx: ArrayLike, syy: ArrayLike, sxy: ArrayLike) -> Pair:
    """``f_int,x = −(Gx (V ∘ σxx) + Gy (V ∘ σxy))``, ``f_int,y = −(Gx (V ∘ σxy) + Gy (V ∘ σyy))``."""

def dispersion(
    shape: Union[str, Mapping[str, Any]],
    mass: str,
    acceleration_mass: Optional[str] = None,
    particles_per_cell: int = 2,
    samples: int = 64,
    cells: Optional[int] = None,
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def mass_diagnostics(ops: Operators, m: ArrayLike, mass: str = "lumped") -> Dict[str, Union[int, float]]:
    """``MassDiagnostics::compute`` as a dict of its fields."""

def critical_time_step(
    ops: Operators,
    m: ArrayLike,
    volume: ArrayLike,
    youngs_modulus: float,
    poisson_ratio: float,
    plane: str = "stress",
    mass: str = "lumped",
) -> float:
    """``Δt_crit = 2 / ω_max``, ``ω²_max = λ_max(M⁻¹ K)``."""

def explicit_step(
    grid: Grid,
    particles: Particles,
    youngs_modulus: float,
    poisson_ratio: float,
    dt: float,
    plane: str = "stress",
    shape: ShapeSpec = None,
    mass: str = "lumped",
    position_update: str = "grid_velocity",
) -> Dict[str, Any]:
    """``step::explicit_step`` on a copy of ``particles``: every intermediate of its ``StepRecord``."""

def report_columns() -> List[str]: ...
def scene_operators(path: Union[str, PathLike[str]]) -> Tuple[Grid, Particles, Operators]: ...

class Simulation:
    @staticmethod
    def from_scene(path: Union[str, PathLike[str]], allow_large: bool = False) -> Simulation: ...
    @staticmethod
    def from_toml(text: str, base_dir: Optional[str] = None, allow_large: bool = False) -> Simulation: ...
    @staticmethod
    def from_dict(scene: Dict[str, Any], base_dir: Optional[str] = None, allow_large: bool = False) -> Simulation: ...
    @property
    def time(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def end_time(self) -> float: ...
    land_every: Optional[float]
    def scene_toml(self) -> str: ...
    def stable_time_step(self) -> float: ...
    def step(self, max_dt: Optional[float] = None) -> Dict[str, float]: ...
    def run_rows(self, until: float) -> Tuple[npt.NDArray[np.float64], int]: ...
    def particles(self) -> Dict[str, np.ndarray]: ...
    def grid(self) -> Grid: ...
    def operators(self) -> Operators: ...
    def lumped_mass(self) -> npt.NDArray[np.float64]: ...
