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
use isomarch::molecule::build::{atoms_scene, load_scene};
use isomarch::molecule::{Coloring, MoleculeOptions, elements};
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
}

fn molecule_options(
    hydrogens: bool,
    sharpness: f64,
    radius_scale: f64,
    iso: f64,
    coloring: &str,
    turntable: Option<f64>,
) -> PyResult<MoleculeOptions> {
    let coloring = match coloring {
        "element" => Coloring::Element,
        "chain" => Coloring::Chain,
        "none" => Coloring::None,
        other => return Err(IsomarchError::new_err(format!("coloring must be \"element\", \"chain\" or \"none\", got {other:?}"))),
    };
    let o = MoleculeOptions { hydrogens, sharpness, radius_scale, iso, coloring, turntable };
    o.check().map_err(raise)?;
    Ok(o)
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
#[allow(clippy::too_many_arguments)]
fn scene_from_molecule(
    py: Python<'_>,
    path: PathBuf,
    hydrogens: bool,
    sharpness: f64,
    radius_scale: f64,
    iso: f64,
    coloring: &str,
    turntable: Option<f64>,
) -> PyResult<(NativeScene, Vec<String>, String)> {
    let o = molecule_options(hydrogens, sharpness, radius_scale, iso, coloring, turntable)?;
    let (scene, notes) = py.detach(|| load_scene(&path, &o)).map_err(raise)?;
    Ok((NativeScene { scene }, notes.warnings, notes.summary))
}

#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn scene_from_atoms(
    positions: PyReadonlyArray2<'_, f64>,
    radii: PyReadonlyArray1<'_, f64>,
    colors: Option<PyReadonlyArray2<'_, f64>>,
    sharpness: f64,
    radius_scale: f64,
    iso: f64,
    turntable: Option<f64>,
) -> PyResult<NativeScene> {
    let o = molecule_options(false, sharpness, radius_scale, iso, "element", turntable)?;
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
    let rgb: Vec<u8> = rgba.iter().enumerate().filter(|(i, _)| i % 4 != 3).map(|(_, v)| *v).collect();
    let img = image::RgbImage::from_raw(width, height, rgb).ok_or_else(|| IsomarchError::new_err("image size"))?;
    let bytes = isomarch::output::png_bytes(&img).map_err(raise)?;
    Ok(PyBytes::new(py, &bytes))
}

/// Marchers by name; at least one.
fn parse_methods(names: &[String]) -> PyResult<Vec<Method>> {
    if names.is_empty() {
        return Err(IsomarchError::new_err("no method given"));
    }
    names.iter().map(|m| m.parse::<Method>().map_err(|e| IsomarchError::new_err(format!("invalid method {m:?}: {e}")))).collect()
}

/// A Vulkan context kept between renders.
#[pyclass(module = "isomarch._native")]
struct NativeRenderer {
    ctx: Arc<Context>,
    timeout: Duration,
}

#[pymethods]
impl NativeRenderer {
    #[new]
    #[pyo3(signature = (device=None, timeout=600.0))]
    fn new(py: Python<'_>, device: Option<String>, timeout: f64) -> PyResult<Self> {
        if !(timeout.is_finite() && timeout > 0.0) {
            return Err(IsomarchError::new_err(format!("--timeout must be a positive number of seconds, got {timeout}")));
        }
        let ctx = py.detach(|| Context::new(&ContextOptions { validation: false, device, present: None })).map_err(raise)?;
        Ok(NativeRenderer { ctx, timeout: Duration::from_secs_f64(timeout) })
    }

    #[getter]
    fn device(&self) -> String {
        self.ctx.info.name.clone()
    }

    /// Renders `scene` at `time`: a dict of flat arrays (rgba uint8, depth
    /// float32 with inf on misses, steps uint32, normals float32) and the
    /// frame's statistics.
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        scene: &NativeScene,
        width: u32,
        height: u32,
        method: Option<&str>,
        time: f64,
        samples: Option<u32>,
    ) -> PyResult<Bound<'py, PyDict>> {
        if !(1..=16384).contains(&width) || !(1..=16384).contains(&height) {
            return Err(IsomarchError::new_err(format!("expected a size with each side in 1..=16384, got {width}x{height}")));
        }
        if !time.is_finite() {
            return Err(IsomarchError::new_err(format!("--time must be a finite number of seconds, got {time}")));
        }
        let mut posed = scene.scene.at_time(time);
        if let Some(m) = method {
            posed.marching.method = m.parse::<Method>().map_err(|e| IsomarchError::new_err(format!("invalid method {m:?}: {e}")))?;
        }
        let method = posed.marching.method;
        let mut job = RenderJob::new(posed, method, (width, height), PathBuf::new(), self.timeout);
        if let Some(n) = samples {
            job.samples = isomarch::render::offscreen::check_samples(n).map_err(raise)?;
        }
        let ctx = Arc::clone(&self.ctx);
        let isomarch::render::offscreen::FrameReport { frame, march: stats, .. } =
            py.detach(move || render_frame_indexed(&ctx, &job)).map_err(raise)?;
        let shaded = frame.shaded();
        let mut rgba = Vec::with_capacity(frame.pixels.len() * 4);
        for p in shaded.pixels() {
            rgba.extend_from_slice(&[p[0], p[1], p[2], 255]);
        }
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
        let s = PyDict::new(py);
        s.set_item("rays", stats.rays)?;
        s.set_item("hit_rate", stats.hit_rate)?;
        s.set_item("steps_per_ray", stats.steps_per_ray)?;
        s.set_item("evals_per_ray", stats.evals_per_ray)?;
        s.set_item("refine_per_ray", stats.refine_per_ray)?;
        s.set_item("turns_per_ray", stats.turns_per_ray)?;
        s.set_item("visits_per_ray", stats.visits_per_ray)?;
        s.set_item("out_of_steps_rate", stats.out_of_steps_rate)?;
        s.set_item("max_steps_taken", stats.max_steps_taken)?;
        s.set_item("gpu_ms", stats.gpu_ms)?;
        s.set_item("ns_per_ray", stats.ns_per_ray)?;
        // The shadow and occlusion rays, as `render --stats` writes them.
        let any_hit = match stats.any_hit {
            Some(a) => {
                let d = PyDict::new(py);
                d.set_item("shadow_rays", a.shadow_rays)?;
                d.set_item("shadow_steps_per_ray", a.shadow_steps_per_ray)?;
                d.set_item("ao_rays", a.ao_rays)?;
                d.set_item("ao_steps_per_ray", a.ao_steps_per_ray)?;
                d.set_item("gpu_ms", a.gpu_ms)?;
                Some(d)
            }
            None => None,
        };
        s.set_item("any_hit", any_hit)?;
        out.set_item("stats", s)?;
        Ok(out)
    }

    /// `isomarch bench`: the protocol's rays (or a sample of the camera's
    /// pixel rays), every method against the f64 reference; the report as
    /// the JSON `bench --json` writes.
    #[allow(clippy::too_many_arguments)]
    fn bench(
        &self,
        py: Python<'_>,
        scene: &NativeScene,
        methods: Vec<String>,
        rays: usize,
        seed: u64,
        repeats: usize,
        camera: Option<(u32, u32)>,
        any_hit: bool,
    ) -> PyResult<String> {
        let methods = parse_methods(&methods)?;
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
    #[allow(clippy::too_many_arguments)]
    fn tradeoff(
        &self,
        py: Python<'_>,
        scene: &NativeScene,
        methods: Vec<String>,
        min_steps: Vec<f64>,
        max_steps: Vec<u32>,
        rays: usize,
        seed: u64,
    ) -> PyResult<String> {
        let sweep = isomarch::tradeoff::Sweep { methods: parse_methods(&methods)?, min_steps, max_steps, rays, seed, any_hit: false };
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
}

#[pymethods]
impl NativeTrajectory {
    fn __len__(&self) -> usize {
        self.len
    }

    fn source(&self) -> String {
        self.source.clone()
    }

    /// Frame `k`'s scene and simulation time (ps, or None).
    fn scene(&self, py: Python<'_>, k: usize) -> PyResult<(NativeScene, Option<f64>)> {
        let stager = &self.stager;
        let (scene, time) = py.detach(|| stager.lock().map_err(|_| anyhow::anyhow!("the trajectory's lock is poisoned"))?.scene(k)).map_err(raise)?;
        Ok((NativeScene { scene }, time))
    }
}

#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (topology, trajectory, framing, hydrogens, sharpness, radius_scale, iso, coloring, turntable))]
fn trajectory_open(
    py: Python<'_>,
    topology: PathBuf,
    trajectory: Option<PathBuf>,
    framing: &str,
    hydrogens: bool,
    sharpness: f64,
    radius_scale: f64,
    iso: f64,
    coloring: &str,
    turntable: Option<f64>,
) -> PyResult<(NativeTrajectory, Vec<String>, String)> {
    use isomarch::molecule::playback::{FramingRule, Stager};
    let o = molecule_options(hydrogens, sharpness, radius_scale, iso, coloring, turntable)?;
    let rule = match framing {
        "first" => FramingRule::First,
        "all" => FramingRule::All,
        other => return Err(IsomarchError::new_err(format!("framing must be \"first\" or \"all\", got {other:?}"))),
    };
    let (stager, notes) = py
        .detach(|| -> anyhow::Result<_> {
            let t = isomarch::molecule::trajectory::open(&topology, trajectory.as_deref())?;
            let mut stager = Stager::new(t, o, rule)?;
            let (_, _, notes) = stager.text(0)?;
            Ok((stager, notes))
        })
        .map_err(raise)?;
    let (len, source) = (stager.len(), stager.trajectory.source.clone());
    Ok((NativeTrajectory { stager: std::sync::Mutex::new(stager), len, source }, notes.warnings, notes.summary))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("IsomarchError", m.py().get_type::<IsomarchError>())?;
    m.add_class::<NativeScene>()?;
    m.add_class::<NativeRenderer>()?;
    m.add_class::<NativeTrajectory>()?;
    m.add_function(wrap_pyfunction!(trajectory_open, m)?)?;
    m.add_function(wrap_pyfunction!(scene_load, m)?)?;
    m.add_function(wrap_pyfunction!(scene_from_molecule, m)?)?;
    m.add_function(wrap_pyfunction!(scene_from_atoms, m)?)?;
    m.add_function(wrap_pyfunction!(element_radius, m)?)?;
    m.add_function(wrap_pyfunction!(element_color, m)?)?;
    m.add_function(wrap_pyfunction!(png_bytes, m)?)?;
    Ok(())
}
