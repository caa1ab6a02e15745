"""Type stubs of the `superhelix` extension module (docs/python.md)."""

import pathlib
from os import PathLike
from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike
FloatArray = npt.NDArray[np.float64]
Path = Union[str, PathLike]

class SceneError(ValueError):
    """A scene the runtime refuses; str(e) is what `superhelix validate` prints."""

    problems: List[Tuple[str, str]]

class SimulationError(RuntimeError):
    """A step failed (a strand diverged or a solve failed)."""

    result: "RunResult"

class StepError(RuntimeError):
    """A strand of a Batch failed its step and kept its state."""

    report: "StepReport"

def supported_elements() -> List[int]: ...

class Scene:
    @staticmethod
    def from_toml(text: str, base_dir: Optional[Path] = None) -> "Scene": ...
    @staticmethod
    def from_file(path: Path) -> "Scene": ...
    @staticmethod
    def from_dict(d: Mapping[str, Any], base_dir: Optional[Path] = None) -> "Scene": ...
    @staticmethod
    def default() -> "Scene": ...
    @staticmethod
    def rod(
        *,
        length: float,
        radius: float,
        youngs_modulus: float,
        density: float,
        poisson: float,
        elements: int = 10,
        ellipticity: float = 1.0,
        root: Optional[ArrayLike] = None,
        direction: Optional[ArrayLike] = None,
        normal: Optional[ArrayLike] = None,
        natural: Optional[ArrayLike] = None,
        root_end: str = "clamped",
        tip: Optional[Mapping[str, Any]] = None,
        point_loads: Optional[List[Mapping[str, Any]]] = None,
        gravity: Optional[ArrayLike] = None,
        internal_friction: float = 0.0,
        air_drag: float = 0.0,
        dt: float = 1e-3,
        duration: float = 1.0,
        integrator: Optional[str] = None,
        engine: Optional[str] = None,
        name: str = "rod",
    ) -> "Scene": ...
    @property
    def toml(self) -> str: ...
    @property
    def base_dir(self) -> pathlib.Path: ...
    @property
    def strand_count(self) -> int: ...
    @property
    def strand_names(self) -> List[str]: ...
    @property
    def elements(self) -> List[int]: ...
    @property
    def dt(self) -> float: ...
    @property
    def duration(self) -> float: ...
    @property
    def output_fps(self) -> float: ...
    @property
    def tolerance(self) -> Optional[float]: ...
    @property
    def samples_per_element(self) -> int: ...
    @property
    def steps(self) -> int: ...
    @property
    def frame_count(self) -> int: ...
    @property
    def engine(self) -> str: ...
    @property
    def groom_reports(self) -> List[str]: ...
    def validate(self) -> Dict[str, Any]: ...
    def run(
        self,
        *,
        duration: Optional[float] = None,
        frames: Optional[int] = None,
        tolerance: Optional[float] = None,
        energies: bool = True,
        max_bytes: float = 4e9,
        mechanics: bool = False,
    ) -> "RunResult": ...
    def simulation(
        self, *, dt: Optional[float] = None, tolerance: Optional[float] = None
    ) -> "Simulation": ...
    def head_pose(self, t: float) -> Tuple[FloatArray, FloatArray]: ...

class RunResult:
    times: FloatArray
    state_times: FloatArray
    points: FloatArray
    offsets: npt.NDArray[np.int64]
    nodes: Union[FloatArray, List[FloatArray]]
    q: Union[FloatArray, List[FloatArray]]
    qdot: Union[FloatArray, List[FloatArray]]
    kinetic_energy: Optional[FloatArray]
    potential_energy: Optional[FloatArray]
    energy: Optional[FloatArray]
    strand_names: List[str]
    groups: List[str]
    radii: FloatArray
    stats: Dict[str, int]
    summary: Dict[str, Any]
    summary_line: str
    frame_steps: Optional[FloatArray]
    strand_steps: Optional[FloatArray]
    held: Optional[FloatArray]
    held_tips: List[int]
    arc_nodes: Optional[FloatArray]
    d1: Optional[FloatArray]
    mechanics: Optional[List[Dict[str, Any]]]
    engine: str
    completed: bool
    @property
    def frame_count(self) -> int: ...

class Simulation:
    def step(
        self,
        dt: Optional[float] = None,
        steps: int = 1,
        callback: Optional[Callable[["Simulation"], None]] = None,
        every: int = 1,
    ) -> None: ...
    @staticmethod
    def load(path: Union[str, Path], folder: Optional[Union[str, Path]] = None) -> "Simulation": ...
    def save(self, path: Union[str, Path]) -> None: ...
    @property
    def time(self) -> float: ...
    @property
    def dt(self) -> float: ...
    @property
    def steps_taken(self) -> int: ...
    @property
    def strand_count(self) -> int: ...
    @property
    def strand_names(self) -> List[str]: ...
    @property
    def engine(self) -> str: ...
    @property
    def q(self) -> Union[FloatArray, List[FloatArray]]: ...
    @property
    def qdot(self) -> Union[FloatArray, List[FloatArray]]: ...
    def nodes(
        self, samples_per_element: Optional[int] = None
    ) -> Union[FloatArray, List[FloatArray]]: ...
    def set_state(self, i: int, q: ArrayLike, qdot: Optional[ArrayLike] = None) -> None: ...
    def energies(self) -> Dict[str, FloatArray]: ...
    def stats(self) -> Dict[str, int]: ...
    def error_control(self) -> Optional[Dict[str, Any]]: ...
    def head_pose(self) -> Tuple[FloatArray, FloatArray]: ...
    def set_head(
        self,
        position: ArrayLike,
        rotation: Optional[ArrayLike] = None,
        velocity: Optional[ArrayLike] = None,
        acceleration: Optional[ArrayLike] = None,
        omega: Optional[ArrayLike] = None,
        alpha: Optional[ArrayLike] = None,
        time: Optional[float] = None,
    ) -> None: ...
    @property
    def gravity(self) -> Optional[FloatArray]: ...
    def set_gravity(self, g: Optional[ArrayLike]) -> None: ...
    def solve_static(self) -> List[Dict[str, Any]]: ...
    def directors(
        self, samples_per_element: Optional[int] = None
    ) -> Union[FloatArray, List[FloatArray]]: ...
    def velocities(
        self, samples_per_element: Optional[int] = None
    ) -> Union[FloatArray, List[FloatArray]]: ...
    track_inertia: bool
    def internal_loads(self, inertia: Optional[bool] = None) -> List[Dict[str, Any]]: ...
    def point_loads(self, i: int) -> List[Dict[str, Any]]: ...
    def set_point_loads(self, i: int, loads: Iterable[Mapping[str, Any]]) -> None: ...
    def holder(self, i: int) -> Optional[Dict[str, FloatArray]]: ...
    def set_holder(
        self, i: int, position: ArrayLike, frame: Optional[ArrayLike] = None
    ) -> None: ...
    def follow_branch(
        self,
        i: int,
        stop: float,
        parameter: str = "load",
        start: Optional[float] = None,
        direction: Optional[ArrayLike] = None,
        step: float = 0.02,
        max_step: Optional[float] = None,
        max_points: int = 1000,
    ) -> Dict[str, Any]: ...

class StepReport:
    stepped: int
    failed: int
    first_failed: Optional[int]
    max_element_rotation: float
    attempts: int
    substeps: int
    energy_rejected: int
    energy_limited: int
    energy_unbalanced: int
    steps: int
    rejected: int
    largest_error: float
    smallest_step: float
    largest_step: float
    def as_dict(self) -> Dict[str, Any]: ...

class Batch:
    def __init__(
        self,
        elements: int,
        count: int = 1,
        *,
        length: float = 0.2,
        element_lengths: Optional[ArrayLike] = None,
        root_position: Optional[ArrayLike] = None,
        root_frame: Optional[ArrayLike] = None,
        radius: float = 50e-6,
        ellipticity: float = 1.0,
        youngs_modulus: float = 1.5e9,
        poisson_ratio: float = 0.48,
        density: float = 1300.0,
        natural: Optional[ArrayLike] = None,
        internal_friction: float = 5e-11,
        air_drag: float = 5e-6,
        gravity: Optional[ArrayLike] = None,
    ) -> None: ...
    @staticmethod
    def from_scene(scene: Scene) -> "Batch": ...
    def step(
        self,
        dt: float,
        head_position: Optional[ArrayLike] = None,
        head_rotation: Optional[ArrayLike] = None,
        *,
        velocity: Optional[ArrayLike] = None,
        acceleration: Optional[ArrayLike] = None,
        angular_velocity: Optional[ArrayLike] = None,
        angular_acceleration: Optional[ArrayLike] = None,
    ) -> StepReport: ...
    def set_head(
        self,
        position: ArrayLike,
        rotation: ArrayLike,
        *,
        velocity: Optional[ArrayLike] = None,
        acceleration: Optional[ArrayLike] = None,
        angular_velocity: Optional[ArrayLike] = None,
        angular_acceleration: Optional[ArrayLike] = None,
    ) -> None: ...
    def set_gravity(self, g: Optional[ArrayLike]) -> None: ...
    def set_checked(self, checked: bool) -> None: ...
    def set_tolerance(self, tau: float) -> None: ...
    @property
    def tolerance(self) -> Optional[float]: ...
    @property
    def checked(self) -> bool: ...
    @property
    def count(self) -> int: ...
    @property
    def elements(self) -> int: ...
    @property
    def strand_bytes(self) -> int: ...
    @property
    def workspace_bytes(self) -> int: ...
    @property
    def last_step(self) -> Optional[StepReport]: ...
    @property
    def q(self) -> FloatArray: ...
    @property
    def qdot(self) -> FloatArray: ...
    def set_state(self, i: int, q: ArrayLike, qdot: Optional[ArrayLike] = None) -> None: ...
    def centrelines(self) -> FloatArray: ...
    def energies(self) -> Dict[str, FloatArray]: ...
