//! `isomarch info`: the Vulkan devices.

use anyhow::Result;

use isomarch::gpu::list_devices;

pub fn run() -> Result<()> {
    for d in list_devices()? {
        println!("{}: {} ({}, Vulkan {})", d.index, d.name, d.kind, d.api_version);
        println!("    max storage buffer:       {} MiB", d.max_storage_buffer_range >> 20);
        println!("    max texel buffer:         {} texels", d.max_texel_buffer_elements);
        println!("    max workgroup invocations: {}", d.max_compute_workgroup_invocations);
        println!("    max workgroup count:      {:?}", d.max_compute_workgroup_count);
        println!("    timestamps:               {} ({} ns/tick)", d.timestamps, d.timestamp_period_ns);
        println!("    64-bit floats in shaders: {}", d.float64);
        println!("    subgroup arithmetic:      {}", d.subgroup_arithmetic);
        println!("    subgroup ballots:         {} ({} lanes)", d.subgroup_ballot, d.subgroup_size);
        println!("    memory heaps:             {:?} MiB", d.memory_heaps_mib);
    }
    Ok(())
}
