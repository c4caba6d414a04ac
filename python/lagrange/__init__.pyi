# Type stubs for the lagrange package (units SI; arrays float64 numpy).
from os import PathLike
from typing import Literal, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

python_executable: str
python_version: str

# ---- lagrange.Model (python/model.cpp) ------------------------------------
# n = num_dofs. A per-joint argument is one state (n,) or a batch (N, n)
# (any layout, any real dtype, lists too); a batch's results gain a leading
# axis N and are computed without the GIL over `threads` threads.
# A floating base (from_urdf(..., floating_base=True)): q is (nq,) | (N, nq)
# with nq = num_positions = n + 7 (p, quaternion x y z w, joints), and qd,
# qdd, tau (and every result's n) are nv = num_velocities = n + 6 (v_b, ω_b
# in base axes, joint rates); the README's "Floating base".

_ArrayLike = npt.ArrayLike
_Array = npt.NDArray[np.float64]
_Method = Literal["closed-form", "lagrangian", "recursive"]
# The axes of a frame's Jacobian and J̇ qd, by Pinocchio's names: the world's (LOCAL_WORLD_ALIGNED) or the frame's own (LOCAL).
_Reference = Literal["local_world_aligned", "local"]
# A URDF file (str, bytes, os.PathLike), or its text: a str whose first character other than white space is '<'.
_Urdf = Union[str, bytes, PathLike[str], PathLike[bytes]]

class Model:
    """A plant's rigid-body dynamics and frame kinematics: tau = M(q) qdd + C(q, qd) qd + G(q).

    Picklable (copy, multiprocessing): it pickles as what built it (a URDF's text, or a built-in plant's parameters)."""

    def __init__(self, urdf: _Urdf, *, gravity: Sequence[float] = (0.0, 0.0, -9.81), method: _Method = "recursive",
                 mass_scale: float = 1.0, floating_base: bool = False) -> None:
        """A robot from a URDF file or its text, as Model.from_urdf (pinocchio.buildModelFromUrdf)."""
    @staticmethod
    def from_urdf(
        urdf: _Urdf,
        gravity: Sequence[float] = (0.0, 0.0, -9.81),
        method: _Method = "recursive",
        mass_scale: float = 1.0,
        floating_base: bool = False,
    ) -> Model:
        """A robot from a URDF file, or its text (a str beginning with '<'); gravity (gx, gy, gz) m/s² in the root
        link's frame.

        Raises FileNotFoundError (no such file), ValueError (not a robot lagrange reads), TypeError (neither)."""
        ...
    @staticmethod
    def builtin(name: Literal["pendulum", "arm2", "cartpole", "chain"], method: _Method | None = None,
                **params: Union[float, str, Sequence[float], Sequence[str]]) -> Model:
        """A built-in planar plant with the parameters of scenes and `lagrangectl eval` (m1=1.0, L1=0.6, ...).

        method None: the fastest exact path (closed-form, or recursive for the chain)."""
        ...
    @property
    def num_dofs(self) -> int:
        """n: the joints' degrees of freedom (q's length for a fixed base)."""
    @property
    def num_positions(self) -> int:
        """nq: q's length (n; n + 7 on a floating base)."""
    @property
    def num_velocities(self) -> int:
        """nv: the length of qd, qdd, tau (n; n + 6 on a floating base)."""
    @property
    def floating_base(self) -> bool:
        """Whether the root link is a free base."""
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

    def mass_matrix(self, q: _ArrayLike, *, threads: int = 1, out: Optional[_Array] = None) -> _Array:
        """q (n,) | (N, n) => M(q) (n, n) | (N, n, n), kg·m² (kg for prismatic joints)."""
    def coriolis_matrix(self, q: _ArrayLike, qd: _ArrayLike, *, threads: int = 1) -> _Array:
        """(q, qd) => C(q, qd) (n, n) | (N, n, n): C qd in N·m, Ṁ − 2C skew."""
    def gravity(self, q: _ArrayLike, *, threads: int = 1, out: Optional[_Array] = None) -> _Array:
        """q => G(q) = ∂V/∂q (n,) | (N, n), N·m or N."""
    def forward_dynamics(self, q: _ArrayLike, qd: _ArrayLike, tau: _ArrayLike, *, threads: int = 1,
                         out: Optional[_Array] = None) -> _Array:
        """(q, qd, tau) => qdd = M⁻¹ (tau − C qd − G) (n,) | (N, n), rad/s² or m/s²."""
    def inverse_dynamics(self, q: _ArrayLike, qd: _ArrayLike, qdd: _ArrayLike, *, threads: int = 1,
                         out: Optional[_Array] = None) -> _Array:
        """(q, qd, qdd) => tau = M qdd + C qd + G (n,) | (N, n), N·m or N."""
    def kinetic_energy(self, q: _ArrayLike, qd: _ArrayLike, *, threads: int = 1) -> Union[float, _Array]:
        """(q, qd) => T = ½ qdᵀ M qd, J: a float | (N,)."""
    def potential_energy(self, q: _ArrayLike, *, threads: int = 1) -> Union[float, _Array]:
        """q => V, J: a float | (N,)."""
    def frame_pose(self, frame: Union[int, str], q: _ArrayLike, *, threads: int = 1) -> tuple[_Array, _Array]:
        """(frame, q) => (R (3, 3) | (N, 3, 3), p (3,) | (N, 3)): the frame's axes and origin (m), world frame."""
    def frame_jacobian(self, frame: Union[int, str], q: _ArrayLike, *, reference: _Reference = "local_world_aligned",
                       threads: int = 1, out: Optional[_Array] = None) -> _Array:
        """(frame, q) => J (6, n) | (N, 6, n): (ṗ m/s, ω rad/s) = J qd of the frame's origin, in world axes or
        (reference="local") the frame's own."""
    def frame_bias_acceleration(self, frame: Union[int, str], q: _ArrayLike, qd: _ArrayLike, *,
                                reference: _Reference = "local_world_aligned", threads: int = 1) -> _Array:
        """(frame, q, qd) => J̇ qd (6,) | (N, 6): (m/s², rad/s²) at qdd = 0, in world axes or the frame's own."""
    def frame_id(self, name: str) -> int:
        """name => its index in frame_names, which frame_pose, frame_jacobian and frame_bias_acceleration take."""
    def center_of_mass(self, q: _ArrayLike, *, threads: int = 1) -> tuple[_Array, _Array]:
        """q => (c (3,) | (N, 3), J_c (3, nv) | (N, 3, nv)): the centre of mass (m, world) and ċ = J_c qd; a
        floating-base Model's."""
    def centroidal_momentum_matrix(self, q: _ArrayLike, *, threads: int = 1) -> _Array:
        """q => A_G (6, nv) | (N, 6, nv): (linear N·s, angular about c N·m·s) = A_G qd, world axes (Pinocchio's
        ccrba); a floating-base Model's."""
    def centroidal_momentum_bias(self, q: _ArrayLike, qd: _ArrayLike, *, threads: int = 1) -> _Array:
        """(q, qd) => Ȧ_G qd (6,) | (N, 6): ḣ_G at qdd = 0 (N, N·m about c), world axes; a floating-base Model's."""
    def integrate(self, q: _ArrayLike, v: _ArrayLike, dt: float, *, threads: int = 1) -> _Array:
        """(q, v, dt) => q ⊕ dt v (nq,) | (N, nq): on SE(3) for a floating base (Pinocchio's integrate)."""
    def difference(self, q0: _ArrayLike, q1: _ArrayLike, *, threads: int = 1) -> _Array:
        """(q0, q1) => v (nv,) | (N, nv) with integrate(q0, v, 1) = q1 (Pinocchio's difference)."""
    def forward_dynamics_derivatives(self, q: _ArrayLike, qd: _ArrayLike, tau: _ArrayLike, *,
                                     threads: int = 1) -> tuple[_Array, _Array, _Array]:
        """(q, qd, tau) => (∂qdd/∂q, ∂qdd/∂qd, ∂qdd/∂tau = M⁻¹), each (n, n) | (N, n, n): exact, [i, j] = ∂qdd_i/∂x_j."""
    def inverse_dynamics_derivatives(self, q: _ArrayLike, qd: _ArrayLike, qdd: _ArrayLike, *,
                                     threads: int = 1) -> tuple[_Array, _Array, _Array]:
        """(q, qd, qdd) => (∂tau/∂q, ∂tau/∂qd, ∂tau/∂qdd = M), each (n, n) | (N, n, n): exact."""
    def step_derivatives(self, q: _ArrayLike, qd: _ArrayLike, tau: _ArrayLike, dt: float,
                         integrator: Literal["explicit-euler", "semi-implicit-euler", "rk4"] = "rk4", *,
                         threads: int = 1) -> tuple[_Array, _Array]:
        """(q, qd, tau, dt) => (A = ∂x⁺/∂x (2n, 2n) | (N, 2n, 2n), B = ∂x⁺/∂tau (2n, n) | (N, 2n, n)), x = (q, qd):
        one step of the integrator with tau held, differentiated through its stages (gravity and Coriolis only)."""

# ---- end of lagrange.Model ------------------------------------------------

# ---- lagrange.optimize_trajectory (python/trajectory.cpp) -----------------
# N = horizon knots, n = model.num_dofs, m = the actuated joints.

class TrajectoryResult:
    """An optimised trajectory (optimize_trajectory): the plan, its affine policy and the solver's record."""
    t: _Array               # (N+1,) s: k dt
    q: _Array               # (N+1, n) rad or m; q[0] = q0
    qd: _Array              # (N+1, n) rad/s or m/s
    tau: _Array             # (N, n) N·m or N, held over [t_k, t_k+1); 0 on joints not actuated
    K: _Array               # (N, m, 2n): u = clamp(u_k + K_k (x − x_k)), x = (q, qd)
    actuated: list[int]     # the m actuated joints (K's rows)
    status: Literal["converged", "max-iterations", "line-search-failed", "not-positive-definite"]
    converged: bool
    iterations: int
    cost: float             # J of the trajectory
    cost_history: _Array    # (iterations + 1,): J of the tau = 0 rollout, then after each iteration; never increasing
    expected_decrease: float
    regularization: float

def optimize_trajectory(model: Model, q0: _ArrayLike, qd0: _ArrayLike, horizon: int, dt: float, *,
                        cost: Union[None, dict[str, Union[float, _ArrayLike]]] = None,
                        tau_limits: Union[None, float, _ArrayLike,
                                          tuple[Union[float, _ArrayLike], Union[float, _ArrayLike]]] = None,
                        integrator: Literal["explicit-euler", "semi-implicit-euler", "rk4"] = "rk4",
                        actuated: Union[None, Sequence[int]] = None, max_iterations: int = 50,
                        tolerance: float = 1e-8) -> TrajectoryResult:
    """Box-constrained DDP (the mpc controller's solver) from (q0, qd0) over `horizon` knots of dt s.

    cost: weights q, qd, q_terminal, qd_terminal (a number or n values >= 0), tau (a number or m values > 0),
    references q_ref, qd_ref ((n,) or (N+1, n)); tau_limits: ±limit (a number, m or n values) or (lower, upper);
    actuated: default a cart-pole's cart, else every joint. ValueError naming a bad argument; RuntimeError when the
    tau = 0 rollout is not finite."""


# ---- lagrange.simulate, Instance, Client, read_log (python/simulate.cpp, python/bus.cpp) ----
# n = an instance's num_dofs, N = rows (steps, states or log records).
import os as _os
from typing import Callable as _Callable, Dict as _Dict, Iterator as _Iterator, List as _List, Mapping as _Mapping
from typing import Optional as _Optional, Sequence as _Sequence, Union as _Union

import numpy as _np
import numpy.typing as _npt

_F64 = _npt.NDArray[_np.float64]
_I64 = _npt.NDArray[_np.int64]
_Scene = _Union[str, bytes, "_os.PathLike[str]", "_os.PathLike[bytes]"]  # a scene file, or YAML text (a str holding a line break)
_Law = _Callable[[float, _F64, _F64], _npt.ArrayLike]  # (t s, q (n,), qd (n,)) -> tau (n,) N·m or N

class TaskRows:
    """The frame a task-space controller (or an mpc with a frame) moved, one row per step: lagrangectl simulate's
    FILE.task.csv (nan at t = 0)."""
    frame: str
    position: _F64          # (N, 3) m, world frame
    position_des: _F64      # (N, 3) m, the commanded origin
    error: _F64             # (N, 6) commanded ⊖ measured: m, then rad

class BaseRows:
    """A floating base, one row per step: lagrangectl simulate's base columns (log2csv's <NAME>_BASE names)."""
    position: _F64          # (N, 3) m: the base frame's origin in the world
    orientation: _F64       # (N, 4) its axes in the world, a unit quaternion (x, y, z, w)
    linear_velocity: _F64   # (N, 3) m/s: the base origin's, base axes
    angular_velocity: _F64  # (N, 3) rad/s: the base's, base axes
    com: _F64               # (N, 3) m: the robot's centre of mass, world
    linear_momentum: _F64   # (N, 3) N·s, world axes (total mass × the centre of mass's velocity)
    angular_momentum: _F64  # (N, 3) N·m·s about the centre of mass, world axes

class BaseState:
    """A floating base at one instant: base_state_t on <NAME>_BASE (Client.base_state) or Instance.base."""
    t: float                # s, simulated
    utime: _Optional[int]   # µs since the epoch: the tick's wall clock (None offline)
    run_id: _Optional[int]  # None offline
    tick: _Optional[int]    # the tick of the State it goes with (None offline)
    position: _F64          # (3,) m
    orientation: _F64       # (4,) unit quaternion (x, y, z, w)
    linear_velocity: _F64   # (3,) m/s, base axes
    angular_velocity: _F64  # (3,) rad/s, base axes
    com: _F64               # (3,) m, world
    linear_momentum: _F64   # (3,) N·s, world axes
    angular_momentum: _F64  # (3,) N·m·s about the centre of mass, world axes

class SimulationResult:
    """One instance's offline run: one row per step, the first at t = 0; each row the doubles lagrangectl simulate writes."""
    name: str
    joint_names: _List[str]
    t: _F64                 # (N,) s
    q: _F64                 # (N, n) rad or m
    qd: _F64                # (N, n)
    q_des: _F64             # (N, n) the setpoint's positions
    tau: _F64               # (N, n) applied (after limits and saturation) by the step that led to the row; 0 at t = 0
    kinetic_energy: _F64    # (N,) J
    potential_energy: _F64  # (N,) J
    energy_residual: _F64   # (N,) J: ε = E − E(0) − W; nan without an energy balance
    epsilon: _F64           # alias of energy_residual
    energies: _F64          # (N, 2) J: kinetic_energy and potential_energy side by side
    fault: _Optional[str]   # the health check's line when the instance faulted (rows end at its last healthy step)
    mpc_failures: _Optional[str]  # how many mpc solves failed, by status (the last usable plan was followed)
    task: _Optional[TaskRows]  # under a controller that moves a frame (not a Python law): its frame per row
    base: _Optional[BaseRows]  # a floating base's pose, twist, centre of mass and momentum per row; None: fixed base

def simulate(scene: _Scene, duration: float, *,
             controller: _Union[None, _Law, _Mapping[str, _Law]] = None) -> _Dict[str, SimulationResult]:
    """Run a scene offline with lagranged's Instance code: {instance name: SimulationResult}.

    duration s (> 0): round(duration / period) steps. controller: a Python law for a one-instance
    scene, or {name: law}; the torque of an instance under `controller: external`, else applied as given.
    Raises ValueError (bad or refused scene; rows that would take over a quarter of the memory),
    FileNotFoundError (no such file); a fault, and an mpc controller's failed solves, are a RuntimeWarning.
    """

class Instance:
    """One scene instance stepped from Python (lagranged's Instance, its controllers and health check)."""
    def __init__(self, scene: _Scene, name: _Optional[str] = None) -> None: ...
    def step(self, tau: _Optional[_npt.ArrayLike] = None) -> None:
        """One period: tau None under the scene's controller; else (n,) N·m or N (an external controller's torque).
        A failed health check restores the last healthy state and raises RuntimeError."""
    def reset(self) -> None: ...
    def set_state(self, q: _Optional[_npt.ArrayLike] = None, qd: _Optional[_npt.ArrayLike] = None,
                  base_q: _Optional[_npt.ArrayLike] = None, base_v: _Optional[_npt.ArrayLike] = None) -> None:
        """Put the instance at (q, qd) now (None keeps one): the next step starts there; ε runs on (re-based).
        A floating base's pose base_q (7: p in m, then the unit quaternion x, y, z, w) and twist base_v (6: v in
        m/s, ω in rad/s, base axes) likewise; ValueError for either on a fixed base."""
    name: str
    num_dofs: int
    joint_names: _List[str]
    period: float            # s
    t: float                 # s
    q: _F64                  # (n,); assigning one moves the instance there (set_state)
    qd: _F64                 # (n,); assignable too
    qdd: _F64                # (n,) at the current state under the last applied tau
    tau: _F64                # (n,) the last step's applied force
    q_des: _F64              # (n,)
    kinetic_energy: float    # J
    potential_energy: float  # J
    energy_residual: float   # J (nan without an energy balance)
    controller: str          # the active controller's type
    base: _Optional[BaseState]  # a floating base now (q, qd, ... are the joints'); None for a fixed base

class State:
    """One state_t as lagranged published it."""
    utime: int               # µs since the epoch: the tick's wall clock
    run_id: int
    tick: int
    t: float                 # s, simulated
    num_dofs: int
    q: _F64                  # (n,)
    qd: _F64
    qdd: _F64
    tau: _F64                # applied, N·m or N
    q_des: _F64
    qd_des: _F64
    kinetic_energy: float    # J
    potential_energy: float  # J
    controller: str
    mode: str                # running, hold, fault, paused, estop, stopped, waiting
    received: float          # s on time.monotonic()'s clock: when this client received it

class Verdict:
    """lagranged's reply to one command; or send_torque's outcome (sent, or refused unsent)."""
    accepted: bool
    message: str             # as lagrangectl command prints it: "arm: pause done; now paused with pd" / "refused: ..."
                             # (an estop to several runs: a line per run, then "estop applied by K of the N runs ..."
                             # unless every run applied it)
    run_id: int
    def __bool__(self) -> bool: ...

class StateIterator(_Iterator[State]):
    dropped: int
    def __next__(self) -> State: ...

class Client:
    """lagranged on the bus through lagrangectl's own client: one run per instance, verdicts, signed traffic."""
    def __init__(self, url: _Optional[str] = None, prefix: str = "", key_file: _Optional[str] = None,
                 wait: float = 3.0, bus_domain: _Optional[str] = None) -> None:
        """wait: s, in (0, 86400] (lagrangectl --wait's bound); state(timeout=) is held to the same."""
    url: str
    prefix: str
    def state(self, name: str, timeout: float = 3.0) -> State: ...
    def states(self, name: str, duration: float) -> StateIterator: ...
    def base_state(self, name: str, timeout: float = 3.0) -> BaseState:
        """The run's latest <NAME>_BASE (a floating base); RuntimeError when none comes within timeout s."""
    def send_setpoint(self, name: str, q: _npt.ArrayLike, qd: _Optional[_npt.ArrayLike] = None,
                      qdd: _Optional[_npt.ArrayLike] = None) -> bool: ...
    def send_torque(self, name: str, tau: _npt.ArrayLike, state_tick: _Optional[int] = None,
                    channel: _Optional[str] = None) -> Verdict:
        """Accepted once sent; refused, unsent, while the instance runs another controller than its external one
        ("refused: the instance is not running its external controller (active: pd)")."""
    def command(self, name: str, kind: str, *words: str, kp: _Optional[_npt.ArrayLike] = None,
                kd: _Optional[_npt.ArrayLike] = None) -> Verdict: ...

class LogChannel:
    """One channel of an lcm-logger file, decoded as log2csv decodes it; fields also as attributes (rec.q)."""
    channel: str
    type: _Optional[str]     # "state_t", ...; None: not a lagrange type
    rows: int
    skipped: int
    columns: _Dict[str, _Union[_F64, _I64, _List[str]]]  # log_utime, then the message's fields; arrays (rows, n)
    def __getattr__(self, name: str) -> _Union[_F64, _I64, _List[str]]: ...
    def __getitem__(self, name: str) -> _Union[_F64, _I64, _List[str]]: ...
    def __len__(self) -> int: ...

def read_log(path: _Union[str, bytes, "_os.PathLike[str]", "_os.PathLike[bytes]"], channel: _Optional[str] = None) -> _Dict[str, LogChannel]:
    """An lcm-logger file as {channel: LogChannel}; channel: a regular expression.

    FileNotFoundError; ValueError for a file that is not a regular file (a FIFO) or not a log, and for a log cut
    short or corrupt, naming the event's byte offset."""
