//! The native half of the `isomarch` Python package (python/isomarch/):
//! scenes, a renderer that keeps its Vulkan context, and arrays out. Every
//! error is raised as `isomarch.IsomarchError` with the one-line message the
//! command line prints; the GPU works with the interpreter released.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use glam::DVec3;
use isomarch::Method;
use isomarch::gpu::{Context, ContextOptions};
use isomarch::layout::FLAG_HIT;
use isomarch::molecule::build::Surfaces;
use isomarch::molecule::build::{atoms_scene, load_scene};
use isomarch::molecule::color::{Palette, Range, Values};
use isomarch::molecule::select::Selection;
use isomarch::molecule::{Coloring, MoleculeChoices, MoleculeOptions, elements};
use isomarch::render::offscreen::{RenderJob, render_frame_indexed};
use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

create_exception!(_native, IsomarchError, PyException, "An isomarch error, with the one-line message the command line prints.");

fn raise(e: impl Into<anyhow::Error>) -> PyErr {
    IsomarchError::new_err(format!("{:#}", e.into()))
}

/// A scene: loaded from a file, made from a molecule, or from atoms.
#[pyclass(module = "isomarch._native", frozen)]
struct NativeScene {
    scene: isomarch::scene::Scene,
}

#[pymethods]
impl NativeScene {
    #[getter]
    fn primitive_count(&self) -> usize {
        self.scene.primitive_count()
    }
    #[getter]
    fn resolution(&self) -> (u32, u32) {
        (self.scene.camera.width, self.scene.camera.height)
    }
    #[getter]
    fn method(&self) -> String {
        self.scene.marching.method.to_string()
    }
    #[getter]
    fn source(&self) -> String {
        self.scene.source.clone()
    }
    #[getter]
    fn animated(&self) -> bool {
        !self.scene.animation.is_static()
    }

    /// The scene seen otherwise, as the command line's view flags do
    /// (isomarch::look::View): `ortho` True takes the perspective view's
    /// height at the target, a number is the height.
    #[pyo3(signature = (*, camera=None, turn=None, zoom=None, fov=None, ortho=None, clip=None, background=None))]
    #[allow(clippy::too_many_arguments)]
    fn viewed(
        &self,
        camera: Option<PathBuf>,
        turn: Option<Vec<String>>,
        zoom: Option<f64>,
        fov: Option<f64>,
        ortho: Option<Bound<'_, PyAny>>,
        clip: Option<String>,
        background: Option<String>,
    ) -> PyResult<NativeScene> {
        let turns = turn
            .unwrap_or_default()
            .iter()
            .map(|t| t.parse::<isomarch::scene::turn::Turn>().map_err(|e| IsomarchError::new_err(format!("turn: {e}"))))
            .collect::<PyResult<Vec<_>>>()?;
        let ortho = match ortho {
            None => None,
            Some(o) if o.is_instance_of::<pyo3::types::PyBool>() => o.extract::<bool>()?.then_some(None),
            Some(o) => Some(Some(o.extract::<f64>()?)),
        };
        let view = isomarch::look::View { camera, turns, zoom, fov, ortho, clip, background };
        let mut scene = self.scene.clone();
        view.apply(&mut scene).map_err(raise)?;
        Ok(NativeScene { scene })
    }
}

/// A value of one of the command line's choices, named by a str
/// (`coloring="chain"`, `framing="all"`): the same names, and for any
/// other one line that lists them.
struct Choice<T>(T);

impl<'a, 'py, T: clap::ValueEnum> FromPyObject<'a, 'py> for Choice<T> {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let name: String = obj.extract()?;
        T::from_str(&name, false).map(Choice).map_err(|_| {
            let names: Vec<String> =
                T::value_variants().iter().filter_map(|v| v.to_possible_value()).map(|v| format!("\"{}\"", v.get_name())).collect();
            IsomarchError::new_err(format!("expected one of {}, got {name:?}", names.join(", ")))
        })
    }
}

/// How a molecule becomes a scene (`isomarch.MoleculeOptions`): made once,
/// keyword by keyword, each field left out taking the command line's
/// default (`MoleculeOptions::default`), and checked as the command line
/// checks it.
#[pyclass(name = "MoleculeOptions", module = "isomarch._native", frozen)]
struct NativeMoleculeOptions {
    options: MoleculeOptions,
}

#[pymethods]
impl NativeMoleculeOptions {
    #[new]
    #[pyo3(signature = (*, select=None, surfaces=None, apart=None, hydrogens=None, sharpness=None, radius_scale=None, iso=None, coloring=None, palette=None, range=None, values=None, turntable=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        select: Option<String>,
        surfaces: Option<Choice<Surfaces>>,
        apart: Option<Vec<String>>,
        hydrogens: Option<bool>,
        sharpness: Option<f64>,
        radius_scale: Option<f64>,
        iso: Option<f64>,
        coloring: Option<Choice<Coloring>>,
        palette: Option<Choice<Palette>>,
        range: Option<(f64, f64)>,
        values: Option<Bound<'_, PyAny>>,
        turntable: Option<f64>,
    ) -> PyResult<Self> {
        let select = select.map(|s| s.parse::<Selection>().map_err(|e| raise(anyhow::anyhow!("select: {e}")))).transpose()?;
        let apart = apart
            .unwrap_or_default()
            .iter()
            .map(|s| s.parse::<Selection>().map_err(|e| raise(anyhow::anyhow!("apart: {e}"))))
            .collect::<PyResult<Vec<_>>>()?;
        let range = range.map(|(min, max)| Range::parse(&format!("{min}:{max}")).map_err(raise)).transpose()?;
        let values = values.map(|v| values_of(&v)).transpose()?.map(Arc::new);
        let choices = MoleculeChoices {
            select,
            values,
            surfaces: surfaces.map(|s| s.0),
            apart,
            hydrogens,
            sharpness,
            radius_scale,
            iso,
            coloring: coloring.map(|c| c.0),
            palette: palette.map(|p| p.0),
            range,
            turntable,
        };
        Ok(NativeMoleculeOptions { options: choices.options().map_err(raise)? })
    }

    #[getter]
    fn select(&self) -> String {
        self.options.selection().to_string()
    }

    #[getter]
    fn hydrogens(&self) -> bool {
        self.options.hydrogens
    }

    #[getter]
    fn sharpness(&self) -> f64 {
        self.options.sharpness
    }

    #[getter]
    fn radius_scale(&self) -> f64 {
        self.options.radius_scale
    }

    #[getter]
    fn iso(&self) -> f64 {
        self.options.iso
    }

    #[getter]
    fn coloring(&self) -> String {
        use clap::ValueEnum as _;
        self.options.coloring.to_possible_value().map_or_else(String::new, |v| v.get_name().to_string())
    }

    #[getter]
    fn turntable(&self) -> Option<f64> {
        self.options.turntable
    }

    fn __repr__(&self) -> String {
        let o = &self.options;
        format!(
            "MoleculeOptions(select={:?}, hydrogens={}, sharpness={}, radius_scale={}, iso={}, coloring={:?}, turntable={})",
            self.select(),
            if o.hydrogens { "True" } else { "False" },
            o.sharpness,
            o.radius_scale,
            o.iso,
            self.coloring(),
            o.turntable.map_or("None".to_string(), |t| t.to_string())
        )
    }
}

/// Values to colour by from a numpy array: one value per atom (N), or one
/// row per frame (T x N).
fn values_of(v: &Bound<'_, PyAny>) -> PyResult<Values> {
    let rows = if let Ok(a) = v.extract::<PyReadonlyArray2<'_, f64>>() {
        a.as_array().rows().into_iter().map(|r| r.to_vec()).collect()
    } else if let Ok(a) = v.extract::<PyReadonlyArray1<'_, f64>>() {
        vec![a.as_array().to_vec()]
    } else {
        return Err(IsomarchError::new_err("values must be a numpy array of float64, one value per atom (N) or per frame and atom (T x N)"));
    };
    Values::from_rows(rows, "values").map_err(raise)
}

/// A scene file, or a molecule file with the default molecule options (as
/// `isomarch render FILE` reads either).
#[pyfunction]
fn scene_load(py: Python<'_>, path: PathBuf) -> PyResult<(NativeScene, Vec<String>, String)> {
    if isomarch::molecule::is_molecule(&path) {
        let (scene, notes) = py.detach(|| load_scene(&path, &MoleculeOptions::default())).map_err(raise)?;
        return Ok((NativeScene { scene }, notes.warnings, notes.summary));
    }
    let scene = py.detach(|| isomarch::scene::Scene::load(&path)).map_err(raise)?;
    Ok((NativeScene { scene }, Vec::new(), String::new()))
}

#[pyfunction]
fn scene_from_molecule(py: Python<'_>, path: PathBuf, options: &NativeMoleculeOptions) -> PyResult<(NativeScene, Vec<String>, String)> {
    let o = options.options.clone();
    let (scene, notes) = py.detach(|| load_scene(&path, &o)).map_err(raise)?;
    Ok((NativeScene { scene }, notes.warnings, notes.summary))
}

#[pyfunction]
fn scene_from_atoms(
    positions: PyReadonlyArray2<'_, f64>,
    radii: PyReadonlyArray1<'_, f64>,
    colors: Option<PyReadonlyArray2<'_, f64>>,
    options: &NativeMoleculeOptions,
) -> PyResult<NativeScene> {
    let o = options.options.clone();
    let p = positions.as_array();
    if p.ncols() != 3 {
        return Err(IsomarchError::new_err(format!("positions must have shape (N, 3), got {:?}", p.shape())));
    }
    let centers: Vec<DVec3> = p.rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect();
    let radii: Vec<f64> = radii.as_array().iter().copied().collect();
    let colors = match &colors {
        Some(c) => {
            let c = c.as_array();
            if c.ncols() != 3 {
                return Err(IsomarchError::new_err(format!("colors must have shape (N, 3), got {:?}", c.shape())));
            }
            Some(c.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect::<Vec<_>>())
        }
        None => None,
    };
    let scene = atoms_scene(&centers, &radii, colors.as_deref(), &o).map_err(raise)?;
    Ok(NativeScene { scene })
}

/// Bondi's van der Waals radius of an element (Å), or None.
#[pyfunction]
fn element_radius(symbol: &str) -> Option<f64> {
    elements::radius(symbol)
}

/// The colour of an element in molecule scenes (Jmol's, linear RGB).
#[pyfunction]
fn element_color(symbol: &str) -> (f64, f64, f64) {
    let c = elements::color(symbol);
    (c[0], c[1], c[2])
}

/// An RGBA uint8 image (H, W, 4) as PNG bytes (its RGB, as the command
/// line writes it).
#[pyfunction]
fn png_bytes<'py>(py: Python<'py>, rgba: PyReadonlyArray1<'_, u8>, width: u32, height: u32) -> PyResult<Bound<'py, PyBytes>> {
    let rgba = rgba.as_array();
    if rgba.len() != (width * height * 4) as usize {
        return Err(IsomarchError::new_err(format!("{} bytes for a {width}x{height} RGBA image", rgba.len())));
    }
    // Opaque: RGB, as `isomarch render` writes; with any alpha below 255
    // (a transparent background): RGBA, as it writes then.
    let bytes = if rgba.iter().skip(3).step_by(4).all(|&a| a == 255) {
        let rgb: Vec<u8> = rgba.iter().enumerate().filter(|(i, _)| i % 4 != 3).map(|(_, v)| *v).collect();
        let img = image::RgbImage::from_raw(width, height, rgb).ok_or_else(|| IsomarchError::new_err("image size"))?;
        isomarch::output::png_bytes(&img).map_err(raise)?
    } else {
        let img = image::RgbaImage::from_raw(width, height, rgba.to_vec()).ok_or_else(|| IsomarchError::new_err("image size"))?;
        isomarch::output::png_bytes(&img).map_err(raise)?
    };
    Ok(PyBytes::new(py, &bytes))
}

/// Marchers by name; at least one.
fn parse_methods(names: &[String]) -> PyResult<Vec<Method>> {
    if names.is_empty() {
        return Err(IsomarchError::new_err("no method given"));
    }
    names.iter().map(|m| isomarch::checks::method(m).map_err(raise)).collect()
}

/// A Vulkan context kept between renders.
#[pyclass(module = "isomarch._native")]
struct NativeRenderer {
    ctx: Arc<Context>,
    timeout: Duration,
}

/// The depth cue, outline width, outline colour and outline jump, as
/// `render` takes them.
type LookArgs = (Option<String>, Option<u32>, Option<String>, Option<f64>);

impl NativeRenderer {
    /// The job of rendering `scene` at `time` with these choices, checked
    /// as the command line checks them, writing (if anything) `output`.
    #[allow(clippy::too_many_arguments)]
    fn job(
        &self,
        scene: &NativeScene,
        (width, height): (u32, u32),
        method: Option<&str>,
        time: f64,
        samples: Option<u32>,
        (depth_cue, outline, outline_color, outline_jump): LookArgs,
        output: PathBuf,
    ) -> PyResult<RenderJob> {
        isomarch::checks::size(width, height).map_err(raise)?;
        let color = outline_color.as_deref().map(|c| isomarch::checks::color("--outline-color", c)).transpose().map_err(raise)?;
        let effects = isomarch::render::offscreen::Effects::from_choices(depth_cue.as_deref(), outline, color, outline_jump).map_err(raise)?;
        let mut posed = scene.scene.at_time(isomarch::checks::time(time).map_err(raise)?);
        if let Some(m) = method {
            posed.marching.method = isomarch::checks::method(m).map_err(raise)?;
        }
        let method = posed.marching.method;
        let mut job = RenderJob::new(posed, method, (width, height), output, self.timeout);
        if let Some(n) = samples {
            job.samples = isomarch::checks::samples(n).map_err(raise)?;
        }
        job.effects = effects;
        Ok(job)
    }
}

#[pymethods]
impl NativeRenderer {
    #[new]
    #[pyo3(signature = (device=None, timeout=None))]
    fn new(py: Python<'_>, device: Option<String>, timeout: Option<f64>) -> PyResult<Self> {
        let timeout = timeout.map_or(Ok(isomarch::render::DEFAULT_TIMEOUT), isomarch::checks::timeout).map_err(raise)?;
        let ctx = py.detach(|| Context::new(&ContextOptions { validation: false, device, present: None })).map_err(raise)?;
        Ok(NativeRenderer { ctx, timeout })
    }

    #[getter]
    fn device(&self) -> String {
        self.ctx.info.name.clone()
    }

    /// Renders `scene` at `time`: a dict of flat arrays (rgba uint8, depth
    /// float32 with inf on misses, steps uint32, normals float32) and the
    /// frame's statistics; with `movie`, as a frame of that movie.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (scene, width, height, method, time, samples, depth_cue, outline, outline_color, outline_jump, transparent_background, movie=None))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        scene: &NativeScene,
        width: u32,
        height: u32,
        method: Option<&str>,
        time: f64,
        samples: Option<u32>,
        depth_cue: Option<String>,
        outline: Option<u32>,
        outline_color: Option<String>,
        outline_jump: Option<f64>,
        transparent_background: bool,
        movie: Option<PathBuf>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let look = (depth_cue, outline, outline_color, outline_jump);
        let mut job = self.job(scene, (width, height), method, time, samples, look, movie.clone().unwrap_or_default())?;
        // A movie's frame (`Trajectory.movie`) is made as `render --frames
        // -o movie` makes it (on the GPU where it can): its image alone,
        // the per-pixel arrays then empty.
        job.results = movie.is_none();
        let (method, background) = (job.method, job.scene.background);
        let ctx = Arc::clone(&self.ctx);
        let isomarch::render::offscreen::FrameReport { frame, march: stats, .. } =
            py.detach(move || render_frame_indexed(&ctx, &job)).map_err(raise)?;
        let rgba = if transparent_background {
            // Alpha the coverage, as `render --transparent-background` writes it.
            frame.shaded_rgba([background.x as f32, background.y as f32, background.z as f32]).into_raw()
        } else {
            let mut rgba = Vec::with_capacity(frame.pixels.len() * 4);
            for p in frame.shaded().pixels() {
                rgba.extend_from_slice(&[p[0], p[1], p[2], 255]);
            }
            rgba
        };
        let depth: Vec<f32> = frame.pixels.iter().map(|p| if p.counts[3] & FLAG_HIT != 0 { p.hit[3] } else { f32::INFINITY }).collect();
        let steps: Vec<u32> = frame.steps();
        let normals: Vec<f32> = frame.pixels.iter().flat_map(|p| [p.hit[0], p.hit[1], p.hit[2]]).collect();
        let out = PyDict::new(py);
        out.set_item("rgba", PyArray1::from_vec(py, rgba))?;
        out.set_item("depth", PyArray1::from_vec(py, depth))?;
        out.set_item("steps", PyArray1::from_vec(py, steps))?;
        out.set_item("normals", PyArray1::from_vec(py, normals))?;
        out.set_item("method", method.to_string())?;
        out.set_item("device", self.ctx.info.name.clone())?;
        // As `render --stats` writes them (the march's part of its JSON).
        out.set_item("stats", serde_json::to_string(&stats).map_err(raise)?)?;
        Ok(out)
    }

    /// `isomarch bench`: the protocol's rays (or a sample of the camera's
    /// pixel rays), every method against the f64 reference; the report as
    /// the JSON `bench --json` writes.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (scene, methods, rays=None, seed=None, repeats=1, camera=None, any_hit=false))]
    fn bench(
        &self,
        py: Python<'_>,
        scene: &NativeScene,
        methods: Vec<String>,
        rays: Option<usize>,
        seed: Option<u64>,
        repeats: usize,
        camera: Option<(u32, u32)>,
        any_hit: bool,
    ) -> PyResult<String> {
        let methods = parse_methods(&methods)?;
        let (rays, seed) = (rays.unwrap_or(isomarch::bench::SAMPLE_RAYS), seed.unwrap_or(isomarch::bench::DEFAULT_SEED));
        let posed = scene.scene.at_time(0.0);
        let variants = [isomarch::bench::Variant { cull: true, quad: posed.marching.quad, generic: false }];
        isomarch::bench::Plan { methods: &methods, variants: &variants, rays, seed, repeats, camera, any_hit }.check().map_err(raise)?;
        let (ctx, timeout) = (Arc::clone(&self.ctx), self.timeout);
        let report = py
            .detach(move || {
                let plan = isomarch::bench::Plan { methods: &methods, variants: &variants, rays, seed, repeats, camera, any_hit };
                isomarch::bench::run(&ctx, &posed, &plan, timeout)
            })
            .map_err(raise)?;
        serde_json::to_string(&report).map_err(raise)
    }

    /// `isomarch tradeoff`: every method at every minimum step and step
    /// budget on the same rays; the points (rows of tradeoff.csv) as JSON.
    /// Arguments left out are `Sweep::full`'s (the command line's).
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (scene, methods, min_steps=None, max_steps=None, rays=None, seed=None))]
    fn tradeoff(
        &self,
        py: Python<'_>,
        scene: &NativeScene,
        methods: Vec<String>,
        min_steps: Option<Vec<f64>>,
        max_steps: Option<Vec<u32>>,
        rays: Option<usize>,
        seed: Option<u64>,
    ) -> PyResult<String> {
        let full = isomarch::tradeoff::Sweep::full(parse_methods(&methods)?);
        let sweep = isomarch::tradeoff::Sweep {
            min_steps: min_steps.unwrap_or(full.min_steps),
            max_steps: max_steps.unwrap_or(full.max_steps),
            rays: rays.unwrap_or(full.rays),
            seed: seed.unwrap_or(full.seed),
            ..full
        };
        sweep.check().map_err(raise)?;
        let posed = scene.scene.at_time(0.0);
        let (ctx, timeout) = (Arc::clone(&self.ctx), self.timeout);
        let points = py.detach(move || isomarch::tradeoff::run(&ctx, &posed, &sweep, timeout, |_| {})).map_err(raise)?;
        serde_json::to_string(&points).map_err(raise)
    }
}

/// A trajectory's frames as scenes (`isomarch render TOPOLOGY TRAJECTORY`'s).
#[pyclass]
struct NativeTrajectory {
    stager: std::sync::Mutex<isomarch::molecule::playback::Stager>,
    len: usize,
    source: String,
    /// What opened it, for a second stager that reads ahead
    /// ([`NativeTrajectory::prefetch`]).
    opened: Opened,
}

/// A trajectory's files and how its frames become scenes.
#[derive(Clone)]
struct Opened {
    topology: PathBuf,
    trajectory: Option<PathBuf>,
    options: MoleculeOptions,
    rule: isomarch::molecule::playback::FramingRule,
    pbc: isomarch::molecule::pbc::Pbc,
    interpolate: usize,
}

impl Opened {
    /// A stager of the trajectory, and the note of what `--pbc` did.
    fn stager(&self) -> anyhow::Result<(isomarch::molecule::playback::Stager, Option<String>)> {
        let (mut t, pbc_note) = isomarch::molecule::trajectory::open_with(&self.topology, self.trajectory.as_deref(), self.pbc)?;
        t.set_interpolate(self.interpolate);
        Ok((isomarch::molecule::playback::Stager::new(t, self.options.clone(), self.rule)?, pbc_note))
    }
}

/// A trajectory's frames read and made into scenes on a thread of their
/// own, two ahead of the caller (`Trajectory.frames`, iteration and
/// `movie`: the next frame is read while this one renders), as `render
/// --frames` and the window read theirs.
#[pyclass]
struct NativeFrames {
    prefetch: std::sync::Mutex<isomarch::molecule::playback::Prefetch>,
}

#[pymethods]
impl NativeFrames {
    /// The next frame: its index, scene, simulation time (ps, or None) and
    /// the saved frames it lies between; None once every frame asked for
    /// was given.
    #[allow(clippy::type_complexity)]
    fn next(&self, py: Python<'_>) -> PyResult<Option<(usize, NativeScene, Option<f64>, (usize, usize, f64))>> {
        let prefetch = &self.prefetch;
        let staged =
            py.detach(|| prefetch.lock().map_err(|_| anyhow::anyhow!("the frames' lock is poisoned")).map(|mut p| p.wait())).map_err(raise)?;
        match staged {
            None => Ok(None),
            Some(s) => {
                let s = s.map_err(raise)?;
                Ok(Some((s.frame, NativeScene { scene: s.scene }, s.time_ps, s.between)))
            }
        }
    }
}

#[pymethods]
impl NativeTrajectory {
    fn __len__(&self) -> usize {
        self.len
    }

    fn source(&self) -> String {
        self.source.clone()
    }

    /// Makes `k` frames between each pair of saved ones (`--interpolate`);
    /// the number of frames after.
    fn set_interpolate(&mut self, k: usize) -> PyResult<usize> {
        let mut stager = self.stager.lock().map_err(|_| IsomarchError::new_err("the trajectory's lock is poisoned"))?;
        stager.trajectory.set_interpolate(k);
        self.len = stager.len();
        self.opened.interpolate = k;
        Ok(self.len)
    }

    /// The saved frames frame `k` lies between, and how far from the first.
    fn between(&self, k: usize) -> PyResult<(usize, usize, f64)> {
        let stager = self.stager.lock().map_err(|_| IsomarchError::new_err("the trajectory's lock is poisoned"))?;
        Ok(stager.trajectory.between(k))
    }

    /// `frames`, in this order, read ahead on a thread of their own.
    fn prefetch(&self, py: Python<'_>, frames: Vec<usize>) -> PyResult<NativeFrames> {
        if let Some(&k) = frames.iter().find(|&&k| k >= self.len) {
            return Err(IsomarchError::new_err(format!("{}: no frame {k}: the trajectory has {}", self.source, self.len)));
        }
        let opened = self.opened.clone();
        let prefetch = py
            .detach(|| -> anyhow::Result<_> {
                use isomarch::molecule::playback::{Order, Prefetch};
                Prefetch::spawn(opened.stager()?.0, Order::List(frames), 2)
            })
            .map_err(raise)?;
        Ok(NativeFrames { prefetch: std::sync::Mutex::new(prefetch) })
    }

    /// Frame `k`'s scene and simulation time (ps, or None).
    fn scene(&self, py: Python<'_>, k: usize) -> PyResult<(NativeScene, Option<f64>)> {
        let stager = &self.stager;
        let (scene, time) = py.detach(|| stager.lock().map_err(|_| anyhow::anyhow!("the trajectory's lock is poisoned"))?.scene(k)).map_err(raise)?;
        Ok((NativeScene { scene }, time))
    }
}

#[pyfunction]
#[pyo3(signature = (topology, trajectory, framing, options, pbc, interpolate))]
fn trajectory_open(
    py: Python<'_>,
    topology: PathBuf,
    trajectory: Option<PathBuf>,
    framing: Choice<isomarch::molecule::playback::FramingRule>,
    options: &NativeMoleculeOptions,
    pbc: Choice<isomarch::molecule::pbc::Pbc>,
    interpolate: usize,
) -> PyResult<(NativeTrajectory, Vec<String>, String)> {
    let opened = Opened { topology, trajectory, options: options.options.clone(), rule: framing.0, pbc: pbc.0, interpolate };
    let (stager, mut notes, pbc_note) = py
        .detach(|| -> anyhow::Result<_> {
            let (mut stager, pbc_note) = opened.stager()?;
            let (_, _, notes) = stager.text(0)?;
            Ok((stager, notes, pbc_note))
        })
        .map_err(raise)?;
    // What --pbc did goes with the warnings, as the command line's note.
    notes.warnings.extend(pbc_note);
    let (len, source) = (stager.len(), stager.trajectory.source.clone());
    Ok((NativeTrajectory { stager: std::sync::Mutex::new(stager), len, source, opened }, notes.warnings, notes.summary))
}

/// A movie being written (`Trajectory.movie`): RGBA frames pushed in
/// order, then finished, by the command line's writer
/// (`isomarch::movie`): whole, or not at all.
#[pyclass(module = "isomarch._native")]
struct NativeMovie {
    writer: Option<isomarch::movie::MovieWriter>,
    size: (u32, u32),
}

#[pymethods]
impl NativeMovie {
    /// Checks the movie (its format, its size, ffmpeg for MP4 and WebM) and
    /// starts it.
    #[new]
    fn new(path: PathBuf, fps: f64, quality: &str, width: u32, height: u32) -> PyResult<Self> {
        use clap::ValueEnum as _;
        let quality = isomarch::movie::Quality::from_str(quality, true)
            .map_err(|_| IsomarchError::new_err(format!("quality {quality:?}: one of highest, higher, high, good, medium, fair, low")))?;
        let spec = isomarch::movie::MovieSpec::new(&path, fps, quality, (width, height))
            .map_err(raise)?
            .ok_or_else(|| IsomarchError::new_err(format!("{}: a movie is .mp4, .webm or .gif", path.display())))?;
        let writer = isomarch::movie::MovieWriter::create(&spec, (width, height)).map_err(raise)?;
        Ok(NativeMovie { writer: Some(writer), size: (width, height) })
    }

    /// Appends a frame: RGBA uint8, the movie's size (alpha dropped).
    fn push(&mut self, py: Python<'_>, rgba: PyReadonlyArray1<'_, u8>) -> PyResult<()> {
        let (width, height) = self.size;
        let rgba = rgba.as_array();
        if rgba.len() != (width * height * 4) as usize {
            return Err(IsomarchError::new_err(format!("{} bytes for a {width}x{height} RGBA frame", rgba.len())));
        }
        let rgb: Vec<u8> = rgba.iter().enumerate().filter(|(i, _)| i % 4 != 3).map(|(_, v)| *v).collect();
        let img = image::RgbImage::from_raw(width, height, rgb).ok_or_else(|| IsomarchError::new_err("frame size"))?;
        let writer = self.writer.as_mut().ok_or_else(|| IsomarchError::new_err("the movie is already closed"))?;
        py.detach(|| writer.push(&img)).map_err(raise)
    }

    /// Ends the movie and renames it into place.
    fn finish(&mut self, py: Python<'_>) -> PyResult<()> {
        let writer = self.writer.take().ok_or_else(|| IsomarchError::new_err("the movie is already closed"))?;
        py.detach(|| writer.finish()).map(drop).map_err(raise)
    }

    /// Drops an unfinished movie: its encoder stopped, its temporary file
    /// removed.
    fn abandon(&mut self) {
        self.writer = None;
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("IsomarchError", m.py().get_type::<IsomarchError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("DEFAULT_SEED", isomarch::bench::DEFAULT_SEED)?;
    m.add_class::<NativeMoleculeOptions>()?;
    m.add_class::<NativeScene>()?;
    m.add_class::<NativeRenderer>()?;
    m.add_class::<NativeTrajectory>()?;
    m.add_class::<NativeFrames>()?;
    m.add_class::<NativeMovie>()?;
    m.add_function(wrap_pyfunction!(trajectory_open, m)?)?;
    m.add_function(wrap_pyfunction!(scene_load, m)?)?;
    m.add_function(wrap_pyfunction!(scene_from_molecule, m)?)?;
    m.add_function(wrap_pyfunction!(scene_from_atoms, m)?)?;
    m.add_function(wrap_pyfunction!(element_radius, m)?)?;
    m.add_function(wrap_pyfunction!(element_color, m)?)?;
    m.add_function(wrap_pyfunction!(png_bytes, m)?)?;
    Ok(())
}
