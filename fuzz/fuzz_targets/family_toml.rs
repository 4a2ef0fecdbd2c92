//! Problem-family TOML (a `builtin:NAME` base, or a path from the working
//! directory) → validated family; families of at most 4 random obstacles
//! are sampled once (more only cost time: each placement may try 100 poses).
#![no_main]

use libfuzzer_sys::fuzz_target;
use tandem::problem::ProblemFamily;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(family) = ProblemFamily::from_str_with(text, "<fuzz>", None) else { return };
    if family.max_obstacles() <= 4 {
        let _ = family.sample(0, 0);
    }
});
