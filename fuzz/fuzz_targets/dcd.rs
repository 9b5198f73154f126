#![no_main]
//! Fuzzes isomarch::inputs::read("dcd", ..): every frame (atom) read, or a one-line error.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isomarch::inputs::check("dcd", data);
});
