//! Fixtures shared by the integration tests.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Arc, OnceLock};

use glam::DVec3;
use isomarch::Method;
use isomarch::gpu::{Context, ContextOptions};
use isomarch::scene::{Aabb, Camera, Kernel, Light, Marching, Primitive, Scene};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// The GPU with validation on, one for the whole test binary: every test
/// shares its device and so its pipelines (made once per recipe, where
/// each test's own device made them again: most of the binary's time on
/// lavapipe went to making pipelines, in the driver and the validation
/// layer). Fails (never skips) when Vulkan is missing.
pub fn gpu() -> Arc<Context> {
    static SHARED: OnceLock<Arc<Context>> = OnceLock::new();
    Arc::clone(SHARED.get_or_init(own_gpu))
}

/// A device of the test's own, with validation on: for a test that
/// provokes validation messages on purpose, which would fail every test
/// sharing [`gpu`] after it.
pub fn own_gpu() -> Arc<Context> {
    match Context::new(&ContextOptions { validation: true, ..Default::default() }) {
        Ok(ctx) => ctx,
        Err(e) => {
            panic!("these tests need Vulkan with the validation layer (run them through `bash scripts/test.sh`, which installs lavapipe): {e:#}")
        }
    }
}

/// Fails the test on any validation message. On the shared device a
/// message may be another test's: each names the thread (the test) whose
/// call the layer caught.
pub fn assert_no_validation(ctx: &Context) {
    let messages = ctx.validation_messages();
    assert!(messages.is_empty(), "validation messages:\n{}", messages.join("\n"));
}

pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_isomarch"))
}

/// The isomarch binary with `args`, to run once:
/// `isomarch(["render", ...]).arg(path).env(..).current_dir(..)`, then
/// - `.ok()`: it succeeds (else the test fails showing the command, its
///   stderr and stdout); its output;
/// - `.fails_in_one_line()`: a refusal, exit status 1 (not success, not a
///   usage error's 2, not a panic's 101), and stderr exactly one non-empty
///   line; that line;
/// - `.fails()`: it fails, without a panic; its stderr;
/// - `.output()` or `.spawn()`, for tests that look at the rest themselves.
pub fn isomarch<I, S>(args: I) -> Isomarch
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    Isomarch { command: Command::new(bin()) }.args(args)
}

/// A run of the binary being set up: see [`isomarch`].
#[must_use = "run it: .ok(), .fails_in_one_line(), .fails(), .output() or .spawn()"]
pub struct Isomarch {
    command: Command,
}

impl Isomarch {
    pub fn arg(mut self, arg: impl AsRef<OsStr>) -> Self {
        self.command.arg(arg);
        self
    }

    pub fn args<I, S>(mut self, args: I) -> Self
    where
        I: IntoIterator<Item = S>,
        S: AsRef<OsStr>,
    {
        self.command.args(args);
        self
    }

    pub fn env(mut self, key: impl AsRef<OsStr>, value: impl AsRef<OsStr>) -> Self {
        self.command.env(key, value);
        self
    }

    pub fn envs<I, K, V>(mut self, vars: I) -> Self
    where
        I: IntoIterator<Item = (K, V)>,
        K: AsRef<OsStr>,
        V: AsRef<OsStr>,
    {
        self.command.envs(vars);
        self
    }

    pub fn env_remove(mut self, key: impl AsRef<OsStr>) -> Self {
        self.command.env_remove(key);
        self
    }

    pub fn current_dir(mut self, dir: impl AsRef<Path>) -> Self {
        self.command.current_dir(dir);
        self
    }

    pub fn stdin(mut self, cfg: impl Into<Stdio>) -> Self {
        self.command.stdin(cfg);
        self
    }

    pub fn stdout(mut self, cfg: impl Into<Stdio>) -> Self {
        self.command.stdout(cfg);
        self
    }

    pub fn stderr(mut self, cfg: impl Into<Stdio>) -> Self {
        self.command.stderr(cfg);
        self
    }

    /// The command as the failures show it: its folder and environment
    /// when set, then `isomarch` and its arguments.
    fn shown(&self) -> String {
        let mut words = Vec::new();
        if let Some(dir) = self.command.get_current_dir() {
            words.push(format!("(in {})", dir.display()));
        }
        for (key, value) in self.command.get_envs() {
            let key = key.to_string_lossy();
            words.push(match value {
                Some(value) => format!("{key}={}", value.to_string_lossy()),
                None => format!("(without {key})"),
            });
        }
        words.push("isomarch".to_string());
        for arg in self.command.get_args() {
            let arg = arg.to_string_lossy();
            let plain = !arg.is_empty() && !arg.contains(|c: char| c.is_whitespace() || c == '"' || c == '\'');
            words.push(if plain { arg.into_owned() } else { format!("{arg:?}") });
        }
        words.join(" ")
    }

    /// Runs it to the end; its output, whatever its exit status.
    pub fn output(mut self) -> Output {
        let shown = self.shown();
        self.command.output().unwrap_or_else(|e| panic!("running {shown}: {e}"))
    }

    /// Starts it.
    pub fn spawn(mut self) -> Child {
        let shown = self.shown();
        self.command.spawn().unwrap_or_else(|e| panic!("starting {shown}: {e}"))
    }

    /// Runs it and fails the test unless it succeeds; its output.
    pub fn ok(self) -> Output {
        let shown = self.shown();
        let out = self.output();
        if !out.status.success() {
            let stdout = String::from_utf8_lossy(&out.stdout);
            let stdout = if stdout.is_empty() { String::new() } else { format!("\nstdout:\n{stdout}") };
            panic!("{shown} failed ({}):\n{}{stdout}", out.status, String::from_utf8_lossy(&out.stderr));
        }
        out
    }

    /// Runs it and fails the test unless it fails without a panic (any
    /// exit status but 0 and 101); its stderr.
    pub fn fails(self) -> String {
        let shown = self.shown();
        let out = self.output();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(!out.status.success(), "{shown} was accepted:\n{stderr}");
        assert_ne!(out.status.code(), Some(101), "{shown} panicked:\n{stderr}");
        stderr
    }

    /// Runs it and fails the test unless it is refused: exit status 1 (a
    /// usage error exits 2, a panic 101) and stderr exactly one non-empty
    /// line; that line.
    pub fn fails_in_one_line(self) -> String {
        self.fails_in_one_line_and_stdout().0
    }

    /// [`Isomarch::fails_in_one_line`], and what it wrote to stdout.
    pub fn fails_in_one_line_and_stdout(self) -> (String, String) {
        let shown = self.shown();
        let out = self.output();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{shown} was accepted:\n{stderr}");
        assert_eq!(out.status.code(), Some(1), "{shown}: exit status {}, not a refusal's 1:\n{stderr}", out.status);
        let lines: Vec<&str> = stderr.lines().collect();
        assert!(lines.len() == 1 && !lines[0].trim().is_empty(), "{shown}: stderr is not one line:\n{stderr}");
        (lines[0].to_string(), String::from_utf8_lossy(&out.stdout).into_owned())
    }
}

/// Runs the binary with `args`, validation on and a generous deadline;
/// fails the test when it fails.
pub fn run_ok(args: &[&str]) -> Output {
    isomarch(args).args(["--validation", "--timeout", "300"]).ok()
}

/// Whether a test rewrites its record (`VAR=1`) rather than checking it.
pub fn rewriting(var: &str) -> bool {
    std::env::var(var).is_ok_and(|v| v == "1")
}

/// A record of measurements kept in the repository (a CSV under
/// tests/data) that a test checks its measurements against. Under
/// `var=1` (see [`rewriting`]) it writes `header` (its comment lines and
/// its column line, each ending in a newline) and then `rows` (one line
/// each, without the newline) to `path`, and fails the test, so that a run
/// that rewrites a record never passes for one that checked it. Otherwise
/// the record's text, whose column line must be `header`'s.
pub fn record(path: &Path, var: &str, header: &str, rows: &[String]) -> String {
    if rewriting(var) {
        let mut text = header.to_string();
        for row in rows {
            text.push_str(row);
            text.push('\n');
        }
        std::fs::write(path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        panic!("{} rewritten ({var}=1): look at the diff, then run again without it to check", path.display());
    }
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e} (create it with {var}=1)", path.display()));
    let columns = |t: &str| t.lines().find(|l| !l.starts_with('#') && !l.trim().is_empty()).map(str::to_string);
    assert_eq!(columns(text.as_str()), columns(header), "{}: not the columns this test writes (rewrite it with {var}=1)", path.display());
    text
}

/// The rows of a record's text, each split at its commas: the lines that
/// are not comments (`#`), not blank and not the column line (the first of
/// the others). Every row has as many fields as the column line.
pub fn record_rows<'a>(text: &'a str, path: &Path) -> Vec<Vec<&'a str>> {
    let mut lines = text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let columns = lines.next().unwrap_or_else(|| panic!("{}: no column line", path.display())).split(',').count();
    lines
        .map(|line| {
            let fields: Vec<&str> = line.split(',').collect();
            assert_eq!(fields.len(), columns, "{}: bad row {line:?}", path.display());
            fields
        })
        .collect()
}

/// A JSON file the binary wrote.
pub fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A fresh, empty scratch folder for one test.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isomarch-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub fn compact(center: DVec3, radius: f64) -> Primitive {
    Primitive::Point { center, kernel: Kernel::Compact { radius, weight: 1.0 } }
}

/// A Gaussian with the default weight `iso·e^s`.
pub fn gaussian(center: DVec3, r: f64, s: f64, iso: f64) -> Primitive {
    Primitive::Point { center, kernel: Kernel::Gaussian { r, s, weight: iso * s.exp() } }
}

/// A scene around `groups`, bounds from the supports (as the loader does),
/// camera looking down -z at the origin.
pub fn scene(groups: Vec<Vec<Primitive>>, iso: f64, method: Method, min_step: f64) -> Scene {
    let mut s = Scene {
        source: "test scene".into(),
        camera: Camera {
            eye: DVec3::new(0.0, 0.0, 10.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            fov_y_deg: 40.0,
            projection: Default::default(),
            clip: Default::default(),
            width: 64,
            height: 64,
            samples: 1,
        },
        background: DVec3::splat(0.05),
        ambient: DVec3::splat(0.1),
        surface: DVec3::new(0.8, 0.5, 0.3),
        lights: vec![Light { direction: DVec3::new(0.4, 0.8, 0.45).normalize(), color: DVec3::ONE }],
        iso,
        transparency: None,
        shadows: false,
        ao: None,
        marching: Marching { method, min_step, max_steps: 100_000, growth: None, quad: Default::default(), refine: Default::default() },
        groups,
        bounds: Aabb::empty(),
        bounds_explicit: false,
        animation: Default::default(),
        colors: None,
    };
    s.marching.min_step = min_step;
    s.bounds = s.support_bounds();
    s
}

/// A seeded random scene: 2 to 3 groups when `max_of_groups`, else one;
/// 3 to 8 blobs each, compact and Gaussian mixed, in a 6-unit cube.
pub fn random_scene(seed: u64, max_of_groups: bool, method: Method) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let iso = 0.5;
    let groups = if max_of_groups { rng.random_range(2..=3) } else { 1 };
    let groups = (0..groups)
        .map(|_| {
            (0..rng.random_range(3..=8))
                .map(|_| {
                    let c = DVec3::new(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0));
                    if rng.random_bool(0.5) {
                        compact(c, rng.random_range(1.0..2.5))
                    } else {
                        gaussian(c, rng.random_range(0.6..1.4), rng.random_range(1.0..4.0), iso)
                    }
                })
                .collect()
        })
        .collect();
    let mut s = scene(groups, iso, method, 1.0);
    s.marching.min_step = 1e-4 * s.min_radius();
    s
}

/// A plane slab (normal +y through the origin, support radius 1) with a
/// compact and a Gaussian blob above it, like fig16: one group, or the
/// slab and the blobs in two groups combined by max. Bounds are explicit
/// (the slab is infinite).
pub fn plane_scene(max_of_groups: bool) -> Scene {
    let slab = Primitive::Plane { normal: DVec3::Y, offset: 0.0, radius: 1.0, weight: 1.0 };
    let blobs = vec![compact(DVec3::new(0.0, 1.5, 0.0), 2.0), gaussian(DVec3::new(1.5, 1.0, 0.5), 1.0, 2.0, 0.5)];
    let groups = if max_of_groups { vec![vec![slab], blobs] } else { vec![[vec![slab], blobs].concat()] };
    let mut s = scene(groups, 0.5, Method::QuadraticTaylor, 1e-3);
    s.bounds = Aabb { min: DVec3::new(-4.0, -1.5, -4.0), max: DVec3::new(4.0, 4.0, 4.0) };
    s.bounds_explicit = true;
    s
}

/// `n` control points `(position, outward normal)` on the ellipsoid of
/// semi-axes `axes` about `center`, at directions uniform on the sphere.
pub fn ellipsoid_points(rng: &mut Pcg64Mcg, n: usize, center: DVec3, axes: DVec3) -> Vec<(DVec3, DVec3)> {
    (0..n)
        .map(|_| {
            let z: f64 = rng.random_range(-1.0..1.0);
            let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let d = DVec3::new((1.0 - z * z).sqrt() * phi.cos(), (1.0 - z * z).sqrt() * phi.sin(), z);
            let p = d / (d / axes).length();
            (center + p, (p / (axes * axes)).normalize())
        })
        .collect()
}

/// RON for an HRBF through `points`.
pub fn hrbf_ron(points: &[(DVec3, DVec3)]) -> String {
    let v = |p: DVec3| format!("({}, {}, {})", p.x, p.y, p.z);
    let list: Vec<String> = points.iter().map(|&(p, n)| format!("({}, {})", v(p), v(n))).collect();
    format!("Hrbf(points: [{}])", list.join(", "))
}

/// A seeded random HRBF scene: 6 to 12 points on a random ellipsoid, in a
/// group with a compact blob near its surface (they blend by sum); with
/// `max_of_groups`, a second group of two blobs beside it (max). Built
/// through the scene file, so the fit and the box are the loader's.
pub fn random_hrbf_scene(seed: u64, max_of_groups: bool, method: Method) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let axes = DVec3::new(rng.random_range(1.0..2.0), rng.random_range(1.0..2.0), rng.random_range(1.0..2.0));
    let n = rng.random_range(6..=12);
    let points = ellipsoid_points(&mut rng, n, DVec3::ZERO, axes);
    let blob = |c: DVec3, r: f64| format!("Point(center: ({}, {}, {}), kernel: Compact(radius: {r}))", c.x, c.y, c.z);
    let near = points[0].0 + 0.3 * points[0].1;
    let mut groups = format!("(primitives: [{}, {}])", hrbf_ron(&points), blob(near, 1.0));
    if max_of_groups {
        groups += &format!(", (primitives: [{}, {}])", blob(DVec3::new(axes.x + 0.5, 0.3, 0.0), 1.5), blob(DVec3::new(axes.x + 1.2, -0.4, 0.5), 1.2));
    }
    let text = format!(
        "Scene(camera: (eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0), resolution: (64, 64)), iso: 0.5, \
         marching: (method: \"{method}\", max_steps: 100000), groups: [{groups}])"
    );
    let mut s = Scene::parse(&text, &format!("random HRBF scene {seed}")).unwrap();
    s.marching.min_step = 1e-4 * s.min_radius();
    s
}

/// A channel of an EXR image's first layer, row-major, top row first.
pub fn exr_channel(exr: &exr::prelude::FlatImage, name: &str) -> Vec<f32> {
    let c = exr.layer_data[0].channel_data.list.iter().find(|c| c.name.to_string() == name).unwrap_or_else(|| panic!("no channel {name}"));
    c.sample_data.values_as_f32().collect()
}
