//! The integration tests: one binary, a module per area (each file's
//! header says what it checks), so the library is linked once. The window
//! (tests/viewer.rs, under Xvfb) and the cluster (tests/slurm.rs) keep their
//! own binaries. Run one area with `cargo test --release --test tests AREA::`.

mod common;

mod antialias;
mod aovs;
mod batch;
mod bench_cli;
mod comparators;
mod dispatch;
mod extremes;
mod fuzz_corpus;
mod generate;
mod golden;
mod gpu_frame;
mod gpu_harness;
mod hrbf;
mod inclusion;
mod index;
mod layering;
mod lighting;
mod limits;
mod marching;
mod memory;
mod molecules;
mod movies;
mod optics;
mod planes;
mod refinement;
mod scaling;
mod scene_files;
mod scene_input;
mod selections;
mod specialise;
mod tile_build;
mod trajectories;
mod view_flags;
