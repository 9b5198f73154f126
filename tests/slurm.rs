//! Batch frames on a real SLURM: `scripts/slurm-local.sh` starts a one-node
//! cluster (or finds one answering), `scripts/frames.sbatch` renders one
//! shard per array task, `isomarch merge-stats` joins the shards'
//! statistics. One test, so that the cluster starts once: it fails, saying
//! why, when SLURM cannot be started (it never skips), and stops the
//! daemons that it started.

mod common;

use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet};
use std::os::unix::fs::MetadataExt;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant, SystemTime};

use common::*;

/// How long one job may take before the test gives up on it.
const JOB_LIMIT: Duration = Duration::from_secs(240);

fn run(program: &str, args: &[&str]) -> Output {
    Command::new(program).args(args).current_dir(repo_root()).stdin(Stdio::null()).output().unwrap_or_else(|e| panic!("running {program}: {e}"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// A running SLURM, for the length of the test.
struct Cluster {
    /// Whether `slurm-local.sh start` started daemons, which drop stops.
    started: bool,
    /// Jobs submitted, cancelled on drop (a failed test leaves none queued).
    jobs: RefCell<Vec<String>>,
}

/// One array job's tasks: array index -> (state, exit code).
type Tasks = BTreeMap<u64, (String, String)>;

impl Cluster {
    fn up() -> Cluster {
        let out = run("bash", &["scripts/slurm-local.sh", "start"]);
        assert!(
            out.status.success(),
            "SLURM could not be started, and this test needs a real SLURM: `bash scripts/slurm-local.sh start` failed \
             ({}). Its output:\n{}{}",
            out.status,
            text(&out.stdout),
            text(&out.stderr)
        );
        let started = text(&out.stdout).trim() == "started";
        Cluster { started, jobs: RefCell::new(Vec::new()) }
    }

    /// `sbatch --array=ARRAY scripts/frames.sbatch ARGS` with the logs in
    /// `dir`, from the repository; returns the job id.
    fn submit(&self, dir: &Path, array: &str, args: &[&str]) -> String {
        let out = Command::new("sbatch")
            .args(["--parsable", "--job-name=isomarch-test", "--time=10"])
            .arg(format!("--array={array}"))
            .arg(format!("--output={}/slurm-%A_%a.out", dir.display()))
            .arg("scripts/frames.sbatch")
            .args(args)
            .env("ISOMARCH", bin())
            .current_dir(repo_root())
            .stdin(Stdio::null())
            .output()
            .expect("running sbatch");
        assert!(out.status.success(), "sbatch failed: {}", text(&out.stderr));
        let id = text(&out.stdout).trim().split(';').next().unwrap().to_string();
        assert!(id.parse::<u64>().is_ok(), "sbatch --parsable printed {:?}", text(&out.stdout));
        self.jobs.borrow_mut().push(id.clone());
        id
    }

    /// Whether job `id` still has tasks pending, running or completing.
    fn queued(&self, id: &str) -> bool {
        let out = run("squeue", &["-h", "-j", id, "-o", "%i %T"]);
        // squeue fails for a job id that the controller no longer knows.
        out.status.success() && !text(&out.stdout).trim().is_empty()
    }

    /// Waits until job `id` has left the queue, then returns its tasks.
    fn wait(&self, id: &str, dir: &Path) -> Tasks {
        let start = Instant::now();
        while self.queued(id) {
            if start.elapsed() > JOB_LIMIT {
                let queue = text(&run("squeue", &["-j", id]).stdout);
                panic!("job {id} still queued after {JOB_LIMIT:?}:\n{queue}\nlogs:\n{}", logs(dir));
            }
            std::thread::sleep(Duration::from_millis(200));
        }
        self.tasks(id)
    }

    /// The array tasks of job `id` with their states and exit codes.
    fn tasks(&self, id: &str) -> Tasks {
        let out = run("scontrol", &["-o", "show", "job", id]);
        assert!(out.status.success(), "scontrol show job {id}: {}", text(&out.stderr));
        let mut tasks = Tasks::new();
        for line in text(&out.stdout).lines() {
            let field = |name: &str| {
                line.split_whitespace()
                    .find_map(|w| w.strip_prefix(name).and_then(|v| v.strip_prefix('=')))
                    .unwrap_or_else(|| panic!("no {name} in {line}"))
                    .to_string()
            };
            tasks.insert(field("ArrayTaskId").parse().unwrap(), (field("JobState"), field("ExitCode")));
        }
        tasks
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for id in self.jobs.borrow().iter() {
            if self.queued(id) {
                let _ = run("scancel", &[id]);
            }
        }
        if self.started {
            let out = run("bash", &["scripts/slurm-local.sh", "stop"]);
            if !out.status.success() && !std::thread::panicking() {
                panic!("`bash scripts/slurm-local.sh stop` failed: {}", text(&out.stderr));
            }
        }
    }
}

/// Every task's log in `dir`, for failure messages.
fn logs(dir: &Path) -> String {
    let mut all = String::new();
    for name in files(dir) {
        if name.starts_with("slurm-") {
            all += &format!("--- {name}\n{}", std::fs::read_to_string(dir.join(&name)).unwrap_or_default());
        }
    }
    all
}

fn files(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect()
}

fn frame_name(f: u64) -> String {
    format!("f_{f:04}.png")
}

/// The frames in `dir`, after checking that nothing partial is there: no
/// temporary or hidden file, every PNG decodes at `size`.
fn whole_frames(dir: &Path, size: u32) -> BTreeSet<String> {
    let mut frames = BTreeSet::new();
    for name in files(dir) {
        assert!(!name.starts_with('.') && !name.ends_with(".tmp"), "temporary file {name} left in {}", dir.display());
        if name.ends_with(".png") {
            let image = image::open(dir.join(&name)).unwrap_or_else(|e| panic!("{name} is not a whole PNG: {e}"));
            assert_eq!((image.width(), image.height()), (size, size), "{name}");
            frames.insert(name);
        }
    }
    frames
}

/// The frames listed in a task's statistics CSV, in order.
fn csv_frames(csv: &Path) -> Vec<u64> {
    let text = std::fs::read_to_string(csv).unwrap_or_else(|e| panic!("{}: {e}", csv.display()));
    text.lines().skip(1).map(|l| l.split(',').next().unwrap().parse().unwrap()).collect()
}

/// `isomarch merge-stats --frames RANGE -o OUT` over the tasks' CSVs, to run.
fn merge(dir: &Path, range: &str, tasks: &[u64], out: &Path) -> Isomarch {
    isomarch(["merge-stats", "--frames", range, "-o"]).arg(out).args(tasks.iter().map(|t| dir.join(format!("frames-task-{t}.csv"))))
}

fn assert_all_completed(tasks: &Tasks, ids: &[u64], dir: &Path) {
    let expected: Tasks = ids.iter().map(|&i| (i, ("COMPLETED".to_string(), "0:0".to_string()))).collect();
    assert_eq!(tasks, &expected, "every task completes; logs:\n{}", logs(dir));
}

/// The 24 frames of an animated scene over `--array=0-3`: each written once,
/// each PNG whole, and the merged statistics hold 24 rows in frame order.
#[test]
fn frames_on_a_real_slurm_cluster() {
    let cluster = Cluster::up();
    an_array_job_renders_every_frame_exactly_once(&cluster);
    a_resubmitted_array_finishes_what_a_cancelled_task_left(&cluster);
    a_bad_shard_fails_its_task_and_writes_nothing(&cluster);
}

fn an_array_job_renders_every_frame_exactly_once(cluster: &Cluster) {
    let dir = scratch("slurm-array");
    let pattern = dir.join("f_####.png");
    let job = cluster.submit(&dir, "0-3", &["scenes/fig16.ron", "0..24", pattern.to_str().unwrap(), "--size", "32x32"]);
    let tasks = cluster.wait(&job, &dir);
    assert_all_completed(&tasks, &[0, 1, 2, 3], &dir);
    let frames = whole_frames(&dir, 32);
    assert_eq!(frames, (0..24).map(frame_name).collect(), "frames on disk");
    // Each task wrote a row per frame it rendered: its shard, once each.
    for t in 0..4u64 {
        let listed = csv_frames(&dir.join(format!("frames-task-{t}.csv")));
        assert_eq!(listed, (0..24).filter(|f| f % 4 == t).collect::<Vec<_>>(), "task {t}'s frames");
    }
    let merged = dir.join("frames.csv");
    merge(&dir, "0..24", &[0, 1, 2, 3], &merged).ok();
    let text_merged = std::fs::read_to_string(&merged).unwrap();
    assert!(text_merged.starts_with(isomarch::batch::CSV_HEADER), "header");
    assert_eq!(csv_frames(&merged), (0..24).collect::<Vec<_>>(), "24 rows, in frame order");
    // Without task 2's CSV, six frames are missing: refused, nothing written.
    let partial = dir.join("partial.csv");
    let err = merge(&dir, "0..24", &[0, 1, 3], &partial).fails_in_one_line();
    assert!(err.contains("6 frame(s) missing (2, 6, 10, 14, 18, and 1 more)"), "{err}");
    assert!(!partial.exists(), "a failed merge wrote {}", partial.display());
}

/// One task cancelled mid-run, the same array resubmitted: the range
/// completes, nothing partial is left, and no frame is rendered twice.
fn a_resubmitted_array_finishes_what_a_cancelled_task_left(cluster: &Cluster) {
    let dir = scratch("slurm-cancel");
    let pattern = dir.join("f_####.png");
    // 12 frames per task, large enough that a task runs for a few seconds.
    let (range, frames, size) = ("0..48", 48u64, 96u32);
    let args = ["scenes/fig16.ron", range, pattern.to_str().unwrap(), "--size", "96x96"];
    let job = cluster.submit(&dir, "0-3", &args);
    // Task 1 renders 1, 5, 9, ...: cancel it once its first frame is there.
    let start = Instant::now();
    while !dir.join(frame_name(1)).exists() {
        assert!(start.elapsed() < JOB_LIMIT && cluster.queued(&job), "task 1 wrote no frame; logs:\n{}", logs(&dir));
        std::thread::sleep(Duration::from_millis(10));
    }
    let out = run("scancel", &[&format!("{job}_1")]);
    assert!(out.status.success(), "scancel: {}", text(&out.stderr));
    let tasks = cluster.wait(&job, &dir);
    assert_eq!(tasks[&1].0, "CANCELLED", "task 1's state; logs:\n{}", logs(&dir));
    for t in [0, 2, 3] {
        assert_eq!(tasks[&t], ("COMPLETED".to_string(), "0:0".to_string()), "task {t}; logs:\n{}", logs(&dir));
    }
    let before = whole_frames(&dir, size);
    let task1: Vec<u64> = (0..frames).filter(|f| f % 4 == 1).collect();
    let missing: Vec<u64> = task1.iter().copied().filter(|&f| !before.contains(&frame_name(f))).collect();
    assert!(!missing.is_empty(), "the cancel came after task 1 had finished: nothing was tested");
    assert_eq!(before.len() as u64, frames - missing.len() as u64, "only task 1's frames are missing");
    let stamp = |name: &String| -> (SystemTime, u64) {
        let m = std::fs::metadata(dir.join(name)).unwrap();
        (m.modified().unwrap(), m.ino())
    };
    let stamps: Vec<_> = before.iter().map(stamp).collect();

    let again = cluster.submit(&dir, "0-3", &args);
    let tasks = cluster.wait(&again, &dir);
    assert_all_completed(&tasks, &[0, 1, 2, 3], &dir);
    let after = whole_frames(&dir, size);
    assert_eq!(after, (0..frames).map(frame_name).collect(), "the range is complete");
    for (name, was) in before.iter().zip(stamps) {
        assert_eq!(stamp(name), was, "{name} was written again");
    }
    // The statistics list each frame once: every frame was written once.
    let merged = dir.join("frames.csv");
    merge(&dir, range, &[0, 1, 2, 3], &merged).ok();
    assert_eq!(csv_frames(&merged), (0..frames).collect::<Vec<_>>());
    let resumed = csv_frames(&dir.join("frames-task-1.csv"));
    assert_eq!(resumed.len(), task1.len(), "task 1's CSV: the cancelled run's rows, then the resubmission's");
}

/// Array ids that leave a task without a shard (a list, 0,5) and a shard
/// count of 0: the task fails with a one-line error and writes nothing.
fn a_bad_shard_fails_its_task_and_writes_nothing(cluster: &Cluster) {
    let listed = scratch("slurm-listed");
    let zero = scratch("slurm-zero");
    let listed_job = cluster.submit(&listed, "0,5", &["scenes/fig16.ron", "0..2", listed.join("f_####.png").to_str().unwrap(), "--size", "32x32"]);
    let zero_job =
        cluster.submit(&zero, "0-1", &["scenes/fig16.ron", "0..2", zero.join("f_####.png").to_str().unwrap(), "--size", "32x32", "--shard", "0/0"]);

    // --array=0,5: task 0 is shard 0 of 2 (frame 0); task 5 has no shard.
    let tasks = cluster.wait(&listed_job, &listed);
    assert_eq!(tasks[&0], ("COMPLETED".to_string(), "0:0".to_string()), "logs:\n{}", logs(&listed));
    assert_eq!(tasks[&5], ("FAILED".to_string(), "1:0".to_string()), "logs:\n{}", logs(&listed));
    let log = std::fs::read_to_string(listed.join(format!("slurm-{listed_job}_5.out"))).unwrap();
    assert_eq!(log.lines().count(), 1, "one line: {log}");
    assert!(log.starts_with("error: SLURM array task 5 would be shard 5 of 2, which does not exist"), "{log}");
    let expected: BTreeSet<String> =
        ["f_0000.png", "frames-task-0.csv"].into_iter().map(String::from).chain([0, 5].map(|t| format!("slurm-{listed_job}_{t}.out"))).collect();
    assert_eq!(files(&listed), expected, "task 5 wrote nothing");

    // --shard 0/0 in every task: both fail and nothing is written.
    let tasks = cluster.wait(&zero_job, &zero);
    for t in [0, 1] {
        assert_eq!(tasks[&t], ("FAILED".to_string(), "1:0".to_string()), "logs:\n{}", logs(&zero));
        let log = std::fs::read_to_string(zero.join(format!("slurm-{zero_job}_{t}.out"))).unwrap();
        assert_eq!(log.lines().count(), 1, "one line: {log}");
        assert!(log.starts_with("error: --shard: shard 0 of 0 does not exist"), "{log}");
    }
    let expected: BTreeSet<String> = [0, 1].map(|t| format!("slurm-{zero_job}_{t}.out")).into_iter().collect();
    assert_eq!(files(&zero), expected, "nothing but the logs");
}
