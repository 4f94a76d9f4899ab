//! Any bytes read as a motion_cache file: Ok or a clear error, never a panic.
#![no_main]

use drape::untrusted::{Format, read};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = read(Format::MotionCache, data);
});
