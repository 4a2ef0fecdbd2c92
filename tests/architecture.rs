//! The house's layers (docs/design.md, "Layers"): every module of `src/`
//! sits on one layer and may use only modules on the layers below it. This
//! test reads every `crate::…` path in `src/` outside comments and string
//! literals and fails on one that points up or sideways, naming the file,
//! the line and the two modules. Inside a module, no two files may import
//! each other, directly or round a loop: a file's `super::FILE::…` and
//! `crate::MODULE::FILE::…` paths are its imports, and a loop is named
//! file by file with the line of each import.

use std::path::{Path, PathBuf};

/// The layers from the ground up: a module may use the modules of lower
/// layers only. Keep in step with docs/design.md.
const LAYERS: &[(&str, &[&str])] = &[
    ("settings", &["settings"]),
    ("robot", &["robot"]),
    ("files", &["files"]),
    ("trajectory", &["trajectory"]),
    ("figures", &["figures"]),
    // A scene's point cloud obstacles hold a point tree: clouds first.
    ("point clouds", &["point_cloud"]),
    ("geometry", &["scene"]),
    ("collision", &["collision"]),
    ("perception", &["perception"]),
    ("problems", &["problem"]),
    ("planning", &["plan"]),
    ("optimization", &["komo"]),
    ("control", &["control"]),
    ("pipeline", &["pipeline"]),
    ("datasets", &["data"]),
    ("arbitration", &["arbitration"]),
    ("simulation", &["sim"]),
    ("learning", &["learn"]),
    ("laboratory", &["experiments"]),
    ("teleoperation server", &["teleop"]),
    ("ROS 2", &["ros2"]),
    ("command line", &["cli"]),
];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|(_, modules)| modules.contains(&module))
}

/// The source with comments and the contents of string and char literals
/// blanked (newlines kept, so line numbers hold).
fn code_only(source: &str) -> String {
    let chars: Vec<char> = source.chars().collect();
    let mut out = String::with_capacity(source.len());
    let mut i = 0;
    let blank = |c: char| if c == '\n' { '\n' } else { ' ' };
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                out.push(' ');
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(chars[i]));
                    i += 1;
                }
            }
        } else if c == 'r' && (next == Some('"') || next == Some('#')) && !ident_char(out.chars().last()) {
            // A raw string r"…" or r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while chars.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if chars.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            let closing: String = std::iter::once('"').chain(std::iter::repeat_n('#', hashes)).collect();
            out.extend(std::iter::repeat_n(' ', j + 1 - i));
            i = j + 1;
            while i < chars.len() && !chars[i..].iter().collect::<String>().starts_with(&closing) {
                out.push(blank(chars[i]));
                i += 1;
            }
            out.extend(std::iter::repeat_n(' ', closing.len()));
            i += closing.len();
        } else if c == '"' {
            out.push(' ');
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                if chars[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                if i < chars.len() {
                    out.push(blank(chars[i]));
                    i += 1;
                }
            }
            out.push(' ');
            i += 1;
        } else if c == '\'' && next.is_some() && chars.get(i + 2) == Some(&'\'') {
            // A char literal 'x' (lifetimes have no closing quote).
            out.push_str("   ");
            i += 3;
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn ident_char(c: Option<char>) -> bool {
    c.is_some_and(|c| c.is_alphanumeric() || c == '_')
}

/// Every `crate::MODULE` path of `source` (a file of module `from`) that
/// points to a module on the same or a higher layer: "file:line: from ->
/// to (…the line…)".
fn violations(file: &str, from: &str, source: &str) -> Vec<String> {
    let Some(own) = layer_of(from) else {
        return vec![format!("{file}: module `{from}` has no layer: add it to LAYERS and docs/design.md")];
    };
    let code = code_only(source);
    let mut found = Vec::new();
    for (n, (line, original)) in code.lines().zip(source.lines()).enumerate() {
        let mut rest = line;
        while let Some(at) = rest.find("crate::") {
            let before = rest[..at].chars().last();
            rest = &rest[at + "crate::".len()..];
            if ident_char(before) {
                continue;
            }
            let target: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            if target == from || target.is_empty() {
                continue;
            }
            match layer_of(&target) {
                Some(layer) if layer < own => {}
                Some(layer) => found.push(format!(
                    "{file}:{}: `{from}` ({}) uses `{target}` ({}), which is not below it: {}",
                    n + 1,
                    LAYERS[own].0,
                    LAYERS[layer].0,
                    original.trim()
                )),
                None => found.push(format!("{file}:{}: `crate::{target}` is not a module with a layer", n + 1)),
            }
        }
    }
    found
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()) {
        if entry.is_dir() {
            rust_files(&entry, out);
        } else if entry.extension().is_some_and(|e| e == "rs") {
            out.push(entry);
        }
    }
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every Rust file under `src/`, sorted.
fn src_files() -> Vec<PathBuf> {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    files.sort();
    files
}

#[test]
fn every_crate_path_points_down_the_layers() {
    let src = src();
    let files = src_files();
    let mut found = Vec::new();
    let mut checked = 0;
    for path in &files {
        let relative = path.strip_prefix(&src).unwrap();
        let top = relative.components().next().unwrap().as_os_str().to_string_lossy();
        let module = top.trim_end_matches(".rs");
        // The crate root and the binary stand above the house.
        if module == "lib" || module == "bin" {
            continue;
        }
        let source = std::fs::read_to_string(path).unwrap();
        found.extend(violations(&format!("src/{}", relative.display()), module, &source));
        checked += 1;
    }
    assert!(checked > 100, "only {checked} files read under {}", src.display());
    assert!(found.is_empty(), "{} import(s) against the layers:\n{}", found.len(), found.join("\n"));
}

#[test]
fn every_module_of_the_crate_has_a_layer() {
    let lib = std::fs::read_to_string(src().join("lib.rs")).unwrap();
    let code = code_only(&lib);
    let declared: Vec<&str> = code
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod ").and_then(|m| m.strip_suffix(';')))
        .map(str::trim)
        .collect();
    assert!(declared.len() > 15, "{declared:?}");
    for module in &declared {
        assert!(layer_of(module).is_some(), "lib.rs declares `{module}`, which has no layer in LAYERS");
    }
    for (_, modules) in LAYERS {
        for module in *modules {
            assert!(declared.contains(module), "LAYERS names `{module}`, which lib.rs does not declare");
        }
    }
}

#[test]
fn an_import_up_a_layer_is_named_with_its_file_and_line() {
    let source = "//! Collision.\n\nuse crate::robot::RobotModel;\nuse crate::sim::Episode; // up two layers\n";
    let found = violations("src/collision/model.rs", "collision", source);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].starts_with("src/collision/model.rs:4: `collision` (collision) uses `sim` (simulation)"),
        "{}",
        found[0]
    );
    // A path in code counts as much as a `use`.
    let found = violations("src/sim/x.rs", "sim", "fn f() { crate::sim::run(); crate::learn::train(); }\n");
    assert_eq!(found.len(), 1, "{found:?}");
    // Comments, doc links and strings are not imports.
    let quiet = "/// See [`Episode`](crate::sim::Episode).\n/* crate::sim */ const S: &str = \"crate::sim\";\n";
    assert!(violations("src/collision/a.rs", "collision", quiet).is_empty());
    // A module with no layer cannot hide.
    assert_eq!(violations("src/newbox/a.rs", "newbox", "").len(), 1);
}

#[test]
fn the_solvers_crate_knows_no_robots() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let manifest = std::fs::read_to_string(root.join("solvers/Cargo.toml")).unwrap();
    assert!(!manifest.lines().any(|l| l.trim_start().starts_with("tandem ")), "tandem-solvers depends on tandem");
    let mut files = Vec::new();
    rust_files(&root.join("solvers/src"), &mut files);
    for path in files {
        let code = code_only(&std::fs::read_to_string(&path).unwrap()).to_lowercase();
        for word in ["tandem::", "robot", "urdf", "gripper", "kinematic"] {
            assert!(!code.contains(word), "{} names `{word}` outside comments", path.display());
        }
    }
}

/// The files of `src/` that `file` (a path under `src/`) names in its code
/// through `super::FILE::…` or `crate::MODULE::FILE::…` (grouped forms
/// `super::{a::X, b::Y}` too), with the line of each. A path through a
/// module's face (`super::Name` re-exported by a `mod.rs`) names no file.
fn imported_files(file: &Path, source: &str, exists: &dyn Fn(&Path) -> bool) -> Vec<(PathBuf, usize)> {
    let code = code_only(source);
    let parent = file.parent().unwrap();
    // `super` of `x/mod.rs` is the module above `x`.
    let sup = if file.file_name().is_some_and(|n| n == "mod.rs") { parent.parent().unwrap() } else { parent };
    let mut found = Vec::new();
    for (n, line) in code.lines().enumerate() {
        for (prefix, base) in [("super::", sup.to_path_buf()), ("crate::", src())] {
            let mut rest = line;
            while let Some(at) = rest.find(prefix) {
                let before = rest[..at].chars().last();
                rest = &rest[at + prefix.len()..];
                if ident_char(before) {
                    continue;
                }
                // One path, or each path of a `{…}` group.
                let paths: Vec<&str> = match rest.strip_prefix('{') {
                    Some(group) => group.split('}').next().unwrap_or("").split(',').map(str::trim).collect(),
                    None => vec![rest],
                };
                for path in paths {
                    if let Some(target) = resolve(&base, path, exists)
                        && target != file
                    {
                        found.push((target, n + 1));
                    }
                }
            }
        }
    }
    found
}

/// The file a path (`a::b::Name…`, read from `base`) is in: the deepest
/// `a.rs`, `a/mod.rs`, `a/b.rs`… that exists; `None` for an item of `base`'s
/// own `mod.rs` (a face).
fn resolve(base: &Path, path: &str, exists: &dyn Fn(&Path) -> bool) -> Option<PathBuf> {
    let (mut dir, mut file) = (base.to_path_buf(), None);
    let mut segments = path.split("::").peekable();
    while let Some(segment) = segments.next() {
        // The last segment is the item, never a file.
        if segments.peek().is_none() || segment.is_empty() || !segment.chars().all(|c| c.is_alphanumeric() || c == '_')
        {
            break;
        }
        if exists(&dir.join(format!("{segment}.rs"))) {
            return Some(dir.join(format!("{segment}.rs")));
        }
        let module = dir.join(segment).join("mod.rs");
        if !exists(&module) {
            break;
        }
        dir = dir.join(segment);
        file = Some(module);
    }
    file
}

#[test]
fn no_files_import_each_other_in_a_loop() {
    let src = src();
    let files = src_files();
    let exists = |p: &Path| p.is_file();
    let edges: Vec<Vec<(usize, usize)>> = files
        .iter()
        .map(|f| {
            let source = std::fs::read_to_string(f).unwrap();
            let mut to: Vec<(usize, usize)> = imported_files(f, &source, &exists)
                .into_iter()
                .filter_map(|(t, line)| files.iter().position(|g| *g == t).map(|k| (k, line)))
                .collect();
            to.sort();
            to.dedup_by_key(|e| e.0);
            to
        })
        .collect();
    assert!(edges.iter().map(Vec::len).sum::<usize>() > 100, "too few imports between files were read");
    // Depth-first search; a grey file met again closes a loop.
    let name = |k: usize| files[k].strip_prefix(&src).unwrap().display().to_string();
    let mut colour = vec![0u8; files.len()];
    let mut stack: Vec<(usize, usize)> = Vec::new();
    for root in 0..files.len() {
        if colour[root] != 0 {
            continue;
        }
        colour[root] = 1;
        stack.push((root, 0));
        while let Some(&mut (at, ref mut next)) = stack.last_mut() {
            match edges[at].get(*next) {
                Some(&(to, _)) => {
                    *next += 1;
                    match colour[to] {
                        0 => {
                            colour[to] = 1;
                            stack.push((to, 0));
                        }
                        1 => {
                            let from = stack.iter().position(|s| s.0 == to).unwrap();
                            let ring: Vec<String> = stack[from..]
                                .iter()
                                .map(|&(k, next)| format!("src/{}:{}", name(k), edges[k][next - 1].1))
                                .collect();
                            panic!(
                                "files that import each other in a loop (each at the line of its import of the next): {} -> src/{}",
                                ring.join(" -> "),
                                name(to)
                            );
                        }
                        _ => {}
                    }
                }
                None => {
                    colour[at] = 2;
                    stack.pop();
                }
            }
        }
    }
}

#[test]
fn an_import_of_a_sibling_file_is_read_in_every_form() {
    let files = [
        "src/arbitration/mod.rs",
        "src/arbitration/arbiter.rs",
        "src/arbitration/workspace.rs",
        "src/collision/mod.rs",
        "src/collision/spheres/mod.rs",
    ];
    let exists = |p: &Path| files.iter().any(|f| src().join(f.trim_start_matches("src/")) == p);
    let at = |f: &str| src().join(f.trim_start_matches("src/"));
    let read = |file: &str, source: &str| -> Vec<PathBuf> {
        imported_files(&at(file), source, &exists).into_iter().map(|(p, _)| p).collect()
    };
    let ws = at("src/arbitration/workspace.rs");
    assert_eq!(read("src/arbitration/arbiter.rs", "use super::workspace::ArbiterWorkspace;\n"), vec![ws.clone()]);
    assert_eq!(read("src/arbitration/arbiter.rs", "use super::{modes::M, workspace::W};\n"), vec![ws.clone()]);
    assert_eq!(read("src/arbitration/arbiter.rs", "impl super::workspace::W {}\n"), vec![ws.clone()]);
    assert_eq!(read("src/sim/x.rs", "use crate::arbitration::workspace::W;\n"), vec![ws]);
    assert_eq!(
        read("src/sim/x.rs", "use crate::collision::spheres::SphereModel;\n"),
        vec![at("src/collision/spheres/mod.rs")]
    );
    // Through a module's face, in a comment or a string: no file.
    assert!(read("src/arbitration/arbiter.rs", "use super::ArbiterWorkspace;\n").is_empty());
    assert!(
        read("src/sim/x.rs", "// super::workspace::W\nconst S: &str = \"crate::arbitration::workspace::W\";\n")
            .is_empty()
    );
}
