//! FANUC: one TP listing.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = nextpose::import::decode_text(data);
    let _ = nextpose::import::parse_files(&[("backup/FUZZ.LS", text.as_str())]);
});
