//! MoveIt motion plan request YAML → group, start and joint goal.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tandem::problem::moveit_request_from_str;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let _ = moveit_request_from_str(text, "<fuzz>");
});
