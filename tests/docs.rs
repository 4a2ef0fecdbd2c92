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
    // The user pages name what is there.
    let testing = read("docs/testing.md");
    for path in ["fuzz/", "scripts/fuzz.sh", "scripts/reproduce.sh"] {
        assert!(testing.contains(path), "docs/testing.md does not mention {path}");
    }
    assert!(
        read("docs/design.md").contains("problems/motionbenchmaker"),
        "docs/design.md does not mention problems/motionbenchmaker"
    );
}

/// The fenced blocks of `lang` in `text`: (first line number, body).
fn fenced<'t>(text: &'t str, lang: &str) -> Vec<(usize, &'t str)> {
    let open = format!("```{lang}\n");
    let mut out = vec![];
    let mut rest = text;
    let mut offset = 0;
    while let Some(start) = rest.find(&open) {
        let body_start = start + open.len();
        let Some(len) = rest[body_start..].find("\n```") else { break };
        let line = text[..offset + body_start].lines().count() + 1;
        out.push((line, &rest[body_start..body_start + len + 1]));
        offset += body_start + len + 4;
        rest = &rest[body_start + len + 4..];
    }
    out
}

/// Words of a shell command line: whitespace-separated, quotes removed
/// (no escapes or expansions: the docs' commands need none).
fn words(command: &str) -> Vec<String> {
    let mut out = vec![];
    let mut word = String::new();
    let mut quote = None;
    let mut started = false;
    for c in command.chars() {
        match (quote, c) {
            (None, '\'' | '"') => (quote, started) = (Some(c), true),
            (Some(q), c) if c == q => quote = None,
            (None, c) if c.is_whitespace() => {
                if started {
                    out.push(std::mem::take(&mut word));
                    started = false;
                }
            }
            (_, c) => (word, started) = (word + &c.to_string(), true),
        }
    }
    if started {
        out.push(word);
    }
    out
}

/// Every `tandem …` command in a ```sh block of the README, docs/ and
/// problems/README.md parses against the current command line (unknown
/// options, renamed subcommands and out-of-range values fail here).
/// Synopses with placeholders belong in ```text blocks.
#[test]
fn shell_examples_parse_against_the_current_cli() {
    use clap::Parser;
    let mut files = vec!["README.md".to_string(), "problems/README.md".to_string()];
    let docs = common::repo().join("docs");
    let mut pages: Vec<_> = std::fs::read_dir(&docs).unwrap().flatten().map(|e| e.path()).collect();
    pages.sort();
    files.extend(
        pages
            .iter()
            .filter(|p| p.extension().is_some_and(|e| e == "md"))
            .map(|p| format!("docs/{}", p.file_name().unwrap().to_string_lossy())),
    );
    let mut checked = 0;
    let mut failures = vec![];
    for file in &files {
        let text = read(file);
        for (first, body) in fenced(&text, "sh") {
            // Continued lines joined, each kept at its first line's number.
            let mut lines: Vec<(usize, String)> = vec![];
            let mut continued = false;
            for (k, raw) in body.lines().enumerate() {
                let part = raw.trim_end().trim_end_matches('\\').to_string();
                match lines.last_mut() {
                    Some(last) if continued => last.1 = format!("{} {}", last.1, part.trim()),
                    _ => lines.push((k, part)),
                }
                continued = raw.trim_end().ends_with('\\');
            }
            for (k, line) in &lines {
                let code = line.split(" #").next().unwrap_or("").trim();
                let code = if code.starts_with('#') { "" } else { code };
                // `tandem … || test $? -eq 2` shows a usage error: it must not parse.
                let usage_error = code.contains("test $? -eq 2");
                for segment in
                    code.split("&&").flat_map(|s| s.split("||")).flat_map(|s| s.split(" | ")).flat_map(|s| s.split(';'))
                {
                    let mut argv = words(segment.trim());
                    let Some(program) = argv.first() else { continue };
                    if program != "tandem" && !program.ends_with("/tandem") {
                        continue;
                    }
                    // Redirections are the shell's; shell variables are
                    // values only a run knows (scripts/doc_examples.py runs them).
                    if let Some(at) = argv.iter().position(|w| w.contains('>')) {
                        argv.truncate(at);
                    }
                    if argv.iter().any(|w| w.contains('$')) {
                        continue;
                    }
                    checked += 1;
                    let parsed = match tandem::cli::Cli::try_parse_from(&argv) {
                        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelp => Ok(()),
                        other => other.map(|_| ()),
                    };
                    let line = first + *k;
                    match (parsed, usage_error) {
                        (Ok(()), true) => failures
                            .push(format!("{file}:{line}: `{}` parses (a usage error was shown)", segment.trim())),
                        (Err(e), false) => {
                            let first_line = e.to_string().lines().next().unwrap_or_default().to_string();
                            failures.push(format!("{file}:{line}: `{}`: {first_line}", segment.trim()));
                        }
                        _ => {}
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{} of {checked} commands do not parse:\n{}", failures.len(), failures.join("\n"));
    assert!(checked >= 20, "only {checked} tandem commands found in ```sh blocks");
}
