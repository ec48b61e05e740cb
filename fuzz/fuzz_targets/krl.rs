//! KRL: the input split into a `.src` and its `.dat`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = nextpose::import::decode_text(data);
    let mid = text.char_indices().nth(text.chars().count() / 2).map(|(i, _)| i).unwrap_or(0);
    let (src, dat) = text.split_at(mid);
    let _ = nextpose::import::parse_files(&[("r1/fuzz.src", src), ("r1/FUZZ.dat", dat)]);
    let _ = nextpose::import::parse_files(&[("fuzz.src", text.as_str())]);
});
