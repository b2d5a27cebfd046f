//! The `.pyp` reader ([`yarn_pattern::pyp::parse_pyp`]) on arbitrary text: it returns a tile
//! or an error, and never panics or hangs.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = yarn_pattern::pyp::parse_pyp(text, "fuzz.pyp");
    }
});
