# Type stubs for the lagrange package (units SI; arrays float64 numpy).
from os import PathLike
from typing import Literal, Sequence, Union

import numpy as np
import numpy.typing as npt

python_executable: str
python_version: str

# ---- lagrange.Model (python/model.cpp) ------------------------------------
# n = num_dofs. A per-joint argument is one state (n,) or a batch (N, n)
# (any layout, any real dtype, lists too); a batch's results gain a leading
# axis N and are computed without the GIL over `threads` threads.

_ArrayLike = npt.ArrayLike
_Array = npt.NDArray[np.float64]
_Method = Literal["closed-form", "lagrangian", "recursive"]

class Model:
    """A plant's rigid-body dynamics and frame kinematics: tau = M(q) qdd + C(q, qd) qd + G(q)."""

    @staticmethod
    def from_urdf(
        path: Union[str, PathLike[str]],
        gravity: Sequence[float] = (0.0, 0.0, -9.81),
        method: _Method = "recursive",
        mass_scale: float = 1.0,
    ) -> Model:
        """A robot from a URDF file; gravity (gx, gy, gz) m/s² in the root link's frame.

        Raises FileNotFoundError (no such file) or ValueError (not a robot lagrange reads)."""
        ...
    @staticmethod
    def builtin(name: Literal["pendulum", "arm2", "cartpole", "chain"], method: _Method | None = None,
                **params: Union[float, str, Sequence[float], Sequence[str]]) -> Model:
        """A built-in planar plant with the parameters of scenes and `lagrangectl eval` (m1=1.0, L1=0.6, ...).

        method None: the fastest exact path (closed-form, or recursive for the chain)."""
        ...
    @property
    def num_dofs(self) -> int:
        """n: the degrees of freedom, q's length."""
    @property
    def joint_names(self) -> list[str]:
        """The joints' names in q order (n)."""
    @property
    def frame_names(self) -> list[str]:
        """The frames frame_pose and frame_jacobian take."""
    @property
    def method(self) -> _Method:
        """How M, C and G are derived."""
    @property
    def plant(self) -> Literal["pendulum", "arm2", "cartpole", "chain", "urdf"]:
        """The plant type."""

    def mass_matrix(self, q: _ArrayLike, *, threads: int = 1) -> _Array:
        """q (n,) | (N, n) => M(q) (n, n) | (N, n, n), kg·m² (kg for prismatic joints)."""
    def coriolis_matrix(self, q: _ArrayLike, qd: _ArrayLike, *, threads: int = 1) -> _Array:
        """(q, qd) => C(q, qd) (n, n) | (N, n, n): C qd in N·m, Ṁ − 2C skew."""
    def gravity(self, q: _ArrayLike, *, threads: int = 1) -> _Array:
        """q => G(q) = ∂V/∂q (n,) | (N, n), N·m or N."""
    def forward_dynamics(self, q: _ArrayLike, qd: _ArrayLike, tau: _ArrayLike, *, threads: int = 1) -> _Array:
        """(q, qd, tau) => qdd = M⁻¹ (tau − C qd − G) (n,) | (N, n), rad/s² or m/s²."""
    def inverse_dynamics(self, q: _ArrayLike, qd: _ArrayLike, qdd: _ArrayLike, *, threads: int = 1) -> _Array:
        """(q, qd, qdd) => tau = M qdd + C qd + G (n,) | (N, n), N·m or N."""
    def kinetic_energy(self, q: _ArrayLike, qd: _ArrayLike, *, threads: int = 1) -> Union[float, _Array]:
        """(q, qd) => T = ½ qdᵀ M qd, J: a float | (N,)."""
    def potential_energy(self, q: _ArrayLike, *, threads: int = 1) -> Union[float, _Array]:
        """q => V, J: a float | (N,)."""
    def frame_pose(self, frame: str, q: _ArrayLike, *, threads: int = 1) -> tuple[_Array, _Array]:
        """(frame, q) => (R (3, 3) | (N, 3, 3), p (3,) | (N, 3)): the frame's axes and origin (m), world frame."""
    def frame_jacobian(self, frame: str, q: _ArrayLike, *, threads: int = 1) -> _Array:
        """(frame, q) => J (6, n) | (N, 6, n), world-aligned: (ṗ m/s, ω rad/s) = J qd."""
    def frame_bias_acceleration(self, frame: str, q: _ArrayLike, qd: _ArrayLike, *, threads: int = 1) -> _Array:
        """(frame, q, qd) => J̇ qd (6,) | (N, 6), world-aligned: (m/s², rad/s²) at qdd = 0."""

# ---- end of lagrange.Model ------------------------------------------------
