"""Type hints of the native module (python/src/lib.rs); use the classes of
``isomarch`` instead."""

from typing import Optional, Tuple

import numpy as np

class IsomarchError(Exception): ...

class NativeScene:
    primitive_count: int
    resolution: Tuple[int, int]
    method: str
    source: str
    animated: bool

class NativeTrajectory:
    def __len__(self) -> int: ...
    def source(self) -> str: ...
    def scene(self, k: int) -> Tuple[NativeScene, Optional[float]]: ...

def trajectory_open(
    topology: str,
    trajectory: Optional[str],
    framing: str,
    hydrogens: bool,
    sharpness: float,
    radius_scale: float,
    iso: float,
    coloring: str,
    turntable: Optional[float],
) -> Tuple[NativeTrajectory, list, str]: ...

class NativeRenderer:
    device: str
    def __init__(self, device: Optional[str] = None, timeout: float = 600.0) -> None: ...
    def render(
        self, scene: NativeScene, width: int, height: int, method: Optional[str], time: float, samples: Optional[int]
    ) -> dict: ...
    def bench(
        self,
        scene: NativeScene,
        methods: list,
        rays: int,
        seed: int,
        repeats: int,
        camera: Optional[Tuple[int, int]],
        any_hit: bool,
    ) -> str: ...
    def tradeoff(
        self, scene: NativeScene, methods: list, min_steps: list, max_steps: list, rays: int, seed: int
    ) -> str: ...

def scene_load(path: str) -> Tuple[NativeScene, list, str]: ...
def scene_from_molecule(
    path: str, hydrogens: bool, sharpness: float, radius_scale: float, iso: float, coloring: str, turntable: Optional[float]
) -> Tuple[NativeScene, list, str]: ...
def scene_from_atoms(
    positions: np.ndarray,
    radii: np.ndarray,
    colors: Optional[np.ndarray],
    sharpness: float,
    radius_scale: float,
    iso: float,
    turntable: Optional[float],
) -> NativeScene: ...
def element_radius(symbol: str) -> Optional[float]: ...
def element_color(symbol: str) -> Tuple[float, float, float]: ...
def png_bytes(rgba: np.ndarray, width: int, height: int) -> bytes: ...
