//! The GPU harness itself: validation catches misuse, deadlines end hung
//! work, `info` lists devices.

mod common;

use std::process::Command;
use std::time::{Duration, Instant};

use ash::vk;
use common::*;

#[test]
fn validation_canary_catches_a_dispatch_without_a_pipeline() {
    let ctx = gpu();
    assert!(ctx.validation_enabled());
    let d = &ctx.device;
    // SAFETY: a deliberate misuse, recorded but never submitted.
    unsafe {
        let pool = d
            .create_command_pool(&vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family), None)
            .unwrap();
        let cmd = d
            .allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default().command_pool(pool).level(vk::CommandBufferLevel::PRIMARY).command_buffer_count(1),
            )
            .unwrap()[0];
        d.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default()).unwrap();
        d.cmd_dispatch(cmd, 1, 1, 1);
        let _ = d.end_command_buffer(cmd);
        d.destroy_command_pool(pool, None);
    }
    let messages = ctx.validation_messages();
    assert!(!messages.is_empty(), "the validation layer did not report a dispatch with no pipeline bound");
    assert!(messages.iter().any(|m| m.contains("vkCmdDispatch")), "unexpected messages: {messages:?}");
}

#[test]
fn info_lists_a_device() {
    let run = Command::new(bin()).arg("info").output().unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(stdout.contains("max storage buffer"), "{stdout}");
    assert!(stdout.starts_with("0: "), "{stdout}");
}

#[test]
fn a_passed_deadline_is_reported_and_the_process_exits() {
    // Far more work than a second of lavapipe: sphere tracing fig10 at a
    // tiny minimum step on a large image.
    let dir = scratch("deadline");
    let out = dir.join("never.png");
    let start = Instant::now();
    let run = Command::new(bin())
        .args(["render", "scenes/fig10.ron", "--size", "1024x1024", "--method", "sphere", "--min-step", "1e-6"])
        .args(["--max-steps", "100000", "--timeout", "1", "-o"])
        .arg(&out)
        .current_dir(repo_root())
        .output()
        .unwrap();
    let elapsed = start.elapsed();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("deadline"), "{stderr}");
    assert!(!out.exists(), "a partial image was written");
    // Generous: parallel tests share two cores.
    assert!(elapsed < Duration::from_secs(60), "took {elapsed:?} to give up");
}

#[test]
fn render_writes_image_heatmap_exr_and_stats() {
    let dir = scratch("render-outputs");
    let run = Command::new(bin())
        .args(["render", "scenes/default.ron", "--size", "48x40", "--method", "quadratic-taylor", "--steps-max", "75"])
        .args(["--aov", "depth,steps,normal", "--validation", "-o"])
        .arg(dir.join("img.png"))
        .arg("--heatmap")
        .arg(dir.join("steps.png"))
        .arg("--stats")
        .arg(dir.join("stats.json"))
        .current_dir(repo_root())
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let img = image::open(dir.join("img.png")).unwrap();
    assert_eq!((img.width(), img.height()), (48, 40));
    let heat = image::open(dir.join("steps.png")).unwrap();
    assert_eq!(heat.width(), 48);
    assert!(heat.height() > 40, "the heatmap has no legend");
    let stats: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["method"], "quadratic-taylor");
    assert_eq!(stats["rays"], 48 * 40);
    assert!(stats["steps_per_ray"].as_f64().unwrap() > 1.0);
    let exr = exr::prelude::read_all_flat_layers_from_file(dir.join("img.exr")).unwrap();
    let names: Vec<String> = exr.layer_data[0].channel_data.list.iter().map(|c| c.name.to_string()).collect();
    for want in ["Z", "steps", "normal.X", "normal.Y", "normal.Z"] {
        assert!(names.iter().any(|n| n == want), "channel {want} missing from {names:?}");
    }
    let hit_rate = stats["hit_rate"].as_f64().unwrap();
    let z = &exr.layer_data[0].channel_data.list.iter().find(|c| c.name.to_string() == "Z").unwrap().sample_data;
    let finite = z.values_as_f32().filter(|v| v.is_finite()).count();
    assert_eq!(finite, (hit_rate * 48.0 * 40.0).round() as usize, "depth is finite exactly where rays hit");
}
