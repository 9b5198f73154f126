"""Type hints of the native module (python/src/lib.rs); use the classes of
``isomarch`` instead."""

from typing import Any, List, Optional, Tuple

import numpy as np

class IsomarchError(Exception): ...

__version__: str
DEFAULT_SEED: int

class MoleculeOptions:
    """How a molecule becomes a scene; each field left out is the command
    line's default."""

    select: str
    hydrogens: bool
    sharpness: float
    radius_scale: float
    iso: float
    coloring: str
    turntable: Optional[float]
    def __init__(
        self,
        *,
        select: Optional[str] = None,
        surfaces: Optional[str] = None,
        apart: Optional[list] = None,
        hydrogens: Optional[bool] = None,
        sharpness: Optional[float] = None,
        radius_scale: Optional[float] = None,
        iso: Optional[float] = None,
        coloring: Optional[str] = None,
        palette: Optional[str] = None,
        range: Optional[Tuple[float, float]] = None,
        values: Optional[Any] = None,
        turntable: Optional[float] = None,
    ) -> None: ...

class NativeScene:
    def viewed(
        self,
        *,
        camera: Optional[str] = None,
        turn: Optional[list] = None,
        zoom: Optional[float] = None,
        fov: Optional[float] = None,
        ortho: Optional[Any] = None,
        clip: Optional[str] = None,
        background: Optional[str] = None,
    ) -> "NativeScene": ...
    primitive_count: int
    resolution: Tuple[int, int]
    method: str
    source: str
    animated: bool

class NativeTrajectory:
    def __len__(self) -> int: ...
    def source(self) -> str: ...
    def set_interpolate(self, k: int) -> int: ...
    def between(self, k: int) -> Tuple[int, int, float]: ...
    def prefetch(self, frames: List[int]) -> NativeFrames: ...
    def scene(self, k: int) -> Tuple[NativeScene, Optional[float]]: ...

class NativeFrames:
    def next(self) -> Optional[Tuple[int, NativeScene, Optional[float], Tuple[int, int, float]]]: ...

def trajectory_open(
    topology: str, trajectory: Optional[str], framing: str, options: MoleculeOptions, pbc: str, interpolate: int
) -> Tuple[NativeTrajectory, list, str]: ...

class NativeMovie:
    def __init__(self, path: str, fps: float, quality: str, width: int, height: int) -> None: ...
    def push(self, rgba: np.ndarray) -> None: ...
    def finish(self) -> None: ...
    def abandon(self) -> None: ...

class NativeRenderer:
    device: str
    def __init__(self, device: Optional[str] = None, timeout: Optional[float] = None) -> None: ...
    def render(
        self,
        scene: NativeScene,
        width: int,
        height: int,
        method: Optional[str],
        time: float,
        samples: Optional[int],
        depth_cue: Optional[str],
        outline: Optional[int],
        outline_color: Optional[str],
        outline_jump: Optional[float],
        transparent_background: bool,
        movie: Optional[str] = None,
    ) -> dict: ...
    def bench(
        self,
        scene: NativeScene,
        methods: list,
        rays: Optional[int] = None,
        seed: Optional[int] = None,
        repeats: int = 1,
        camera: Optional[Tuple[int, int]] = None,
        any_hit: bool = False,
    ) -> str: ...
    def tradeoff(
        self,
        scene: NativeScene,
        methods: list,
        min_steps: Optional[list] = None,
        max_steps: Optional[list] = None,
        rays: Optional[int] = None,
        seed: Optional[int] = None,
    ) -> str: ...

def scene_load(path: str) -> Tuple[NativeScene, list, str]: ...
def scene_from_molecule(path: str, options: MoleculeOptions) -> Tuple[NativeScene, list, str]: ...
def scene_from_atoms(
    positions: np.ndarray,
    radii: np.ndarray,
    colors: Optional[np.ndarray],
    options: MoleculeOptions,
) -> NativeScene: ...
def element_radius(symbol: str) -> Optional[float]: ...
def element_color(symbol: str) -> Tuple[float, float, float]: ...
def png_bytes(rgba: np.ndarray, width: int, height: int) -> bytes: ...
