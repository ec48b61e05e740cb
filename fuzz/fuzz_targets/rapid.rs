//! RAPID: one module alone, parsed and imported into a fresh engine (see `import_path`), and
//! split in two modules of one upload (cross-module resolution), parsed.
#![no_main]

mod import_path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = nextpose::import::decode_text(data);
    import_path::import(&[("fuzz.mod", text.as_str())]);
    let mid = text
        .char_indices()
        .nth(text.chars().count() / 2)
        .map(|(i, _)| i)
        .unwrap_or(0);
    let (a, b) = text.split_at(mid);
    let _ = nextpose::import::parse_files(&[("a.mod", a), ("b.sys", b)]);
});
