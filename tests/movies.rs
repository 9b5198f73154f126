//! Movies through the binary (docs/trajectories.md): `render --frames -o
//! movie.mp4` (H.264), `.webm` (VP9) and `.gif` hold the frames that
//! `render` writes as PNGs, within each format's loss; a movie render
//! stopped by SIGTERM leaves no file; a missing ffmpeg and the sizes and
//! flags a movie cannot take are one-line refusals before any frame. The
//! MP4 and WebM are read back with ffmpeg and ffprobe (Debian's ffmpeg,
//! which scripts/test.sh installs).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::*;

fn data(name: &str) -> String {
    repo_root().join("tests/data/trajectories").join(name).to_str().unwrap().to_string()
}

/// The AdK DCD's frames `range` at `size` (`render --frames`), with
/// `extra` flags, into `out` (a pattern or a movie); to run.
fn adk(range: &str, size: &str, out: &Path) -> Isomarch {
    isomarch(["render", &data("adk.psf"), &data("adk_dims.dcd"), "--frames", range, "--size", size, "-o"])
        .arg(out)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
}

/// An ffmpeg tool's output, failing (never skipping) where it is missing.
fn tool(name: &str, args: &[&str]) -> Vec<u8> {
    let out =
        Command::new(name).args(args).stdin(Stdio::null()).output().unwrap_or_else(|e| {
            panic!("{name}: {e}: the movie tests need ffmpeg and ffprobe (Debian package ffmpeg; bash scripts/test.sh installs it)")
        });
    assert!(out.status.success(), "{name} {args:?} failed:\n{}", String::from_utf8_lossy(&out.stderr));
    out.stdout
}

/// What ffprobe reads of a movie's video stream (frames counted by
/// decoding them).
#[derive(Debug, PartialEq)]
struct Probe {
    codec: String,
    width: u32,
    height: u32,
    rate: String,
    frames: u64,
    pix_fmt: String,
    /// Its colour tags: matrix, range, primaries and transfer.
    color: String,
}

fn probe(movie: &Path) -> Probe {
    let out = tool(
        "ffprobe",
        &[
            "-v",
            "error",
            "-select_streams",
            "v:0",
            "-count_frames",
            "-show_entries",
            "stream=codec_name,width,height,r_frame_rate,nb_read_frames,pix_fmt,color_space,color_range,color_primaries,color_transfer",
            "-of",
            "default=nw=1",
            movie.to_str().unwrap(),
        ],
    );
    let text = String::from_utf8(out).unwrap();
    let get = |key: &str| {
        text.lines().find_map(|l| l.strip_prefix(&format!("{key}="))).unwrap_or_else(|| panic!("ffprobe gave no {key}:\n{text}")).to_string()
    };
    Probe {
        codec: get("codec_name"),
        width: get("width").parse().unwrap(),
        height: get("height").parse().unwrap(),
        rate: get("r_frame_rate"),
        frames: get("nb_read_frames").parse().unwrap(),
        pix_fmt: get("pix_fmt"),
        color: ["color_space", "color_range", "color_primaries", "color_transfer"].map(get).join(" "),
    }
}

/// ffmpeg's raw frames of `input` (a movie, or a pattern of PNGs with
/// `-framerate` before it), in `pix_fmt`, after `filter` where given.
fn raw_frames(input: &[&str], filter: Option<&str>, pix_fmt: &str, frame_bytes: usize) -> Vec<Vec<u8>> {
    let mut args = vec!["-v", "error"];
    args.extend(input);
    if let Some(f) = filter {
        args.extend(["-vf", f]);
    }
    args.extend(["-f", "rawvideo", "-pix_fmt", pix_fmt, "-"]);
    let bytes = tool("ffmpeg", &args);
    assert_eq!(bytes.len() % frame_bytes, 0, "ffmpeg gave {} bytes, not whole frames of {frame_bytes}", bytes.len());
    bytes.chunks(frame_bytes).map(<[u8]>::to_vec).collect()
}

/// PSNR in dB of `b` against `a` over all their samples (8 bits).
fn psnr(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    let mse = a.iter().zip(b).map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2)).sum::<f64>() / a.len() as f64;
    10.0 * (255.0f64.powi(2) / mse.max(1e-12)).log10()
}

/// The mean of each channel of RGB samples.
fn mean_colour(rgb: &[u8]) -> [f64; 3] {
    let n = (rgb.len() / 3) as f64;
    [0, 1, 2].map(|c| rgb.iter().skip(c).step_by(3).map(|&v| f64::from(v)).sum::<f64>() / n)
}

/// The names in `dir`.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

/// The frame rows of a movie's statistics CSV: (frame, file).
fn csv_rows(csv: &Path) -> Vec<(u64, String)> {
    let text = std::fs::read_to_string(csv).unwrap_or_else(|e| panic!("{}: {e}", csv.display()));
    let mut lines = text.lines();
    assert!(lines.next().unwrap().starts_with("frame,time_s,file,"), "{}: header", csv.display());
    lines
        .map(|l| {
            let mut cols = l.split(',');
            (cols.next().unwrap().parse().unwrap(), cols.nth(1).unwrap().trim_matches('"').to_string())
        })
        .collect()
}

/// PNGs of the AdK DCD's frames 0 to 9 at 256x256, the references.
fn reference_frames(dir: &Path) -> PathBuf {
    let pattern = dir.join("f_####.png");
    adk("0..10", "256x256", &pattern).ok();
    pattern
}

/// What a codec's loss is measured against: the PNGs converted to
/// Y'CbCr 4:2:0 as the movie's encoder converts them (BT.709, limited
/// range). `ffmpeg -i adk.mp4 -i f50.png -lavfi "[0:v]trim=start_frame=50:end_frame=51,setpts=PTS-STARTPTS[a];[1:v]scale=out_color_matrix=bt709:out_range=tv,format=yuv420p[b];[a][b]psnr" -f null -`
/// reports the same figure (its `average`); without the `scale` ffmpeg
/// converts the PNG with BT.601, not the movie's BT.709, and reports less.
const TO_YUV420: &str = "scale=out_color_matrix=bt709:out_range=tv,format=yuv420p";

/// The PNGs through 4:2:0 and back, without a codec: converted as the
/// encoder converts them, then to RGB as ffmpeg decodes a movie (BT.709,
/// limited range, its default scaler): what a lossless yuv420p movie of
/// the frame decodes to with ffmpeg, about 32 dB PSNR in RGB for AdK at
/// 256x256 (docs/trajectories.md, "How close an MP4 or WebM is to the
/// PNGs").
const THROUGH_YUV420: &str = "scale=out_color_matrix=bt709:out_range=tv,format=yuv420p,scale=in_color_matrix=bt709:in_range=tv,format=rgb24";

/// How much more than 4:2:0 itself the codec may cost in RGB, in dB: over
/// all 98 frames of the AdK DCD at 256x256, measured 2.0 to 3.2 dB for
/// H.264 at CRF 23, 0.3 to 2.3 for VP9 at CRF 31.
const RGB_CODEC_LOSS_DB: f64 = 3.5;

/// How far, in 8-bit levels, a decoded frame's mean colour may be from
/// the same frame's through 4:2:0 without a codec, channel by channel: a
/// codec keeps a frame's mean. A movie converted with another matrix than
/// its tags say (BT.601 tagged BT.709) moved frame 0's green by 1.97
/// levels and its red by 1.19, and cost its PSNR under a dB, which the
/// bounds above miss (frame 0 kept 36.13 dB over the 4:2:0 planes).
const MEAN_SHIFT: f64 = 1.0;

/// The movie, `render adk.psf adk_dims.dcd --frames 0..98 --size
/// 256x256 -o adk.mp4` (and `.webm`): ffprobe reads 98 frames of H.264
/// (VP9) at 256x256, 25 fps, yuv420p, tagged BT.709 in limited range with
/// sRGB's transfer. Frames 0 to 9 (against `render --frames 0..10`'s
/// PNGs) and frame 50 (against `render --frame 50`'s) are within the
/// codec's loss: PSNR at least 35 dB over the Y'CbCr 4:2:0 planes against
/// the PNG converted as the encoder converts it ([`TO_YUV420`]); and in
/// RGB as ffmpeg decodes the movie, at most [`RGB_CODEC_LOSS_DB`] under
/// the same frame through 4:2:0 without a codec ([`THROUGH_YUV420`]),
/// since 4:2:0's halved colour resolution alone keeps RGB near 32 dB
/// (35 dB in RGB is out of reach of any yuv420p movie of these frames),
/// with its mean colour within [`MEAN_SHIFT`] of that frame's.
/// Nothing is left beside the movie but its statistics.
#[test]
fn an_mp4_and_a_webm_hold_the_rendered_frames_within_the_codecs_loss() {
    let refs = scratch("movie-refs");
    reference_frames(&refs);
    let f50 = refs.join("f50.png");
    isomarch(["render", &data("adk.psf"), &data("adk_dims.dcd"), "--frame", "50", "--size", "256x256", "-o"]).arg(&f50).ok();
    let (w, h) = (256usize, 256usize);
    let (yuv_bytes, rgb_bytes) = (w * h * 3 / 2, w * h * 3);
    // (frame, the PNG in 4:2:0, the PNG in RGB, the PNG through 4:2:0 in RGB)
    type Want = (usize, Vec<u8>, Vec<u8>, Vec<u8>);
    let wants: Vec<Want> = (0..10)
        .map(|k| (k, refs.join(format!("f_{k:04}.png"))))
        .chain([(50, f50)])
        .map(|(k, png)| {
            let input = ["-i", png.to_str().unwrap()];
            let yuv = raw_frames(&input, Some(TO_YUV420), "yuv420p", yuv_bytes).remove(0);
            let through = raw_frames(&input, Some(THROUGH_YUV420), "rgb24", rgb_bytes).remove(0);
            (k, yuv, image::open(&png).unwrap().to_rgb8().into_raw(), through)
        })
        .collect();
    for (ext, codec) in [("mp4", "h264"), ("webm", "vp9")] {
        let dir = scratch(&format!("movie-{ext}"));
        let movie = dir.join(format!("adk.{ext}"));
        adk("0..98", "256x256", &movie).ok();
        let want_probe = Probe {
            codec: codec.to_string(),
            width: 256,
            height: 256,
            rate: "25/1".to_string(),
            frames: 98,
            pix_fmt: "yuv420p".to_string(),
            color: "bt709 tv bt709 iec61966-2-1".to_string(),
        };
        assert_eq!(probe(&movie), want_probe, "{ext}: what ffprobe reads");
        let input = ["-i", movie.to_str().unwrap()];
        let got_yuv = raw_frames(&input, None, "yuv420p", yuv_bytes);
        let got_rgb = raw_frames(&input, None, "rgb24", rgb_bytes);
        assert_eq!((got_yuv.len(), got_rgb.len()), (98, 98), "{ext}: decoded frames");
        for (k, want_yuv, want_rgb, through) in &wants {
            let (yuv, rgb) = (psnr(want_yuv, &got_yuv[*k]), psnr(want_rgb, &got_rgb[*k]));
            let ceiling = psnr(want_rgb, through);
            let (got_mean, want_mean) = (mean_colour(&got_rgb[*k]), mean_colour(through));
            let shift = (0..3).map(|c| (got_mean[c] - want_mean[c]).abs()).fold(0.0, f64::max);
            eprintln!(
                "{ext} frame {k}: PSNR {yuv:.2} dB Y'CbCr 4:2:0, {rgb:.2} dB RGB (4:2:0 without a codec {ceiling:.2}); mean colour moved {shift:.2}"
            );
            assert!(yuv >= 35.0, "{ext} frame {k}: PSNR {yuv:.2} dB against the PNG in Y'CbCr 4:2:0, under 35");
            assert!(
                rgb >= ceiling - RGB_CODEC_LOSS_DB,
                "{ext} frame {k}: PSNR {rgb:.2} dB against the PNG in RGB, more than {RGB_CODEC_LOSS_DB} dB under 4:2:0 without a codec ({ceiling:.2})"
            );
            assert!(
                shift <= MEAN_SHIFT,
                "{ext} frame {k}: mean colour {got_mean:.2?} decoded, {want_mean:.2?} through 4:2:0 without a codec: more than {MEAN_SHIFT} apart"
            );
        }
        let csv = dir.join(format!("adk.{ext}.csv"));
        assert_eq!(names(&dir), vec![format!("adk.{ext}"), format!("adk.{ext}.csv")], "{ext}: what the movie render left");
        let rows = csv_rows(&csv);
        assert_eq!(rows.iter().map(|r| r.0).collect::<Vec<_>>(), (0..98).collect::<Vec<u64>>(), "{ext}: the CSV's frames");
        assert!(rows.iter().all(|r| r.1 == movie.to_str().unwrap()), "{ext}: the CSV's file column names the movie: {rows:?}");
    }
}

/// The squared RGB distance of two colours.
fn dist2(a: [u8; 3], b: [u8; 3]) -> i32 {
    (0..3).map(|i| (i32::from(a[i]) - i32::from(b[i])).pow(2)).sum()
}

/// Checks `movie`, a GIF, against the PNGs `png(k)`: `count` frames of
/// `size`, looping, `delay` hundredths each; each frame has its own
/// palette of at most 256 colours, every pixel is the colour of that
/// palette nearest to the PNG's pixel (squared RGB distance; of equals,
/// any), and the frame is within `min_psnr` dB of the PNG. The worst
/// frame's PSNR.
fn assert_gif_frames(movie: &Path, png: impl Fn(usize) -> PathBuf, count: usize, size: (u16, u16), delay: u16, min_psnr: f64) -> f64 {
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::Indexed);
    let mut decoder = options.read_info(std::fs::File::open(movie).unwrap()).unwrap();
    assert_eq!(decoder.repeat(), gif::Repeat::Infinite, "the GIF loops");
    let global = decoder.global_palette().map(<[u8]>::to_vec);
    let mut k = 0;
    let mut worst = f64::INFINITY;
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        assert!(k < count, "more than {count} frames");
        assert_eq!((frame.width, frame.height, frame.left, frame.top), (size.0, size.1, 0, 0), "frame {k}: a whole frame");
        assert_eq!(frame.delay, delay, "frame {k}: its delay in hundredths of a second");
        let palette: Vec<[u8; 3]> =
            frame.palette.clone().or_else(|| global.clone()).expect("a palette").chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        assert!(palette.len() <= 256, "frame {k}: {} colours", palette.len());
        let png = image::open(png(k)).unwrap().to_rgb8();
        let mut got = Vec::with_capacity(png.as_raw().len());
        for (i, &index) in frame.buffer.iter().enumerate() {
            let want = png.as_raw()[3 * i..3 * i + 3].try_into().unwrap();
            let colour = palette[usize::from(index)];
            let nearest = palette.iter().map(|&c| dist2(c, want)).min().unwrap();
            assert!(
                dist2(colour, want) <= nearest,
                "frame {k} pixel {i}: {colour:?} for {want:?}, at {} where the palette's nearest is at {nearest}",
                dist2(colour, want)
            );
            got.extend(colour);
        }
        let p = psnr(png.as_raw(), &got);
        worst = worst.min(p);
        assert!(p >= min_psnr, "frame {k}: PSNR {p:.2} dB against the PNG, under {min_psnr}");
        k += 1;
    }
    assert_eq!(k, count, "frames in the GIF");
    worst
}

/// The GIF of frames 0..10 at 50 fps: 10 frames of 256x256 looping for
/// ever, 2 hundredths of a second each; frame k equals PNG k after the GIF
/// palette, the bound stated in docs/trajectories.md: each frame has its
/// own palette of at most 256 colours, every pixel is the colour of that
/// palette nearest to the PNG's pixel (squared RGB distance; of equals,
/// any), and the frame is within 30 dB PSNR of the PNG.
#[test]
fn gif_frames_are_the_pngs_after_each_frames_palette() {
    let refs = scratch("gif-refs");
    reference_frames(&refs);
    let dir = scratch("movie-gif");
    let movie = dir.join("adk.gif");
    adk("0..10", "256x256", &movie).args(["--fps", "50"]).ok();
    assert_eq!(names(&dir), vec!["adk.gif", "adk.gif.csv"], "what the GIF render left");
    let worst = assert_gif_frames(&movie, |k| refs.join(format!("f_{k:04}.png")), 10, (256, 256), 2, 30.0);
    eprintln!("GIF: the worst frame's PSNR {worst:.2} dB");
}

/// Movies of what else `render --frames` renders: a turntable about a
/// molecule (1A8O, `--turntable 4`) and an animated scene (fig16), each a
/// GIF of the PNG batch's frames (as above), whose frames differ from one
/// another (they move).
#[test]
fn a_turntable_and_an_animated_scene_make_movies_of_their_frames() {
    let pdb = repo_root().join("tests/data/molecules/1A8O.pdb");
    let cases: [(&str, Vec<String>); 2] = [
        ("turntable", vec![pdb.to_str().unwrap().to_string(), "--turntable".into(), "4".into()]),
        ("animated", vec![repo_root().join("scenes/fig16.ron").to_str().unwrap().to_string()]),
    ];
    for (name, input) in cases {
        let dir = scratch(&format!("movie-{name}"));
        let render = |out: &Path| {
            isomarch(["render"]).args(&input).args(["--frames", "0..4", "--fps", "2", "--size", "48x48", "-o"]).arg(out).current_dir(repo_root()).ok()
        };
        render(&dir.join("f_#.png"));
        let movie = dir.join(format!("{name}.gif"));
        render(&movie);
        assert_gif_frames(&movie, |k| dir.join(format!("f_{k}.png")), 4, (48, 48), 50, 25.0);
        let first = std::fs::read(dir.join("f_0.png")).unwrap();
        assert!((1..4).all(|k| std::fs::read(dir.join(format!("f_{k}.png"))).unwrap() != first), "{name}: the frames do not move");
    }
}

/// A movie render stopped by SIGTERM halfway ends with status 130 and
/// leaves neither the movie nor its temporary file nor its statistics; so
/// does one stopped by two Ctrl-C at once (the second quits without
/// waiting for the frame in flight, stopping ffmpeg and removing the file).
#[test]
fn a_movie_render_stopped_by_sigterm_leaves_no_file() {
    let cases: [(&str, &[i32]); 3] = [("mp4", &[libc::SIGTERM]), ("gif", &[libc::SIGTERM]), ("mp4", &[libc::SIGINT, libc::SIGINT])];
    for (ext, signals) in cases {
        let what = format!("{ext} after {} signal(s)", signals.len());
        let dir = scratch(&format!("movie-stop-{ext}-{}", signals.len()));
        let movie = dir.join(format!("adk.{ext}"));
        let mut child = adk("0..98", "128x128", &movie).stderr(Stdio::piped()).spawn();
        // The encoder's temporary file appears with the first frame.
        let start = Instant::now();
        while !names(&dir).iter().any(|n| n.ends_with(".tmp")) {
            assert!(start.elapsed() < Duration::from_secs(120), "{what}: no temporary file after two minutes");
            assert!(child.try_wait().unwrap().is_none(), "{what}: the render ended before it could be stopped");
            std::thread::sleep(Duration::from_millis(10));
        }
        for &signal in signals {
            // SAFETY: kill(2) on our own child's pid.
            assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
            std::thread::sleep(Duration::from_millis(20));
        }
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(130), "{what}: the render ends with status 130:\n{stderr}");
        if signals.len() == 1 {
            assert!(stderr.contains("not written"), "{what}: {stderr}");
        }
        assert_eq!(names(&dir), Vec::<String>::new(), "{what}: a stopped movie render left files");
    }
}

/// Without ffmpeg, an MP4 or WebM is refused in one line naming the Debian
/// package, before the molecule is read (so before any frame); a GIF needs
/// no ffmpeg. An odd size, a shard, --skip-existing and a transparent
/// background are refused in one line too, nothing written.
#[test]
fn a_movie_that_cannot_be_written_is_refused_in_one_line_before_any_frame() {
    let dir = scratch("movie-refused");
    let no_tools = scratch("movie-no-tools");
    for ext in ["mp4", "webm"] {
        let err = adk("0..98", "64x64", &dir.join(format!("a.{ext}"))).env("PATH", &no_tools).fails_in_one_line();
        assert!(err.contains("needs ffmpeg") && err.contains("apt-get install ffmpeg"), "{ext}: {err}");
    }
    adk("0..2", "64x64", &dir.join("a.gif")).env("PATH", &no_tools).ok();
    std::fs::remove_file(dir.join("a.gif")).unwrap();
    std::fs::remove_file(dir.join("a.gif.csv")).unwrap();
    let refused: [(&[&str], &str); 4] = [
        (&["--size", "63x64"], "even width and height"),
        (&["--shard", "0/2"], "--shard"),
        (&["--skip-existing"], "--skip-existing"),
        (&["--transparent-background"], "no transparent background"),
    ];
    for (flags, says) in refused {
        let err = isomarch(["render", &data("adk.psf"), &data("adk_dims.dcd"), "--frames", "0..4", "-o"]).arg(dir.join("a.mp4")).args(flags).fails();
        let last = err.lines().last().unwrap_or_default();
        assert!(last.starts_with("error: ") && last.contains(says), "{flags:?}: {err}");
    }
    assert_eq!(names(&dir), Vec::<String>::new(), "a refused movie wrote something");
}

/// `encode` joins the PNGs that two shards wrote into the movie that one
/// movie render writes, byte for byte (MP4 and GIF); with a frame removed
/// it refuses in one line naming that frame's file, and writes nothing.
#[test]
fn encode_of_two_shards_frames_is_the_movie_of_one_render() {
    let dir = scratch("encode-shards");
    let pattern = dir.join("shards/f_####.png");
    for shard in ["0/2", "1/2"] {
        adk("0..7", "64x64", &pattern).args(["--shard", shard]).ok();
    }
    for ext in ["mp4", "gif"] {
        let one = dir.join(format!("one.{ext}"));
        adk("0..7", "64x64", &one).ok();
        let joined = dir.join(format!("joined.{ext}"));
        isomarch(["encode", pattern.to_str().unwrap(), "-o"]).arg(&joined).ok();
        let (a, b) = (std::fs::read(&one).unwrap(), std::fs::read(&joined).unwrap());
        assert!(a == b, "{ext}: encode of the shards' frames differs from one render's movie ({} and {} bytes)", a.len(), b.len());
    }
    // Only frames 2 to 4, as --frames asks.
    let part = dir.join("part.mp4");
    isomarch(["encode", pattern.to_str().unwrap(), "--frames", "2..5", "-o"]).arg(&part).ok();
    assert_eq!(probe(&part).frames, 3, "encode --frames 2..5");
    std::fs::remove_file(dir.join("shards/f_0003.png")).unwrap();
    let gap = dir.join("gap.mp4");
    let err = isomarch(["encode", pattern.to_str().unwrap(), "-o"]).arg(&gap).fails_in_one_line();
    assert!(err.contains("f_0003.png: missing: frame 3 is the first of frames 0..7 not on disk"), "{err}");
    assert!(!gap.exists() && !names(&dir).iter().any(|n| n.ends_with(".tmp")), "a refused encode wrote something");
}
