//! Batch frames: frame ranges, output name patterns, and shards of a range
//! for array jobs (SLURM, Kubernetes Indexed Jobs).

use std::path::PathBuf;
use std::str::FromStr;

use anyhow::{Result, bail};

pub mod merge;

/// The header of a batch's per-frame statistics CSV. `saved_from`,
/// `saved_to` and `fraction` say which saved frames of a trajectory a
/// frame lies between and how far from the first (`--interpolate`; k, k
/// and 0 for saved frame k; empty for a scene).
/// The last column, `scene`, is the scene or molecule file the frame shows:
/// a batch appends only to a CSV of its own scene ([`check_csv`]).
pub const CSV_HEADER: &str = "frame,time_s,file,width,height,method,steps_per_ray,evals_per_ray,hit_rate,gpu_ms,wall_ms,saved_from,saved_to,fraction,index_build_ms,shadow_steps_per_ray,ao_steps_per_ray,any_hit_gpu_ms,scene";

/// A CSV field in double quotes, its quotes doubled.
fn quoted(field: &str) -> String {
    format!("\"{}\"", field.replace('"', "\"\""))
}

/// The last field of a CSV row when it is quoted, as [`quoted`] writes
/// the `scene` column; `None` otherwise.
fn last_quoted_field(row: &str) -> Option<String> {
    let body = row.strip_suffix('"')?;
    // Walk back over doubled quotes to the lone quote that opens the field.
    let bytes = body.as_bytes();
    let mut i = bytes.len();
    while i > 0 {
        if bytes[i - 1] == b'"' {
            if i >= 2 && bytes[i - 2] == b'"' {
                i -= 2;
                continue;
            }
            return Some(body[i..].replace("\"\"", "\""));
        }
        i -= 1;
    }
    None
}

/// Checks that a batch of `scene` may append to the statistics CSV whose
/// text is `text`: its header is this version's, and every row is a frame
/// of the same scene. Two batches of different scenes sharing the default
/// `frames.csv` would list the same frame numbers twice with nothing to
/// tell them apart.
pub fn check_csv(csv: &std::path::Path, text: &str, scene: &str) -> Result<()> {
    let mut lines = text.lines();
    let Some(header) = lines.next() else { return Ok(()) };
    if header != CSV_HEADER {
        bail!(
            "{}: not this version's batch statistics (its header differs), so this batch's rows are not appended to it: name another file with --csv, or remove it",
            csv.display()
        );
    }
    for (i, row) in lines.enumerate().filter(|(_, r)| !r.trim().is_empty()) {
        let theirs = last_quoted_field(row);
        if theirs.as_deref() != Some(scene) {
            bail!(
                "{}:{}: lists a frame of {}, and this batch renders {scene}: give this batch its own statistics file with --csv (or remove {} first)",
                csv.display(),
                i + 2,
                theirs.as_deref().unwrap_or("another scene"),
                csv.display()
            );
        }
    }
    Ok(())
}

/// Frames `start..end` (end excluded), parsed from Rust range syntax:
/// `a..b` excludes b, `a..=b` includes it, a lone `n` is one frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    pub start: u64,
    pub end: u64,
}

impl FromStr for FrameRange {
    type Err = String;
    fn from_str(s: &str) -> Result<FrameRange, String> {
        let num = |v: &str| v.trim().parse::<u64>().map_err(|_| format!("expected a frame range such as 0..100 or 0..=99, got {s:?}"));
        let (start, end) = if let Some((a, b)) = s.split_once("..=") {
            (num(a)?, num(b)?.checked_add(1).ok_or_else(|| format!("frame range {s:?} is too large"))?)
        } else if let Some((a, b)) = s.split_once("..") {
            (num(a)?, num(b)?)
        } else {
            let n = num(s)?;
            (n, n + 1)
        };
        if end <= start {
            return Err(format!("frame range {s:?} is empty"));
        }
        Ok(FrameRange { start, end })
    }
}

/// The output path of `frame`: the first run of `#` in `pattern` becomes
/// the frame number, zero-padded to the run's length (`frame_####.png`).
pub fn frame_path(pattern: &str, frame: u64) -> Result<PathBuf> {
    let Some(at) = pattern.find('#') else {
        bail!("-o {pattern:?} has no #### for the frame number (e.g. out/frame_####.png)");
    };
    let width = pattern[at..].chars().take_while(|&c| c == '#').count();
    Ok(PathBuf::from(format!("{}{frame:0width$}{}", &pattern[..at], &pattern[at + width..])))
}

/// The frames on disk that `pattern` names ([`frame_path`]'s files, which
/// shards wrote), in order: those of `range`, else every number found
/// from the lowest to the highest. A gap is refused in one line naming the
/// first missing frame's file; so is a pattern that names no file.
pub fn frames_on_disk(pattern: &str, range: Option<FrameRange>) -> Result<Vec<(u64, PathBuf)>> {
    let Some(at) = pattern.find('#') else {
        bail!("{pattern:?} has no #### for the frame number (e.g. out/frame_####.png)");
    };
    let width = pattern[at..].chars().take_while(|&c| c == '#').count();
    let (head, tail) = (&pattern[..at], &pattern[at + width..]);
    if tail.contains(['/', '#']) {
        bail!("{pattern:?}: the frame number must be in the file's name, once");
    }
    let (dir, prefix) = match head.rfind('/') {
        Some(i) => (&head[..=i], &head[i + 1..]),
        None => ("", head),
    };
    let folder = if dir.is_empty() { std::path::Path::new(".") } else { std::path::Path::new(dir) };
    let entries = std::fs::read_dir(folder).map_err(|e| anyhow::anyhow!("{}: {e}", folder.display()))?;
    let mut found = std::collections::BTreeSet::new();
    for entry in entries {
        let name = entry?.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some(digits) = name.strip_prefix(prefix).and_then(|rest| rest.strip_suffix(tail)) else { continue };
        // frame_path pads to the run's width and writes wider numbers whole.
        if digits.len() >= width
            && digits.bytes().all(|b| b.is_ascii_digit())
            && (digits.len() == width || !digits.starts_with('0'))
            && let Ok(n) = digits.parse::<u64>()
        {
            found.insert(n);
        }
    }
    let range = match range {
        Some(r) => r,
        None => match (found.first(), found.last()) {
            (Some(&a), Some(&b)) => FrameRange { start: a, end: b + 1 },
            _ => bail!("{pattern}: no frame on disk ({} holds no file that the pattern names)", folder.display()),
        },
    };
    if let Some(missing) = (range.start..range.end).find(|f| !found.contains(f)) {
        let present = found.range(range.start..range.end).count();
        bail!(
            "{}: missing: frame {missing} is the first of frames {}..{} not on disk ({present} of {} are): render it (--frames with --skip-existing) before encoding",
            frame_path(pattern, missing)?.display(),
            range.start,
            range.end,
            range.end - range.start
        );
    }
    (range.start..range.end).map(|f| Ok((f, frame_path(pattern, f)?))).collect()
}

/// Shard `index` of `count`: the frames whose number modulo `count` is
/// `index`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Shard {
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    fn new(index: u64, count: u64, what: &str) -> Result<Shard> {
        if count == 0 || index >= count {
            bail!("{what}: shard {index} of {count} does not exist (shards are 0 to count - 1)");
        }
        Ok(Shard { index, count })
    }

    pub fn contains(&self, frame: u64) -> bool {
        frame % self.count == self.index
    }

    /// The shard from `--shard I/N` when given; otherwise from the
    /// scheduler's environment: a SLURM array (`SLURM_ARRAY_TASK_ID -
    /// SLURM_ARRAY_TASK_MIN` (divided by `SLURM_ARRAY_TASK_STEP` when set)
    /// of `SLURM_ARRAY_TASK_COUNT`) or a Kubernetes
    /// Indexed Job (`JOB_COMPLETION_INDEX` of `shard_count`); otherwise
    /// every frame.
    pub fn resolve(explicit: Option<&str>, shard_count: Option<u64>, env: impl Fn(&str) -> Option<String>) -> Result<Shard> {
        let parse = |name: &str, v: &str| v.trim().parse::<u64>().map_err(|_| anyhow::anyhow!("{name}={v:?} is not a number"));
        if let Some(s) = explicit {
            let Some((i, n)) = s.split_once('/') else {
                bail!("--shard {s:?}: expected I/N, e.g. 0/4");
            };
            return Shard::new(parse("--shard", i)?, parse("--shard", n)?, "--shard");
        }
        if let Some(id) = env("SLURM_ARRAY_TASK_ID") {
            let id = parse("SLURM_ARRAY_TASK_ID", &id)?;
            let min = env("SLURM_ARRAY_TASK_MIN").map(|v| parse("SLURM_ARRAY_TASK_MIN", &v)).transpose()?.unwrap_or(0);
            let Some(count) = env("SLURM_ARRAY_TASK_COUNT") else {
                bail!("SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not");
            };
            let count = parse("SLURM_ARRAY_TASK_COUNT", &count)?;
            let step = env("SLURM_ARRAY_TASK_STEP").map(|v| parse("SLURM_ARRAY_TASK_STEP", &v)).transpose()?.unwrap_or(1).max(1);
            let Some(index) = id.checked_sub(min).map(|d| d / step) else {
                bail!("SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}");
            };
            if count == 0 || index >= count {
                bail!(
                    "SLURM array task {id} would be shard {index} of {count}, which does not exist: the array ids must be consecutive or evenly stepped (--array=0-7 or 0-14:2), not a list such as 0,5"
                );
            }
            return Shard::new(index, count, "SLURM array");
        }
        if let Some(index) = env("JOB_COMPLETION_INDEX") {
            let index = parse("JOB_COMPLETION_INDEX", &index)?;
            let Some(count) = shard_count else {
                bail!("JOB_COMPLETION_INDEX is set: give the job's completions as --shard-count N");
            };
            return Shard::new(index, count, "Kubernetes Indexed Job");
        }
        if shard_count.is_some() {
            bail!("--shard-count needs JOB_COMPLETION_INDEX (a Kubernetes Indexed Job); otherwise use --shard I/N");
        }
        Ok(Shard::ALL)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_follow_rust_syntax() {
        assert_eq!("0..100".parse(), Ok(FrameRange { start: 0, end: 100 }));
        assert_eq!("5..=9".parse(), Ok(FrameRange { start: 5, end: 10 }));
        assert_eq!("7".parse(), Ok(FrameRange { start: 7, end: 8 }));
        assert!("3..3".parse::<FrameRange>().is_err());
        assert!("a..b".parse::<FrameRange>().is_err());
    }

    #[test]
    fn patterns_pad_the_frame_number() {
        assert_eq!(frame_path("out/frame_####.png", 7).unwrap(), PathBuf::from("out/frame_0007.png"));
        assert_eq!(frame_path("f#.png", 123).unwrap(), PathBuf::from("f123.png"));
        assert!(frame_path("out/frame.png", 1).is_err());
    }

    #[test]
    fn frames_on_disk_are_found_in_order_and_a_gap_is_named() {
        let dir = std::env::temp_dir().join(format!("isomarch-frames-on-disk-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let pattern = format!("{}/f_###.png", dir.display());
        for f in [2, 3, 4, 1000] {
            std::fs::write(frame_path(&pattern, f).unwrap(), b"").unwrap();
        }
        for other in ["f_0003.png", "f_03.png", "f_003.png.tmp", "g_005.png"] {
            std::fs::write(dir.join(other), b"").unwrap();
        }
        let got = frames_on_disk(&pattern, Some(FrameRange { start: 2, end: 5 })).unwrap();
        assert_eq!(got.iter().map(|f| f.0).collect::<Vec<_>>(), vec![2, 3, 4]);
        assert_eq!(got[0].1, dir.join("f_002.png"));
        let e = frames_on_disk(&pattern, None).unwrap_err().to_string();
        assert!(e.contains("f_005.png: missing: frame 5 is the first of frames 2..1001 not on disk (4 of 999 are)"), "{e}");
        let e = frames_on_disk(&format!("{}/h_##.png", dir.display()), None).unwrap_err().to_string();
        assert!(e.contains("no frame on disk"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_scene_column_reads_back_and_other_scenes_are_refused() {
        for scene in ["scenes/fig16.ron", "a \"quoted\", name.pdb", ""] {
            assert_eq!(last_quoted_field(&format!("0,1.0,{}", quoted(scene))).as_deref(), Some(scene));
        }
        let csv = std::path::Path::new("out/frames.csv");
        let text = format!("{CSV_HEADER}\n0,0.000000,\"out/f_0.png\",8,8,segment,1,1,1,,1,,,,,,,,{}\n", quoted("scenes/fig16.ron"));
        check_csv(csv, &text, "scenes/fig16.ron").unwrap();
        let e = check_csv(csv, &text, "3KPR.pdb").unwrap_err().to_string();
        assert!(e.contains("out/frames.csv:2: lists a frame of scenes/fig16.ron, and this batch renders 3KPR.pdb"), "{e}");
        assert!(check_csv(csv, "frame,time_s\n", "x").is_err(), "an older header");
    }

    #[test]
    fn shards_partition_a_range() {
        let env = |_: &str| None;
        let shards: Vec<Shard> = (0..3).map(|i| Shard::resolve(Some(&format!("{i}/3")), None, env).unwrap()).collect();
        for f in 0..100 {
            assert_eq!(shards.iter().filter(|s| s.contains(f)).count(), 1, "frame {f}");
        }
        assert!(Shard::resolve(Some("3/3"), None, env).is_err());
        assert_eq!(Shard::resolve(None, None, env).unwrap(), Shard::ALL);
    }

    #[test]
    fn shards_come_from_the_scheduler() {
        let slurm = |k: &str| match k {
            "SLURM_ARRAY_TASK_ID" => Some("12".to_string()),
            "SLURM_ARRAY_TASK_MIN" => Some("10".to_string()),
            "SLURM_ARRAY_TASK_COUNT" => Some("4".to_string()),
            _ => None,
        };
        assert_eq!(Shard::resolve(None, None, slurm).unwrap(), Shard { index: 2, count: 4 });
        // --array=10-40:10 gives ids 10, 20, 30, 40.
        let stepped = |k: &str| match k {
            "SLURM_ARRAY_TASK_ID" => Some("30".to_string()),
            "SLURM_ARRAY_TASK_MIN" => Some("10".to_string()),
            "SLURM_ARRAY_TASK_STEP" => Some("10".to_string()),
            "SLURM_ARRAY_TASK_COUNT" => Some("4".to_string()),
            _ => None,
        };
        assert_eq!(Shard::resolve(None, None, stepped).unwrap(), Shard { index: 2, count: 4 });
        // --array=0,5 gives ids 0 and 5 with MIN 0, STEP 1 and COUNT 2: no shard 5.
        let listed = |k: &str| match k {
            "SLURM_ARRAY_TASK_ID" => Some("5".to_string()),
            "SLURM_ARRAY_TASK_MIN" => Some("0".to_string()),
            "SLURM_ARRAY_TASK_STEP" => Some("1".to_string()),
            "SLURM_ARRAY_TASK_COUNT" => Some("2".to_string()),
            _ => None,
        };
        let e = Shard::resolve(None, None, listed).unwrap_err().to_string();
        assert!(e.contains("task 5 would be shard 5 of 2") && e.contains("0,5"), "{e}");
        let k8s = |k: &str| (k == "JOB_COMPLETION_INDEX").then(|| "1".to_string());
        assert_eq!(Shard::resolve(None, Some(5), k8s).unwrap(), Shard { index: 1, count: 5 });
        assert!(Shard::resolve(None, None, k8s).is_err(), "Kubernetes needs --shard-count");
        // An explicit shard wins over the environment.
        assert_eq!(Shard::resolve(Some("0/2"), None, slurm).unwrap(), Shard { index: 0, count: 2 });
    }
}

/// A marched frame on its way to disk: its image, file, CSV row (the
/// columns before `wall_ms` and those after it, which is known when the
/// file has landed) and the instant its frame started.
struct Landed {
    image: crate::output::Frame,
    path: PathBuf,
    row: (String, String),
    started: std::time::Instant,
}

/// What a batch did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BatchSummary {
    pub rendered: u64,
    pub skipped: u64,
    /// Stopped early on request (Ctrl-C); every file written is whole.
    pub interrupted: bool,
}

/// Where a batch's frames go.
#[derive(Clone, Copy, Debug)]
pub enum Sink<'a> {
    /// A file per frame, named by `pattern` ([`frame_path`]), each written
    /// whole; with `skip_existing`, frames already on disk are kept. The
    /// statistics CSV is appended to as each frame lands.
    Files { pattern: &'a str, skip_existing: bool },
    /// One movie of every frame in order, written whole at the end or not
    /// at all; the statistics CSV is written with it, whole, replacing any
    /// before.
    Movie(&'a crate::movie::MovieSpec),
}

/// The size of a batch's frames as a movie holds them: the image, and the
/// legend's rows under it where it has one.
pub fn movie_frame_size(job: &crate::render::offscreen::RenderJob) -> (u32, u32) {
    let legend = if job.legend.is_some() { crate::output::LEGEND_HEIGHT } else { 0 };
    (job.width, job.height + legend)
}

/// Where a batch's CSV rows go: appended to the file as frames land, or
/// kept until the movie they describe is whole.
enum Log {
    File(std::fs::File),
    Held(Vec<u8>),
}

impl std::io::Write for Log {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Log::File(f) => f.write(buf),
            Log::Held(v) => v.write(buf),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Log::File(f) => f.flush(),
            Log::Held(_) => Ok(()),
        }
    }
}

/// Renders the frames of `range` in `shard` to `sink`: PNGs (see
/// [`frame_path`]), each written atomically, or one movie; with a progress
/// bar (frames done, frames per second, time left). Per-frame statistics
/// go to `csv` ([`Sink`] says when). `stop` is checked between frames: a
/// requested stop ends the batch after the frame in flight is written (a
/// movie is then not written at all). With a `trajectory`, frame
/// n is the trajectory's frame n (posed at scene time n / fps, for a
/// turntable camera), decoded ahead on another thread. Each frame is
/// encoded and written on a thread of its own while the next one marches
/// (on a GPU the PNG encoding is longer than the march; on lavapipe the
/// CPU is the GPU, and 98 AdK frames at 256x256 took the same time).
#[allow(clippy::too_many_arguments)]
pub fn run(
    ctx: &std::sync::Arc<crate::gpu::Context>,
    job: &crate::render::offscreen::RenderJob,
    trajectory: Option<crate::molecule::playback::Stager>,
    sink: Sink,
    range: FrameRange,
    fps: f64,
    shard: Shard,
    csv: &std::path::Path,
    stop: &std::sync::atomic::AtomicBool,
) -> Result<BatchSummary> {
    use std::io::Write;
    use std::sync::atomic::Ordering;

    use anyhow::Context as _;

    use crate::output::{FileFormat, shaded_bytes, shaded_rgb, write_atomic};
    use crate::render::{MarchOptions, Renderer};

    let frames: Vec<u64> = (range.start..range.end).filter(|&f| shard.contains(f)).collect();
    let mut summary = BatchSummary::default();
    let (todo, mut log, mut movie): (Vec<(u64, PathBuf)>, Log, _) = match sink {
        Sink::Files { pattern, skip_existing } => {
            let todo = frames
                .iter()
                .map(|&f| Ok((f, frame_path(pattern, f)?)))
                .collect::<Result<Vec<_>>>()?
                .into_iter()
                .filter(|(_, path)| {
                    let keep = !(skip_existing && path.exists());
                    summary.skipped += u64::from(!keep);
                    keep
                })
                .collect();
            let existing = match std::fs::read_to_string(csv) {
                Ok(text) => text,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
                Err(e) => return Err(e).with_context(|| format!("reading {}", csv.display())),
            };
            check_csv(csv, &existing, &job.scene.source)?;
            let new_csv = existing.trim().is_empty();
            if let Some(dir) = csv.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            }
            let mut log =
                Log::File(std::fs::OpenOptions::new().create(true).append(true).open(csv).with_context(|| format!("opening {}", csv.display()))?);
            if new_csv {
                writeln!(log, "{CSV_HEADER}")?;
            }
            (todo, log, None)
        }
        Sink::Movie(spec) => {
            anyhow::ensure!(
                shard == Shard::ALL,
                "a movie is written by one process: render numbered PNGs in shards and join them with `isomarch encode`"
            );
            let size = movie_frame_size(job);
            let writer = crate::movie::MovieWriter::create(spec, size)?;
            let todo = frames.iter().map(|&f| (f, spec.path.clone())).collect();
            (todo, Log::Held(format!("{CSV_HEADER}\n").into_bytes()), Some(writer))
        }
    };
    let bar = indicatif::ProgressBar::new(todo.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} frames ({per_sec}, {eta} left)")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(format!("shard {}/{}", shard.index, shard.count));
    // Coordinates centred on the camera, frame by frame (f32 precision).
    let still = job.scene.recentred_on_camera();
    let mut renderer = Renderer::for_camera(ctx, &still, job.timeout)?;
    let animated = !job.scene.animation.is_static();
    let mut frames = match trajectory {
        Some(stager) => {
            let order = crate::molecule::playback::Order::List(todo.iter().map(|(f, _)| *f as usize).collect());
            Some(crate::molecule::playback::Prefetch::spawn(stager, order, 2)?)
        }
        None => None,
    };
    // The scene the renderer holds (its camera makes the rays).
    let mut shown = still.clone();
    // Posing moves primitives and the camera, not the marching settings.
    let options = MarchOptions::for_scene(&still);
    // Whether the index was built for the frame about to be marched: the
    // first frame's is built with the renderer, an animated scene's again
    // for every frame; a static scene's later frames reuse the first's.
    let mut index_built = true;
    // Frames are encoded and written on a thread of their own while the
    // GPU marches the next: a frame waits in the channel at most one
    // frame, and its CSV row is appended when its file has landed, so the
    // rows and the files on disk agree whenever the batch stops.
    let look = job.look();
    std::thread::scope(|scope| -> Result<()> {
        let (landed, to_write) = std::sync::mpsc::sync_channel::<Landed>(1);
        let bar = &bar;
        let log = &mut log;
        let movie = &mut movie;
        let writer = scope.spawn(move || -> Result<u64> {
            let mut written = 0;
            for frame in to_write {
                match movie.as_mut() {
                    Some(movie) => movie.push(&shaded_rgb(&frame.image, look)?)?,
                    None => {
                        let bytes = shaded_bytes(&frame.image, FileFormat::of("-o", &frame.path, FileFormat::IMAGE)?, &[], look)?;
                        write_atomic(&frame.path, &bytes)?;
                    }
                }
                let (head, tail) = &frame.row;
                writeln!(log, "{head},{:.1},{tail}", frame.started.elapsed().as_secs_f64() * 1e3)?;
                log.flush()?;
                written += 1;
                bar.inc(1);
            }
            Ok(written)
        });
        let marched = (|| -> Result<()> {
            for (frame, path) in todo {
                if stop.load(Ordering::SeqCst) {
                    summary.interrupted = true;
                    break;
                }
                let started = std::time::Instant::now();
                let mut saved = ",,".to_string();
                if let Some(prefetch) = frames.as_mut() {
                    let staged = prefetch.wait().ok_or_else(|| anyhow::anyhow!("the trajectory's decoder stopped before frame {frame}"))??;
                    anyhow::ensure!(staged.frame as u64 == frame, "the decoder gave frame {} for frame {frame}", staged.frame);
                    shown = staged.scene.at_time(frame as f64 / fps).recentred_on_camera();
                    let (i, j, f) = staged.between;
                    saved = format!("{i},{j},{f:.6}");
                    renderer.set_scene(&shown)?;
                    index_built = true;
                } else if animated {
                    // The scene at this frame's time: primitives, camera, bounds.
                    shown = job.scene.at_time(frame as f64 / fps).recentred_on_camera();
                    renderer.set_scene(&shown)?;
                    index_built = true;
                }
                let (image, stats) = crate::render::offscreen::march_image(
                    &mut renderer,
                    job.method,
                    options,
                    &shown,
                    (job.width, job.height),
                    job.samples,
                    job.effects,
                    job.image_only(),
                )?;
                // GPU time of this frame's index build: 0 where a static scene
                // reuses the first frame's, empty without an index (or without
                // GPU timestamps).
                let built = std::mem::take(&mut index_built);
                let index_ms = match renderer.index_stats() {
                    Some(_) if !built => "0".to_string(),
                    Some(i) if i.build_ns.is_finite() => format!("{:.3}", i.build_ns * 1e-6),
                    _ => String::new(),
                };
                let head = format!(
                    "{frame},{:.6},{},{},{},{},{:.4},{:.2},{:.5},{}",
                    frame as f64 / fps,
                    quoted(&path.display().to_string()),
                    job.width,
                    job.height,
                    job.method,
                    stats.steps_per_ray,
                    stats.evals_per_ray,
                    stats.hit_rate,
                    stats.gpu_ms.map_or(String::new(), |ms| format!("{ms:.2}")),
                );
                let tail = format!("{saved},{index_ms},{},{}", any_hit_columns(stats.any_hit.as_ref()), quoted(&job.scene.source));
                let row = (head, tail);
                // The writer stopped only on an error, which its join reports.
                if landed.send(Landed { image, path, row, started }).is_err() {
                    break;
                }
            }
            Ok(())
        })();
        drop(landed);
        let written = writer.join().map_err(|_| anyhow::anyhow!("the frame writer panicked"))?;
        summary.rendered = written?;
        marched
    })?;
    bar.finish_and_clear();
    // A movie is written whole, then its statistics; a stopped one is
    // dropped, its temporary file with it.
    if let (Some(movie), false) = (movie, summary.interrupted) {
        movie.finish()?;
        if let Log::Held(rows) = log {
            write_atomic(csv, &rows)?;
        }
    }
    Ok(summary)
}

/// The CSV's shadow and occlusion columns: steps per shadow ray and per
/// occlusion ray and their GPU ms, empty where the frame cast none.
fn any_hit_columns(a: Option<&crate::output::AnyHitStats>) -> String {
    let Some(a) = a else { return ",,".to_string() };
    let per = |rays: u64, steps: f64| if rays > 0 { format!("{steps:.4}") } else { String::new() };
    format!(
        "{},{},{}",
        per(a.shadow_rays, a.shadow_steps_per_ray),
        per(a.ao_rays, a.ao_steps_per_ray),
        a.gpu_ms.map_or(String::new(), |ms| format!("{ms:.2}"))
    )
}
