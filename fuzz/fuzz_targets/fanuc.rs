//! FANUC: one TP listing, parsed and imported into a fresh engine (see `import_path`).
#![no_main]

mod import_path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = nextpose::import::decode_text(data);
    import_path::import(&[("backup/FUZZ.LS", text.as_str())]);
});
