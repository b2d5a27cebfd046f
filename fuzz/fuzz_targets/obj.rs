//! The OBJ mesh readers ([`yarn_output::obj_mesh`]) on arbitrary text: a mesh with and
//! without texture coordinates, and the positions of an animation frame. A mesh or an error
//! naming the file and line, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;
use yarn_output::obj_mesh::{Uv, parse_obj, parse_obj_positions};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("fuzz.obj");
    let _ = parse_obj(text, path, Uv::Required);
    let _ = parse_obj(text, path, Uv::Ignored);
    let mut positions = Vec::new();
    let _ = parse_obj_positions(text, path, &mut positions);
});
