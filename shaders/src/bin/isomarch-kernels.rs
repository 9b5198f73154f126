//! Compiles every kernel that the cache does not hold yet, one after
//! another, so that later programs find them there: scripts/test.sh runs
//! it beside the test build, and a cluster job can run it once before an
//! array of renders. Says on stderr which it compiled; exits 1 naming the
//! kernel that failed.

fn main() {
    let Some(dir) = isomarch_shaders::cache_dir() else {
        eprintln!("isomarch-kernels: no cache folder (ISOMARCH_SHADER_CACHE is empty, or there is no home): nothing to keep the kernels in");
        std::process::exit(1);
    };
    let started = std::time::Instant::now();
    for kernel in isomarch_shaders::Kernel::ALL {
        if let Err(e) = kernel.spirv() {
            eprintln!("isomarch-kernels: {e}");
            std::process::exit(1);
        }
    }
    eprintln!(
        "isomarch-kernels: all {} kernels in {} ({:.1} s)",
        isomarch_shaders::Kernel::ALL.len(),
        dir.display(),
        started.elapsed().as_secs_f64()
    );
}
