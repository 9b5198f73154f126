//! Frames made on the GPU (src/render/frame.rs, shaders/look.comp): the
//! camera rays the shader makes are the host's within f32, the statistics
//! it reduces are the host's of the same results, the images are the
//! host path's within one 8-bit level, and a frame reads back its image
//! and a few words in at most 3 fence waits.

use std::path::Path;

use crate::common::*;
use isomarch::layout::FLAG_HIT;
use isomarch::output::{Frame, MarchStats};
use isomarch::render::frame::Readback;
use isomarch::render::offscreen::{Effects, SAMPLE_SEED};
use isomarch::render::rays::{camera_rays_through, subpixel};
use isomarch::render::{MarchOptions, Renderer};
use isomarch::scene::{Projection, Scene};

/// A scene file or a molecule with the default look, posed at time 0 and
/// recentred as a frame is rendered.
fn load(path: &str) -> Scene {
    let file = repo_root().join(path);
    let s = if path.ends_with(".ron") {
        Scene::load(&file).unwrap()
    } else {
        isomarch::molecule::build::load_scene(&file, &isomarch::molecule::MoleculeOptions::default()).unwrap().0
    };
    s.at_time(0.0).recentred_on_camera()
}

/// Every camera ray look.comp makes (perspective and orthographic, one
/// sample and the third of four, a frame of partial tiles) is the host's
/// f64 ray rounded to f32, bit for bit: look.comp makes it in f64 in the
/// host's order of operations (lavapipe rounds f64 as IEEE asks; a device
/// whose f64 division or square root is less exact could differ in a last
/// bit).
#[test]
fn the_shaders_camera_rays_are_the_hosts() {
    let ctx = gpu();
    for (path, ortho) in [("scenes/fig10.ron", false), ("tests/data/molecules/1A8O.pdb", false), ("tests/data/molecules/1A8O.pdb", true)] {
        let mut scene = load(path);
        if ortho {
            scene.camera.projection = Projection::Orthographic { height: 20.0 };
        }
        let mut renderer = Renderer::new(&ctx, &scene).unwrap();
        for (sample, samples) in [(0, 1), (2, 4)] {
            let (w, h) = (61, 37);
            let gpu_rays = renderer.gpu_camera_rays(&scene, (w, h), sample, samples).unwrap();
            let (host, pixels) = camera_rays_through(&scene.camera, w, h, &scene.bounds, |p| subpixel(p, sample, samples, SAMPLE_SEED));
            assert_eq!(gpu_rays.len(), host.len(), "{path}: ray count");
            let mut compared = 0;
            for (i, (g, r)) in gpu_rays.iter().zip(&host).enumerate() {
                let what = format!("{path} (ortho {ortho}), sample {sample} of {samples}, ray {i} (pixel {:?})", pixels[i]);
                let bits = |v: &[f32; 4]| v.map(f32::to_bits);
                assert!(bits(&g.o) == bits(&r.o) && bits(&g.d) == bits(&r.d), "{what}: {g:?} against the host's {r:?}");
                compared += usize::from(pixels[i].is_some() && r.o[3] <= r.d[3]);
            }
            assert!(compared > (w * h) as usize / 4, "{path}: only {compared} rays meet the box: a test of nothing");
        }
    }
    assert_no_validation(&ctx);
}

/// What the GPU reduced is what the host reduces from the same results
/// (every count, the largest step count), and its image is the host's
/// composition of those results within one level (sRGB's power in f32 on
/// both sides); the image is not blank.
#[test]
fn the_gpu_reduces_what_the_host_would() {
    let ctx = gpu();
    for path in ["tests/data/molecules/1A8O.pdb", "scenes/hrbf8.ron"] {
        let scene = load(path);
        let mut renderer = Renderer::for_camera(&ctx, &scene, std::time::Duration::from_secs(300)).unwrap();
        let options = MarchOptions::for_scene(&scene);
        let method = scene.marching.method;
        let (w, h) = (72, 56);
        assert!(renderer.gpu_frame_applies(&options, &scene, (w, h)), "{path}: the GPU frame should apply");
        renderer.prepare_camera(method, &options, &scene.camera, w, h).unwrap();
        let made = renderer.gpu_frame_reading(method, options, &scene, (w, h), 1, &Effects::default(), Readback::ImageAndRays).unwrap();
        let (rays, results) = made.last.unwrap();
        let (_, pixels) = camera_rays_through(&scene.camera, w, h, &scene.bounds, |_| (0.5, 0.5));
        let kept: Vec<_> = results.iter().zip(&pixels).filter(|(_, p)| p.is_some()).map(|(r, _)| r).collect();
        let host = MarchStats::of(kept.iter().copied(), None);
        let gpu = MarchStats { gpu_ms: None, ns_per_ray: None, ns_per_eval: None, ns_per_turn: None, ..made.stats.clone() };
        assert_eq!(gpu, host, "{path}: the GPU's statistics against the host's of the same results");
        let hits = kept.iter().filter(|r| r.counts[3] & FLAG_HIT != 0).count();
        assert!(hits > 100 && hits < kept.len() - 100, "{path}: {hits} hits of {}: nothing to see", kept.len());
        // Ray i's pixel from the GPU's own rays: the same tile order.
        assert_eq!(rays.len(), pixels.len());
        let composed = Frame::from_results(w, h, &results, &pixels).shaded();
        let mut off = 0;
        for (i, p) in composed.pixels().enumerate() {
            let g = &made.rgba[4 * i..4 * i + 3];
            let most = p.0.iter().zip(g).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
            assert!(most <= 1, "{path}: pixel {i}: the GPU's {g:?} against the host's {:?}", p.0);
            off += usize::from(most > 0);
        }
        assert!(off * 100 <= kept.len(), "{path}: {off} pixels a level off");
    }
    assert_no_validation(&ctx);
}

/// Decodes a PNG as RGB8.
fn rgb(path: &Path) -> image::RgbImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8()
}

/// `render` makes these frames on the GPU, shadows and occlusion included:
/// each is the host path's (`ISOMARCH_GPU_FRAME=off`) within one 8-bit
/// level at 99.9% of its pixels and within 2 at all, has the host's
/// statistics (the same camera rays; hit rate within 0.002, steps within
/// 0.2%), casts the same shadow and occlusion rays, reads back at most 4
/// bytes a pixel and 64 KiB, and waits on at most 3 fences (the pipelines
/// warmed up together, the index's build where the frame needs it, the
/// frame); the host path reads back 64 bytes a ray.
#[test]
fn render_makes_the_hosts_image_on_the_gpu() {
    let dir = scratch("gpu-frame");
    let (w, h) = (80u32, 64u32);
    let cases: [(&str, &[&str]); 8] = [
        ("scenes/fig10.ron", &["--samples", "4"]),
        ("scenes/default.ron", &[]),
        ("scenes/fig10-gauss.ron", &["--ortho", "--ao", "4"]),
        ("scenes/hrbf8.ron", &["--shadows"]),
        ("tests/data/molecules/1A8O.pdb", &["--depth-cue", "0.3:1", "--outline", "2"]),
        ("tests/data/molecules/1A8O.pdb", &["--samples", "2", "--outline", "1", "--shadows", "--ao", "4"]),
        ("tests/data/molecules/1A8O.pdb", &["--ortho", "--shadows"]),
        ("tests/data/molecules/6WG6.cif.gz", &["--shadows", "--ao", "8"]),
    ];
    for (k, (path, flags)) in cases.iter().enumerate() {
        let run = |name: &str, gpu: bool| {
            let (png, stats) = (dir.join(format!("{k}-{name}.png")), dir.join(format!("{k}-{name}.json")));
            let mut cmd = isomarch(["render", path, "--size", &format!("{w}x{h}")]).args(flags.iter()).arg("-o").arg(&png).arg("--stats").arg(&stats);
            if !gpu {
                cmd = cmd.env("ISOMARCH_GPU_FRAME", "off");
            }
            cmd.ok();
            (rgb(&png), json(&stats))
        };
        let ((g, gs), (c, cs)) = (run("gpu", true), run("host", false));
        let what = format!("{path} {}", flags.join(" "));
        let mut off = 0;
        for (p, q) in g.pixels().zip(c.pixels()) {
            let most = p.0.iter().zip(q.0).map(|(a, b)| a.abs_diff(b)).max().unwrap();
            assert!(most <= 2, "{what}: a pixel {most} levels off ({:?} against {:?})", p.0, q.0);
            off += usize::from(most > 1);
        }
        assert!(off * 1000 <= (w * h) as usize, "{what}: {off} pixels more than a level off");
        let lit = g.pixels().filter(|p| p.0 != g.get_pixel(0, 0).0).count();
        assert!(lit > (w * h) as usize / 20, "{what}: {lit} pixels differ from the corner's: a blank image");
        let f = |j: &serde_json::Value, key: &str| j[key].as_f64().unwrap_or_else(|| panic!("{what}: no {key} in --stats"));
        assert!((f(&gs, "hit_rate") - f(&cs, "hit_rate")).abs() <= 0.002, "{what}: hit rates {} and {}", f(&gs, "hit_rate"), f(&cs, "hit_rate"));
        assert!((f(&gs, "steps_per_ray") / f(&cs, "steps_per_ray") - 1.0).abs() <= 0.002, "{what}: steps per ray");
        assert_eq!(f(&gs, "rays"), f(&cs, "rays"), "{what}: rays counted");
        let limit = f64::from(4 * w * h + 65_536);
        assert!(f(&gs, "readback_bytes") <= limit, "{what}: {} bytes read back, more than {limit}", f(&gs, "readback_bytes"));
        assert!(f(&cs, "readback_bytes") >= f64::from(64 * w * h), "{what}: the host path read back less than its rays' results");
        assert!(f(&gs, "submits") <= 3.0, "{what}: {} fence waits", f(&gs, "submits"));
        // The same shadow and occlusion rays cast, from the same hits.
        for key in ["shadow_rays", "ao_rays"] {
            assert_eq!(gs["any_hit"][key], cs["any_hit"][key], "{what}: {key}");
        }
        if flags.contains(&"--shadows") {
            assert!(f(&gs["any_hit"], "shadow_rays") > 1000.0, "{what}: no shadow rays");
        }
        if flags.contains(&"--ao") {
            let (a, b) = (f(&gs["any_hit"], "ao_steps_per_ray"), f(&cs["any_hit"], "ao_steps_per_ray"));
            assert!((a / b - 1.0).abs() < 1e-3, "{what}: occlusion steps per ray {a} against {b}");
        }
    }
}

/// What a window shows of an image on the GPU (present.comp, through
/// `gpu::scale`): each window pixel the image's pixel under its top-left
/// corner (`scale::nearest`, the canvas's scaling, so a screenshot read
/// back equals the window), R and B swapped for a BGRA swapchain, alpha
/// 255, up, down, by odd ratios and 1:1.
#[test]
fn a_window_shows_the_gpus_image_scaled_by_nearest_neighbour() {
    use isomarch::gpu::scale::{nearest, scale_image};
    let ctx = gpu();
    // Every pixel different, alpha not 255: a pixel taken from the wrong
    // place, a swizzle or the alpha shows.
    let from = (13u32, 7u32);
    let image: Vec<u32> = (0..from.0 * from.1).map(|i| (i * 2_654_435_761u32) & 0x7fff_ffff).collect();
    for to in [(13, 7), (40, 21), (97, 64), (5, 3), (1, 1), (13, 30)] {
        for bgra in [false, true] {
            let shown = scale_image(&ctx, &image, from, to, bgra).unwrap();
            for y in 0..to.1 {
                for x in 0..to.0 {
                    let c = image[(nearest(y, from.1, to.1) * from.0 + nearest(x, from.0, to.0)) as usize];
                    let c = if bgra { (c & 0x0000_ff00) | ((c & 0xff) << 16) | ((c >> 16) & 0xff) } else { c & 0x00ff_ffff };
                    let got = shown[(y * to.0 + x) as usize];
                    assert_eq!(got, c | 0xff00_0000, "{from:?} to {to:?} (bgra {bgra}): pixel {x},{y} is {got:#010x}, not {:#010x}", c | 0xff00_0000);
                }
            }
        }
    }
    // 1:1 is the image itself, opaque.
    let same = scale_image(&ctx, &image, from, from, false).unwrap();
    assert!(same.iter().zip(&image).all(|(s, i)| *s == (i | 0xff00_0000)));
    assert_no_validation(&ctx);
}
