//! The camera's tile lists ([`super::tiles`]) built on the GPU by
//! tiles.comp's passes, in two submissions (one where the last frame's
//! entries fit with room to spare), as 3D Gaussian splatting builds its
//! tile lists: each primitive's pixels and depth, the primitives sorted by
//! depth, one entry per (tile, primitive) made in that order, the entries
//! sorted by list with a stable radix sort (so each list stays in depth
//! order), and each list's start found among them.
//!
//! The pixels are found in f64 with the host's arithmetic, pads and order
//! of operations (`precise`: nothing fused), from the same f32 primitives
//! and the view the host computes, so the lists are the host's where the
//! device rounds f64 as IEEE asks (lavapipe does), and the host's
//! conservative argument (`render::tiles`: the pads cover the f32 rays
//! and sphere tests) carries over unchanged. Where a device's f64 division
//! or root is off by an ulp, a bound that lands within 1e-12 pixel of a
//! pixel's edge may move by one pixel: beyond the 1e-3 pixel pad, it
//! only widens a list.
//!
//! The sort is a least-significant-digit radix sort of (key, value) words,
//! up to 8 bits a pass and only the bits a key needs (20 for the depth, as
//! many as the lists' count needs for the tiles): per chunk of keys a
//! subgroup counts its digits (HISTOGRAM), a prefix sum over digits then
//! chunks gives each chunk's place for each digit (SCAN_*), and the subgroup
//! writes its keys there in order (SCATTER: lanes of one digit ranked by
//! ballots). No workgroup barrier but the prefix sums', whose cost lavapipe
//! feels most.
//!
//! The entries' total is known on the GPU alone: passes over the entries
//! read it there (`TILE_COUNT_ENTRIES`), and the host reads it back with
//! the longest list, once the lists are made, to size the march's slices.
//! Where the entries outgrow the buffers, the lists are made again in
//! larger ones.

use std::time::Instant;

use anyhow::{Result, bail};
use ash::vk;

use super::tiles::View;
use crate::gpu::{Buffer, ComputePipeline, Context, Role, Submitter, Transfers};
use crate::layout::{self, GpuTileBuild, TexelFormat};
use crate::scene::Camera;

/// Keys in a subgroup's chunk of the sort: a chunk's histogram is one
/// column of the prefix sum, so fewer, larger chunks on a CPU's driver
/// (whose workgroups run one after another) and more, smaller ones where
/// many workgroups run at once.
fn chunk_keys(ctx: &Context) -> u32 {
    if ctx.info.is_cpu() { 2048 } else { 512 }
}

/// Set, each pass of a build is submitted and timed alone, and its time
/// printed (where the build's time goes).
const PROFILE_SWITCH: &str = "ISOMARCH_TILE_PROFILE";

/// Bits of a radix pass's digit at most.
const DIGIT_BITS: u32 = 8;
/// Bits of the depth key (tiles.comp: the depth word's high 19 bits, and
/// one more for a primitive no ray meets).
const DEPTH_KEY_BITS: u32 = 32 - layout::TILE_PIXEL_BITS;

/// The radix passes of a key of `bits` bits: (first bit, width), as few as
/// [`DIGIT_BITS`] allows, of equal widths.
fn digits(bits: u32) -> Vec<(u32, u32)> {
    let bits = bits.max(1);
    let passes = bits.div_ceil(DIGIT_BITS);
    let width = bits.div_ceil(passes);
    (0..passes).map(|p| (p * width, width.min(bits - p * width))).collect()
}

/// Whether `ctx`'s device can build the lists: 64-bit floats, subgroup
/// ballots and sums, subgroups of 4 to 64 lanes (tiles.comp keeps 16
/// subgroups' digit counts per workgroup of 64).
pub fn supported(ctx: &Context) -> bool {
    ctx.info.float64 && ctx.info.subgroup_arithmetic && ctx.info.subgroup_ballot && (4..=64).contains(&ctx.info.subgroup_size)
}

/// The host's name for what the build made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Built {
    pub entries: usize,
    pub longest: usize,
    pub crowd: usize,
}

/// tiles.comp's pipelines, one per pass, and the buffers the build alone
/// uses, sized for `primitives` and `capacity` entries.
pub(super) struct TileBuild {
    pipelines: Vec<ComputePipeline>,
    params: Buffer,
    prim_tiles: Buffer,
    keys: Buffer,
    values: Buffer,
    scan: Buffer,
    emitted: Buffer,
    stats: Buffer,
    primitives: u64,
    /// Entries the buffers hold.
    pub capacity: u64,
    /// Where the second half of the keys and values starts.
    half: u64,
    /// Where the prefix sums' partials start in `scan`.
    partials: u64,
    chunk: u32,
    subgroup_size: u32,
    /// Workgroups of one row of a dispatch.
    max_row: u32,
    /// The entries of the last build with these buffers.
    last_entries: Option<u64>,
}

impl TileBuild {
    pub(super) fn new(ctx: &std::sync::Arc<Context>, primitives: u64, capacity: u64) -> Result<TileBuild> {
        let spirv = isomarch_shaders::Kernel::Tiles.spirv().map_err(anyhow::Error::msg)?;
        let chunk = chunk_keys(ctx);
        let half = primitives.max(capacity).max(1);
        // The histograms' columns (a chunk's digit counts), or the tile
        // counts of every primitive and the total.
        let values = ((1u64 << DIGIT_BITS) * half.div_ceil(u64::from(chunk))).max(primitives + 1);
        let partials = values.div_ceil(u64::from(layout::TILE_SCAN_BLOCK)) + 1;
        Ok(TileBuild {
            pipelines: (0..layout::TILE_PASSES)
                .map(|pass| ComputePipeline::new(ctx, spirv, layout::TILES_BINDINGS, 32, &[(layout::TILE_PASS_CONSTANT, pass)]))
                .collect::<Result<_>>()?,
            params: Buffer::uniform(ctx, "tile build", &[GpuTileBuild::default()])?,
            prim_tiles: Buffer::device(ctx, "primitives' tiles", 16 * primitives.max(1))?,
            keys: Buffer::device(ctx, "tile sort keys", 8 * half)?,
            values: Buffer::device(ctx, "tile sort values", 8 * half)?,
            scan: Buffer::device(ctx, "tile prefix sums", 4 * (values + partials))?,
            emitted: Buffer::device(ctx, "tile entries made", 8 * capacity.max(1))?,
            stats: Buffer::with_usage(
                ctx,
                "tile statistics",
                4 * u64::from(layout::TILE_STAT_WORDS),
                vk::BufferUsageFlags::STORAGE_BUFFER,
                Role::Device,
            )?,
            primitives,
            capacity,
            half,
            partials: values,
            chunk,
            subgroup_size: ctx.info.subgroup_size,
            max_row: ctx.info.max_compute_workgroup_count[0].min(65_535),
            last_entries: None,
        })
    }

    /// Whether the buffers hold `primitives` and `entries`.
    pub(super) fn fits(&self, primitives: u64, entries: u64) -> bool {
        self.primitives >= primitives && self.capacity >= entries
    }

    /// Builds the lists of the `prims` uploaded (`primitives` of them,
    /// `groups` groups) for `camera`'s `width` x `height` frame into
    /// `starts` and `entries` (sized for [`TileBuild::capacity`]). Returns what was made (`entries` beyond the capacity:
    /// the lists are incomplete, to be made again in larger buffers) and
    /// the GPU's nanoseconds.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn build(
        &mut self,
        submitter: &mut Submitter,
        transfers: &mut Transfers,
        (prims, starts, entries): (&Buffer, &Buffer, &Buffer),
        (primitives, groups): (u32, u32),
        camera: &Camera,
        (width, height): (u32, u32),
        timeout: std::time::Duration,
    ) -> Result<(Built, Option<f64>)> {
        let view = View::new(camera, width, height);
        let tiles_x = width.div_ceil(super::rays::PIXEL_TILE);
        let tiles_y = height.div_ceil(super::rays::PIXEL_TILE);
        let lists = tiles_x * tiles_y * groups;
        let bits = super::frame::bits;
        let params = GpuTileBuild {
            eye64: bits(view.eye.x, view.eye.y),
            eye64_z: bits(view.eye.z, view.half_w),
            forward64: bits(view.forward.x, view.forward.y),
            forward64_z: bits(view.forward.z, view.half_h),
            right64: bits(view.right.x, view.right.y),
            right64_z: bits(view.right.z, 0.0),
            up64: bits(view.up.x, view.up.y),
            up64_z: bits(view.up.z, 0.0),
            sizes: [width, height, tiles_x, tiles_y],
            counts: [primitives, groups, self.capacity as u32, lists],
            halves: [self.half as u32, self.partials as u32, 0, 0],
        };
        self.params.write(0, &[params])?;
        let own = [&self.params, prims, &self.prim_tiles, &self.keys, &self.values, &self.scan, &self.emitted, starts, entries, &self.stats];
        self.pipelines.iter().try_for_each(|p| p.bind(&own))?;

        // (pass, invocations, push constants) in order.
        let half = self.half as u32;
        let mut passes: Vec<(u32, u32, [u32; 8])> = Vec::new();
        let push = |count: u32, shift: u32, bits: u32, src: u32, dst: u32, scan_n: u32| [count, shift, bits, src, dst, self.chunk, scan_n, 0];
        let groups_of = |items: u64, per: u64| u32::try_from(items.div_ceil(per)).unwrap_or(u32::MAX);
        let sg_per_wg = u64::from(64 / self.subgroup_size);
        // An exclusive prefix sum of `values` words of `scan` (0: a radix
        // pass's histograms, as many as its push constants say).
        let prefix_sum = |passes: &mut Vec<(u32, u32, [u32; 8])>, values: u64, p: [u32; 8]| {
            let blocks = groups_of(values, u64::from(layout::TILE_SCAN_BLOCK)) * 64;
            passes.push((layout::TILE_PASS_SCAN_REDUCE, blocks, p));
            passes.push((layout::TILE_PASS_SCAN_TOP, 64, p));
            passes.push((layout::TILE_PASS_SCAN_DOWN, blocks, p));
        };
        // A radix pass over `items` keys (or the entries', at most the
        // capacity): histogram, prefix sum, scatter.
        let radix = |passes: &mut Vec<(u32, u32, [u32; 8])>, count: u32, items: u64, (shift, width): (u32, u32), src: u32, dst: u32, last: bool| {
            let chunks = items.div_ceil(u64::from(self.chunk));
            let wgs = groups_of(chunks, sg_per_wg) * 64;
            let mut p = push(count, shift, width, src, dst, 0);
            p[7] = u32::from(last);
            passes.push((layout::TILE_PASS_HISTOGRAM, wgs, p));
            prefix_sum(passes, chunks << width, p);
            passes.push((layout::TILE_PASS_SCATTER, wgs, p));
        };
        passes.push((layout::TILE_PASS_PROJECT, primitives.max(layout::TILE_STAT_WORDS), push(primitives, 0, 0, 0, 0, 0)));
        // The primitives by depth: from the first half, ending where the
        // passes leave them.
        let mut at = 0u32;
        for digit in digits(DEPTH_KEY_BITS) {
            let to = half - at;
            radix(&mut passes, primitives, u64::from(primitives), digit, at, to, false);
            at = to;
        }
        let sorted = at;
        // Each primitive's entries' place, in depth order, and the total.
        let scan_n = primitives + 1;
        let p = push(primitives, 0, 1, sorted, 0, scan_n);
        passes.push((layout::TILE_PASS_COUNT, scan_n, p));
        prefix_sum(&mut passes, u64::from(scan_n), p);
        passes.push((layout::TILE_PASS_TOTAL, 1, p));
        // The entries, into the half the primitives are not in, sorted by
        // list, the last pass writing them into the lists; a second
        // submission, once the host knows they fit.
        let mut second = Vec::new();
        let mut at = half - sorted;
        second.push((layout::TILE_PASS_EMIT, primitives, push(primitives, 0, 0, sorted, at, 0)));
        let list_bits = u32::BITS - lists.saturating_sub(1).leading_zeros();
        let list_digits = digits(list_bits);
        for (k, &digit) in list_digits.iter().enumerate() {
            let to = half - at;
            radix(&mut second, layout::TILE_COUNT_ENTRIES, self.capacity, digit, at, to, k + 1 == list_digits.len());
            at = to;
        }
        let e = layout::TILE_COUNT_ENTRIES;
        second.push((layout::TILE_PASS_RANGES, lists + 1, push(e, 0, 0, at, 0, 0)));
        second.push((layout::TILE_PASS_STATS, tiles_x * tiles_y, push(e, 0, 0, at, 0, 0)));

        let handles: Vec<_> = self.pipelines.iter().map(|p| (p.pipeline, p.layout, p.set)).collect();
        let max_row = self.max_row;
        let record = |d: &ash::Device, cmd: vk::CommandBuffer, passes: &[(u32, u32, [u32; 8])]| {
            for (pass, invocations, push) in passes {
                // SAFETY: the pipelines and their sets are alive and bound
                // to buffers sized for these counts.
                unsafe {
                    crate::gpu::memory_barrier(
                        d,
                        cmd,
                        (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE),
                        (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE),
                    );
                    crate::gpu::bind_compute(d, cmd, handles[*pass as usize], push);
                    // Rows of workgroups where one row would pass the
                    // device's limit (tiles.comp: linear_group).
                    let groups = invocations.div_ceil(64).max(1);
                    let row = groups.min(max_row);
                    d.cmd_dispatch(cmd, row, groups.div_ceil(row), 1);
                }
            }
        };
        let deadline = Instant::now() + timeout;
        let mut gpu_ns: Option<f64> = Some(0.0);
        let mut add = |ns: Option<f64>| gpu_ns = gpu_ns.zip(ns).map(|(a, b)| a + b);
        let profile = std::env::var_os(PROFILE_SWITCH).is_some();
        let mut words = Vec::new();
        // Where an earlier frame's entries fit with room to spare, the
        // whole build in one submission (a frame that outgrows the buffers
        // is made again, larger); else the entries are counted first.
        let submissions = match self.last_entries {
            Some(e) if !profile && e + e / 4 <= self.capacity => vec![passes.into_iter().chain(second).collect::<Vec<_>>()],
            _ => vec![passes, second],
        };
        for (k, passes) in submissions.iter().enumerate() {
            if profile {
                // Each pass a submission of its own, timed: where the
                // build's time goes (stderr).
                for (j, p) in passes.iter().enumerate() {
                    let ns = submitter.run_with(deadline, timeout, transfers, |d, cmd| record(d, cmd, std::slice::from_ref(p)))?;
                    eprintln!("tile build {k}.{j:02} (pass {:2}, {:8} invocations): {:.3} ms", p.0, p.1, ns.unwrap_or(0.0) * 1e-6);
                }
            }
            let stats = transfers.fetch::<u32>(&self.stats, 0, layout::TILE_STAT_WORDS as usize)?;
            // (Profiled, the passes ran: this submission only reads.)
            let passes: &[_] = if profile { &[] } else { passes };
            add(submitter.run_with(deadline, timeout, transfers, |d, cmd| record(d, cmd, passes))?);
            words = transfers.take::<u32>(stats)?;
            if u64::from(words[layout::TILE_STAT_ENTRIES as usize]) > self.capacity {
                // They would not fit: the caller makes larger buffers.
                break;
            }
        }
        self.last_entries = Some(u64::from(words[layout::TILE_STAT_ENTRIES as usize]));
        let built = Built {
            entries: words[layout::TILE_STAT_ENTRIES as usize] as usize,
            longest: words[layout::TILE_STAT_LONGEST as usize] as usize,
            crowd: words[layout::TILE_STAT_CROWD as usize] as usize,
        };
        Ok((built, gpu_ns))
    }
}

/// The starts' and entries' buffers of lists for `lists` lists and
/// `entries` entries (texel views for the march, storage for the build).
pub(super) fn list_buffers(ctx: &std::sync::Arc<Context>, lists: u64, entries: u64) -> Result<(Buffer, Buffer)> {
    let grow = |bytes: u64| bytes.max(16).next_power_of_two();
    let starts = Buffer::texels(ctx, "tile list starts", grow(4 * (lists + 1)), TexelFormat::R32Uint, true)?;
    let entries = Buffer::texels(ctx, "tile list entries", grow(8 * entries.max(1)), TexelFormat::Rg32Uint, true)?;
    if entries.size > ctx.info.max_storage_buffer_range {
        bail!("tile lists of {} bytes exceed the device's largest storage buffer", entries.size);
    }
    Ok((starts, entries))
}
