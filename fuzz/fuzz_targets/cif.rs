#![no_main]
//! Fuzzes isomarch::inputs::read("cif", ..): a scene or a one-line error.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isomarch::inputs::check("cif", data);
});
