//! Any bytes read as a fbx file: Ok or a clear error, never a panic.
#![no_main]

use drape::untrusted::{Format, read};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = read(Format::Fbx, data);
});
