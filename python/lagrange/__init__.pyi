# Type stubs for the lagrange package (units SI; arrays float64 numpy).

# ---- lagrange.simulate, Instance, Client, read_log (python/simulate.cpp, python/bus.cpp) ----
# n = an instance's num_dofs, N = rows (steps, states or log records).
import os as _os
from typing import Callable as _Callable, Dict as _Dict, Iterator as _Iterator, List as _List, Mapping as _Mapping
from typing import Optional as _Optional, Sequence as _Sequence, Union as _Union

import numpy as _np
import numpy.typing as _npt

_F64 = _npt.NDArray[_np.float64]
_I64 = _npt.NDArray[_np.int64]
_Scene = _Union[str, "_os.PathLike[str]"]  # a scene file, or YAML text (a str holding a line break)
_Law = _Callable[[float, _F64, _F64], _npt.ArrayLike]  # (t s, q (n,), qd (n,)) -> tau (n,) N·m or N

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

def simulate(scene: _Scene, duration: float, *,
             controller: _Union[None, _Law, _Mapping[str, _Law]] = None) -> _Dict[str, SimulationResult]:
    """Run a scene offline with lagranged's Instance code: {instance name: SimulationResult}.

    duration s (> 0): round(duration / period) steps. controller: a Python law for a one-instance
    scene, or {name: law}; the torque of an instance under `controller: external`, else applied as given.
    Raises ValueError (bad or refused scene), FileNotFoundError (no such file); a fault is a RuntimeWarning.
    """

class Instance:
    """One scene instance stepped from Python (lagranged's Instance, its controllers and health check)."""
    def __init__(self, scene: _Scene, name: _Optional[str] = None) -> None: ...
    def step(self, tau: _Optional[_npt.ArrayLike] = None) -> None:
        """One period: tau None under the scene's controller; else (n,) N·m or N (an external controller's torque).
        A failed health check restores the last healthy state and raises RuntimeError."""
    def reset(self) -> None: ...
    name: str
    num_dofs: int
    joint_names: _List[str]
    period: float            # s
    t: float                 # s
    q: _F64                  # (n,)
    qd: _F64                 # (n,)
    qdd: _F64                # (n,) at the current state under the last applied tau
    tau: _F64                # (n,) the last step's applied force
    q_des: _F64              # (n,)
    kinetic_energy: float    # J
    potential_energy: float  # J
    energy_residual: float   # J (nan without an energy balance)
    controller: str          # the active controller's type

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
    """lagranged's reply to one command."""
    accepted: bool
    message: str             # as lagrangectl command prints it: "arm: pause done; now paused with pd" / "refused: ..."
    run_id: int
    def __bool__(self) -> bool: ...

class StateIterator(_Iterator[State]):
    dropped: int
    def __next__(self) -> State: ...

class Client:
    """lagranged on the bus through lagrangectl's own client: one run per instance, verdicts, signed traffic."""
    def __init__(self, url: _Optional[str] = None, prefix: str = "", key_file: _Optional[str] = None,
                 wait: float = 3.0) -> None: ...
    url: str
    prefix: str
    def state(self, name: str, timeout: float = 3.0) -> State: ...
    def states(self, name: str, duration: float) -> StateIterator: ...
    def send_setpoint(self, name: str, q: _npt.ArrayLike, qd: _Optional[_npt.ArrayLike] = None,
                      qdd: _Optional[_npt.ArrayLike] = None) -> bool: ...
    def send_torque(self, name: str, tau: _npt.ArrayLike, state_tick: _Optional[int] = None,
                    channel: _Optional[str] = None) -> bool: ...
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

def read_log(path: _Union[str, "_os.PathLike[str]"], channel: _Optional[str] = None) -> _Dict[str, LogChannel]:
    """An lcm-logger file as {channel: LogChannel}; channel: a regular expression. FileNotFoundError / ValueError."""
