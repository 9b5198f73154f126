#![no_main]
//! Fuzzes isomarch::inputs::read("xtc", ..): every frame (atom) read, or a one-line error.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isomarch::inputs::check("xtc", data);
});
