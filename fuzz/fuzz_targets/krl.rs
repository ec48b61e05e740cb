//! KRL: the input split into a `.src` and its `.dat`, then alone as a `.src`; each parsed and
//! imported into a fresh engine (see `import_path`).
#![no_main]

mod import_path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = nextpose::import::decode_text(data);
    let mid = text
        .char_indices()
        .nth(text.chars().count() / 2)
        .map(|(i, _)| i)
        .unwrap_or(0);
    let (src, dat) = text.split_at(mid);
    import_path::import(&[("r1/fuzz.src", src), ("r1/FUZZ.dat", dat)]);
    import_path::import(&[("fuzz.src", text.as_str())]);
});
