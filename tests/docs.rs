//! The words that describe tandem match what it does: public items are
//! documented (the `missing_docs` lint is on, and clippy's `-D warnings`
//! makes a miss an error), and phrases that described an earlier state
//! are gone.

mod common;

fn read(path: &str) -> String {
    std::fs::read_to_string(common::repo().join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn public_items_must_be_documented() {
    assert!(read("src/lib.rs").contains("#![warn(missing_docs)]"));
    assert!(read("scripts/test.sh").contains("-D warnings"), "clippy turns the warning into an error");
}

#[test]
fn stale_descriptions_are_gone() {
    for (file, stale) in [
        ("src/lib.rs", "provides the first box"),
        ("README.md", "the foundation:"),
        ("README.md", "cross-checked against scipy to 1e-12"),
        ("src/cli/mod.rs", "manipulability along a sweep"),
        ("src/cli/demo.rs", "join this command as they land"),
        ("README.md", "[[q_1], …, [q_T]]"),
    ] {
        assert!(!read(file).contains(stale), "{file} still says '{stale}'");
    }
    // The layout names what is there.
    let readme = read("README.md");
    for path in ["fuzz/", "problems/motionbenchmaker", "scripts/fuzz.sh"] {
        assert!(readme.contains(path), "README.md does not mention {path}");
    }
}
