"""isomarch from Python: implicit surfaces and molecules, ray marched on the
GPU (Vulkan; lavapipe on machines without one) with the forward inclusion
functions of Aydinlilar & Zanni, into numpy arrays.

>>> import isomarch
>>> scene = isomarch.Scene.from_molecule("1A8O.pdb")
>>> renderer = isomarch.Renderer()
>>> image = renderer.render(scene, size=(256, 256))
>>> image.rgba.shape
(256, 256, 4)

Errors raise :class:`IsomarchError` with the message the command line
prints. The GPU works with the interpreter released.
"""

from __future__ import annotations

import json as _json
import os as _os
from typing import TYPE_CHECKING

import numpy as _np

from . import _native
from ._native import DEFAULT_SEED, IsomarchError, MoleculeOptions, __version__

if TYPE_CHECKING:  # names for the annotations only: not in the module
    import os
    from typing import Optional, Sequence, Tuple, Union

    PathLike = Union[str, "os.PathLike[str]"]

__all__ = [
    "Scene",
    "Trajectory",
    "Renderer",
    "Image",
    "MoleculeOptions",
    "IsomarchError",
    "DEFAULT_SEED",
    "element_radius",
    "element_color",
    "to_dataframe",
]


def __dir__():
    """The API alone (PEP 562): not the names the module imports."""
    return sorted([*__all__, "__version__"])


def _molecule_options(options: Optional[MoleculeOptions], fields: dict) -> MoleculeOptions:
    """``options``, or one made of its fields given as keywords
    (``hydrogens=True``); not both. ``color=`` is ``coloring=`` (the
    command line's ``--color``)."""
    if "color" in fields:
        if "coloring" in fields:
            raise TypeError("give color or coloring, not both")
        fields["coloring"] = fields.pop("color")
    if options is None:
        return MoleculeOptions(**fields)
    if fields:
        raise TypeError(f"give options or its fields ({', '.join(sorted(fields))}), not both")
    if not isinstance(options, MoleculeOptions):
        raise TypeError(f"options must be an isomarch.MoleculeOptions, got {type(options).__name__}")
    return options


def element_radius(symbol: str) -> Optional[float]:
    """Bondi's van der Waals radius of an element in ångström, or None."""
    return _native.element_radius(symbol)


def element_color(symbol: str) -> Tuple[float, float, float]:
    """The colour molecule scenes give an element (Jmol's, linear RGB)."""
    return _native.element_color(symbol)


class Scene:
    """A scene: a file's, a molecule's, or atoms given as arrays.

    Build one with :meth:`load`, :meth:`from_molecule` or :meth:`from_atoms`.
    """

    def __init__(self, native: "_native.NativeScene", warnings: Sequence[str] = (), summary: str = ""):
        self._native = native
        #: Warnings from reading a molecule (elements without a radius).
        self.warnings = list(warnings)
        #: What a molecule became: atoms used and left out.
        self.summary = summary

    def viewed(self, **view) -> "Scene":
        """This scene seen otherwise, as ``isomarch render``'s view flags
        do, applied in this order: ``camera`` (a file holding a RON camera
        block, as the viewer's C key writes), ``turn`` (a list such as
        ``["y:90", "x:-20"]``: VTK's azimuth, elevation and roll),
        ``zoom``, ``fov`` (degrees), ``ortho`` (True, or the view's height),
        ``clip`` (``"near:D,far:D"``) and ``background`` (a colour name,
        ``#rrggbb`` or linear ``"r,g,b"``). The scene itself is unchanged."""
        return Scene(self._native.viewed(**view), self.warnings, self.summary)

    @staticmethod
    def load(path: PathLike) -> "Scene":
        """Reads, parses and validates a scene file (.ron); a molecule file
        (.pdb, .cif, .gro, optionally .gz) is read with the default molecule
        options, as ``isomarch render FILE`` reads either."""
        native, warnings, summary = _native.scene_load(_os.fspath(path))
        return Scene(native, warnings, summary)

    @staticmethod
    def from_molecule(path: PathLike, options: Optional[MoleculeOptions] = None, **fields) -> "Scene":
        """The scene of a PDB, mmCIF or GRO file (optionally gzipped): one
        Gaussian blob per atom, as ``isomarch scene`` and ``render`` make it.

        How: ``options`` (a :class:`MoleculeOptions`), or its fields as
        keywords: ``hydrogens``, ``sharpness``, ``radius_scale``, ``iso``,
        ``coloring`` (``"element"``, ``"chain"`` or ``"none"``) and
        ``turntable`` (seconds per turn of the camera about the vertical);
        each left out is the command line's default.
        """
        native, warnings, summary = _native.scene_from_molecule(_os.fspath(path), _molecule_options(options, fields))
        return Scene(native, warnings, summary)

    @staticmethod
    def from_atoms(positions, radii, colors=None, options: Optional[MoleculeOptions] = None, **fields) -> "Scene":
        """The scene of atoms given as arrays, as :meth:`from_molecule` makes
        it of a file with the same atoms: ``positions`` (N, 3) in ångström,
        ``radii`` (N,) van der Waals radii in ångström, ``colors`` (N, 3)
        linear RGB or None (one surface colour). Any array-like works: an
        MDAnalysis selection's ``positions``, a gemmi structure's.
        ``options`` or its fields as keywords, as :meth:`from_molecule`
        takes them (``hydrogens`` and ``coloring`` do not apply: the atoms
        are those given, coloured by ``colors``).
        """
        positions = _np.ascontiguousarray(positions, dtype=_np.float64)
        radii = _np.ascontiguousarray(radii, dtype=_np.float64).reshape(-1)
        if positions.ndim != 2:
            raise IsomarchError(f"positions must have shape (N, 3), got {positions.shape}")
        if colors is not None:
            colors = _np.ascontiguousarray(colors, dtype=_np.float64)
            if colors.ndim != 2:
                raise IsomarchError(f"colors must have shape (N, 3), got {colors.shape}")
        native = _native.scene_from_atoms(positions, radii, colors, _molecule_options(options, fields))
        return Scene(native)

    @property
    def primitive_count(self) -> int:
        """Primitives in the scene (atoms, for a molecule)."""
        return self._native.primitive_count

    @property
    def resolution(self) -> Tuple[int, int]:
        """The camera's resolution (width, height): the default size."""
        return self._native.resolution

    @property
    def method(self) -> str:
        """The scene's marcher (``marching.method``)."""
        return self._native.method

    @property
    def animated(self) -> bool:
        """Whether anything moves over scene time."""
        return self._native.animated

    def __repr__(self) -> str:
        w, h = self.resolution
        return f"<isomarch.Scene {self._native.source!r}: {self.primitive_count} primitives, {w}x{h}, {self.method}>"


class Image:
    """A rendered frame: ``rgba`` (H, W, 4) uint8 (sRGB, alpha 255), and the
    per-pixel ``depth`` (H, W) float32 (hit distance, inf on a miss),
    ``steps`` (H, W) uint32 (marching steps) and ``normals`` (H, W, 3)
    float32 (0 on a miss), with the frame's ``stats``. It converts to a
    numpy array (``np.asarray(image)`` is ``rgba``) and shows itself in
    Jupyter.
    """

    def __init__(self, raw: dict, width: int, height: int):
        self.width, self.height = width, height
        self.rgba: _np.ndarray = raw["rgba"].reshape(height, width, 4)
        self.depth: _np.ndarray = raw["depth"].reshape(height, width)
        self.steps: _np.ndarray = raw["steps"].reshape(height, width)
        self.normals: _np.ndarray = raw["normals"].reshape(height, width, 3)
        #: Steps, evaluations and times per ray, as ``render --stats`` writes them.
        self.stats: dict = _json.loads(raw["stats"])
        self.method: str = raw["method"]
        self.device: str = raw["device"]

    def __array__(self, dtype=None, copy=None):
        return self.rgba if dtype is None else self.rgba.astype(dtype)

    def to_float(self) -> _np.ndarray:
        """The image as (H, W, 4) float32 in [0, 1]."""
        return self.rgba.astype(_np.float32) / 255.0

    def png(self) -> bytes:
        """PNG bytes, the file ``isomarch render -o x.png`` writes."""
        return _native.png_bytes(self.rgba.reshape(-1), self.width, self.height)

    def save(self, path: PathLike) -> None:
        """Writes the PNG to ``path`` (whole, or not at all)."""
        path = _os.fspath(path)
        tmp = f"{path}.{_os.getpid()}.tmp"
        with open(tmp, "wb") as f:
            f.write(self.png())
        _os.replace(tmp, path)

    def _repr_png_(self) -> bytes:
        return self.png()

    def __repr__(self) -> str:
        return f"<isomarch.Image {self.width}x{self.height} {self.method} on {self.device}: {self.stats['steps_per_ray']:.2f} steps/ray>"


class Trajectory:
    """The frames of a trajectory as scenes: a topology (PDB, mmCIF, GRO,
    optionally gzipped, or PSF) and its trajectory (XTC, DCD), or a file of
    several models or frames alone (docs/trajectories.md).

    Frame ``k`` is the scene ``isomarch scene TOPOLOGY TRAJECTORY --frame k``
    writes, with the camera framed once (``framing="first"``: on the first
    frame's atoms; ``"all"``: on every frame's), each frame's atoms made
    into blobs by ``options`` or its fields as keywords (as
    :meth:`Scene.from_molecule` takes them). Frames are read when asked
    for: ``len(t)``, ``t[k]``; ``for scene in t``, :meth:`frames` and
    :meth:`movie` read each frame on a thread of their own while the one
    before is rendered (two ahead), as ``isomarch render --frames`` does.

    ``pbc`` is the command line's ``--pbc``: ``"auto"`` (molecules split by
    the periodic box made whole where the file has a box and one is split;
    the note is among :attr:`warnings`), ``"whole"``, ``"center"`` or
    ``"none"`` (the file's coordinates). ``interpolate=K`` is
    ``--interpolate K``: K frames between each pair of saved ones, the
    atoms' positions interpolated linearly; each scene's ``between`` says
    which saved frames it lies between and how far from the first.
    """

    def __init__(
        self,
        topology: PathLike,
        trajectory: Optional[PathLike] = None,
        *,
        framing: str = "first",
        options: Optional[MoleculeOptions] = None,
        pbc: str = "auto",
        interpolate: int = 0,
        **fields,
    ):
        self._native, warnings, summary = _native.trajectory_open(
            _os.fspath(topology),
            None if trajectory is None else _os.fspath(trajectory),
            framing,
            _molecule_options(options, fields),
            str(pbc),
            int(interpolate),
        )
        self._interpolate = int(interpolate)
        #: Warnings from reading the topology.
        self.warnings = list(warnings)
        #: What the first frame became: atoms used and left out.
        self.summary = summary

    def __len__(self) -> int:
        return len(self._native)

    def __getitem__(self, k: int) -> Scene:
        n = len(self)
        if k < 0:
            k += n
        if not 0 <= k < n:
            raise IndexError(f"frame {k} of a trajectory of {n}")
        native, time_ps = self._native.scene(k)
        scene = Scene(native, self.warnings, self.summary)
        #: The frame's simulation time in picoseconds, where the file gives one.
        scene.time_ps = time_ps
        #: The saved frames it lies between and how far from the first:
        #: (k, k, 0.0) for saved frame k.
        scene.between = self._native.between(k)
        return scene

    def __iter__(self):
        return self.frames()

    def frames(self, frames: Optional[range] = None):
        """The scenes of ``frames`` (a range or a list of frame numbers,
        default every frame), in that order, each read and made into a
        scene on a thread of its own while the caller renders the one
        before: the same scenes as ``t[k]``."""
        frames = [int(k) for k in (range(len(self)) if frames is None else frames)]
        n = len(self)
        frames = [k + n if k < 0 else k for k in frames]
        ahead = self._native.prefetch(frames)
        for k in frames:
            got = ahead.next()
            if got is None:
                raise IsomarchError(f"frame {k}: the reader stopped early")
            frame, native, time_ps, between = got
            if frame != k:
                raise IsomarchError(f"frame {k} asked, frame {frame} read")
            scene = Scene(native, self.warnings, self.summary)
            scene.time_ps = time_ps
            scene.between = between
            yield scene

    def movie(
        self,
        path: PathLike,
        fps: float = 25.0,
        *,
        size: Optional[Tuple[int, int]] = None,
        quality: str = "good",
        frames: Optional[range] = None,
        renderer: Optional["Renderer"] = None,
        method: Optional[str] = None,
        samples: Optional[int] = None,
        interpolate: Optional[int] = None,
        **look,
    ) -> None:
        """Writes the frames as a movie: ``.mp4`` (H.264), ``.webm`` (VP9)
        or ``.gif``, as ``isomarch render TOPOLOGY TRAJECTORY --frames A..B
        -o path`` writes it, byte for byte for the same options: frame k
        rendered at scene time k / ``fps`` (a turntable turns), ``size``
        (default the first frame's camera's), ``quality`` (``"highest"`` to
        ``"low"``, default ``"good"``), ``frames`` (a range, default every
        frame), and ``method``, ``samples`` and the look's keywords
        (``depth_cue``, ``outline``, ...) as :meth:`Renderer.render` takes
        them. Frames stream to the encoder as they are rendered; the movie
        is written whole or not at all (an error or KeyboardInterrupt
        leaves no file). MP4 and WebM need ffmpeg (Debian's ``ffmpeg``
        package): without it, :class:`IsomarchError` before any frame.
        ``interpolate=K`` makes K frames between each pair of saved ones for
        this movie (``--interpolate K``; ``frames`` then counts those)."""
        if interpolate is not None and int(interpolate) != self._interpolate:
            before = self._interpolate
            self._native.set_interpolate(int(interpolate))
            self._interpolate = int(interpolate)
            try:
                return self.movie(path, fps, size=size, quality=quality, frames=frames, renderer=renderer, method=method, samples=samples, **look)
            finally:
                self._native.set_interpolate(before)
                self._interpolate = before
        frames = range(len(self)) if frames is None else frames
        if len(frames) == 0:
            raise IsomarchError("no frame to write: frames is empty")
        first = self[frames[0]]
        width, height = first.resolution if size is None else size
        path = _os.fspath(path)
        movie = _native.NativeMovie(path, float(fps), str(quality), int(width), int(height))
        try:
            renderer = Renderer() if renderer is None else renderer
            # The next frame is read while this one renders.
            for k, scene in zip(frames, self.frames(frames)):
                movie.push(renderer.render(scene, (width, height), method, k / float(fps), samples, _movie=path, **look))
        except BaseException:
            movie.abandon()
            raise
        movie.finish()

    #: How many frames (the first) and at what size (width, height) a
    #: notebook's inline video of a trajectory shows (:meth:`_repr_html_`).
    repr_frames: int = 100
    repr_size: Tuple[int, int] = (256, 256)

    def _repr_html_(self) -> str:
        """The trajectory as an inline video in a notebook: its first
        ``repr_frames`` frames at ``repr_size``, an MP4 in a ``<video>``
        element (an animated GIF in an ``<img>`` where ffmpeg is not
        installed), embedded as base64."""
        import base64
        import shutil
        import tempfile

        kind = "mp4" if shutil.which("ffmpeg") else "gif"
        with tempfile.TemporaryDirectory() as folder:
            path = _os.path.join(folder, f"trajectory.{kind}")
            self.movie(path, frames=range(min(len(self), int(self.repr_frames))), size=self.repr_size)
            with open(path, "rb") as f:
                data = base64.b64encode(f.read()).decode("ascii")
        width = int(self.repr_size[0])
        if kind == "mp4":
            return f'<video controls autoplay loop muted playsinline width="{width}" src="data:video/mp4;base64,{data}"></video>'
        return f'<img width="{width}" src="data:image/gif;base64,{data}"/>'

    def __repr__(self) -> str:
        return f"Trajectory({self._native.source()!r}, {len(self)} frames)"


class Renderer:
    """Renders scenes on one Vulkan device, keeping its context between
    calls. ``device`` picks one by index or by a part of its name (as
    ``isomarch --device``); None picks a discrete GPU, then an integrated
    one, then the CPU driver. ``timeout`` is seconds per frame (default:
    the command line's ``--timeout``).
    """

    def __init__(self, device: Optional[str] = None, timeout: Optional[float] = None):
        self._native = _native.NativeRenderer(None if device is None else str(device), None if timeout is None else float(timeout))

    @property
    def device(self) -> str:
        """The device's name."""
        return self._native.device

    def render(
        self,
        scene: Scene,
        size: Optional[Tuple[int, int]] = None,
        method: Optional[str] = None,
        time: float = 0.0,
        samples: Optional[int] = None,
        *,
        depth_cue: Optional[str] = None,
        outline: Optional[int] = None,
        outline_color: Optional[str] = None,
        outline_jump: Optional[float] = None,
        transparent_background: bool = False,
        _movie: Optional[str] = None,
    ) -> Image:
        """Renders ``scene`` at scene ``time`` (seconds), ``size`` (width,
        height; default the scene camera's), with ``method`` (default the
        scene's) and ``samples`` rays per pixel (anti-aliasing; default the
        scene camera's): the same pixels as ``isomarch render``, with its
        ``--depth-cue`` (``"START:END"``), ``--outline`` (a width),
        ``--outline-color``, ``--outline-jump`` and
        ``--transparent-background`` (``rgba``'s alpha is then each
        pixel's coverage) as keywords. (``_movie``, for
        :meth:`Trajectory.movie`: the frame of that movie, as the command
        line makes it; its flat RGBA array alone.)"""
        width, height = scene.resolution if size is None else size
        raw = self._native.render(
            scene._native,
            int(width),
            int(height),
            method,
            float(time),
            None if samples is None else int(samples),
            depth_cue,
            None if outline is None else int(outline),
            outline_color,
            None if outline_jump is None else float(outline_jump),
            bool(transparent_background),
            _movie,
        )
        if _movie is not None:
            return raw["rgba"]
        return Image(raw, int(width), int(height))

    def bench(
        self,
        scene: Scene,
        methods: Optional[Sequence[str]] = None,
        rays: Optional[int] = None,
        seed: int = DEFAULT_SEED,
        repeat: int = 1,
        camera: Optional[Tuple[int, int]] = None,
        any_hit: bool = False,
    ) -> dict:
        """``isomarch bench``: each method (default: the scene's) on the
        same seeded rays of the benchmark protocol (``rays`` of them,
        default 16,384: fewer than the command line's default; or ``camera=(w, h)``: a
        sample of that frame's pixel rays), against the f64 reference. The
        report as ``bench --json`` writes it; its rows are
        ``report["methods"]`` (:func:`to_dataframe` makes a pandas
        DataFrame of them). ``any_hit=True`` benchmarks the shadow and
        occlusion rays cast from the reference's hits instead
        (``bench --any-hit``)."""
        methods = [scene.method] if methods is None else [str(m) for m in methods]
        rays = None if rays is None else int(rays)
        return _json.loads(self._native.bench(scene._native, methods, rays, int(seed), int(repeat), camera, bool(any_hit)))

    def tradeoff(
        self,
        scene: Scene,
        methods: Sequence[str] = ("segment", "quadratic-taylor"),
        min_steps: Optional[Sequence[float]] = None,
        max_steps: Optional[Sequence[int]] = None,
        rays: Optional[int] = None,
        seed: int = DEFAULT_SEED,
    ) -> list:
        """``isomarch tradeoff``: each method at every minimum step and
        step budget on the same rays, against the f64 reference: a list of
        rows (the rows of ``tradeoff.csv``: time, steps, errors, miss and
        false-hit rates, Pareto front). The sweep left out is the command
        line's: minimum steps 1e-4 to 1, step budgets 8 to 10,000, 16,384
        rays."""
        return _json.loads(
            self._native.tradeoff(
                scene._native,
                [str(m) for m in methods],
                None if min_steps is None else [float(v) for v in min_steps],
                None if max_steps is None else [int(v) for v in max_steps],
                None if rays is None else int(rays),
                int(seed),
            )
        )

    def __repr__(self) -> str:
        return f"<isomarch.Renderer on {self.device}>"


def to_dataframe(rows):
    """A pandas DataFrame of rows (``bench(...)["methods"]``, ``tradeoff(...)``); pandas
    is needed for this function only."""
    try:
        import pandas
    except ImportError as e:
        raise ImportError("isomarch.to_dataframe needs pandas (pip install pandas); the rows are plain dicts without it") from e
    return pandas.DataFrame(list(rows))
