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
