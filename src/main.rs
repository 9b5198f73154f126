//! The `isomarch` binary: parses the command line, runs the command
//! (src/cli/), and maps its result to an exit status: 0, 1 for an error
//! (one line on stderr), 3 when the GPU missed its deadline, 130 when a
//! batch was interrupted.

mod cli;
#[cfg(feature = "window")]
mod view;

use std::process::ExitCode;

use clap::Parser;

use isomarch::gpu::GpuError;

fn main() -> ExitCode {
    // A closed pipe (`isomarch frames ... | head`) ends the process quietly,
    // as it ends command-line tools written in C: Rust ignores SIGPIPE, so
    // each write would fail with "Broken pipe" and print! would panic.
    // SAFETY: the first thing main does, before any other thread exists.
    unsafe { libc::signal(libc::SIGPIPE, libc::SIG_DFL) };
    let cli = cli::Cli::parse();
    match cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<cli::Interrupted>().is_some() => ExitCode::from(130),
        Err(e) => {
            eprintln!("error: {e:#}");
            if e.downcast_ref::<GpuError>().is_some_and(|g| matches!(g, GpuError::DeadlineExceeded(_))) {
                // The GPU may still run our work: leave now without running
                // exit handlers, which would tear down the driver under it.
                // SAFETY: _exit ends the process at once; nothing runs after.
                unsafe { libc::_exit(3) };
            }
            ExitCode::FAILURE
        }
    }
}
