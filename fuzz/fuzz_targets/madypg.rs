//! The MADYPG database reader ([`yarn_pattern::madypg::Database::parse`]) on arbitrary
//! `axes.txt` and `data.npy` contents: the input's first two bytes (little endian) give the
//! length of the axes text, the rest is the `.npy` file. A validated database or an error
//! naming the file, never a panic, a hang or an allocation the file cannot back.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if data.len() < 2 {
        return;
    }
    let split = (u16::from_le_bytes([data[0], data[1]]) as usize).min(data.len() - 2);
    let (axes, npy) = data[2..].split_at(split);
    let Ok(axes) = std::str::from_utf8(axes) else {
        return;
    };
    if let Ok(db) = yarn_pattern::madypg::Database::parse(axes, npy, Path::new("fuzz-db")) {
        assert!(db.validate().is_ok(), "a parsed database validates");
    }
});
