//! The core is a stack of layers (ARCHITECTURE.md): a module may use its own layer and the
//! layers below, never one above, and modules that do not contain one another import in one
//! direction only (no circles).  This test reads the sources and fails on either.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, bottom up: each top-level module of the crate and its height.
const LAYERS: [(&str, usize); 13] = [
    ("base", 0),
    ("frame", 1),
    ("mappings", 2),
    ("images", 3),
    ("mesh", 3),
    ("resample", 4),
    ("trace", 5),
    ("lighting", 6),
    ("jobs", 7),
    ("batch", 8),
    ("demo", 8),
    ("names", 8),
    ("view", 8),
];

fn layer(module: &str) -> Option<usize> {
    let top = module.split("::").next()?;
    LAYERS.iter().find(|(n, _)| *n == top).map(|(_, h)| *h)
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// `src/a/b/mod.rs` → `a::b`; `src/a/c.rs` → `a::c`.
fn module_of(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts.join("::")
}

/// The source without comments and string literals (doc links may point anywhere).
fn code_only(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            i += 2;
            while i + 1 < b.len() && !b[i..].starts_with(b"*/") {
                i += 1;
            }
            i += 2;
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && i + 2 < b.len() && (b[i + 2] == b'\'' || b[i + 1] == b'\\') {
            // A char literal ('x', '\n'); lifetimes ('a) pass through.
            i += 1;
            while i < b.len() && b[i] != b'\'' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
        } else {
            let ch = text[i..].chars().next().unwrap();
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    out
}

fn ident_at(s: &[u8], mut i: usize) -> (String, usize) {
    let start = i;
    while i < s.len() && (s[i].is_ascii_alphanumeric() || s[i] == b'_') {
        i += 1;
    }
    (String::from_utf8_lossy(&s[start..i]).into_owned(), i)
}

/// Paths starting at `i` (just after `crate::` or `super::`), group braces expanded.
fn paths_at(s: &[u8], i: usize, prefix: Vec<String>, out: &mut Vec<Vec<String>>) -> usize {
    let mut i = i;
    let mut path = prefix;
    loop {
        while i < s.len() && s[i].is_ascii_whitespace() {
            i += 1;
        }
        if i < s.len() && s[i] == b'{' {
            i += 1;
            loop {
                while i < s.len() && (s[i].is_ascii_whitespace() || s[i] == b',') {
                    i += 1;
                }
                if i >= s.len() || s[i] == b'}' {
                    return i + 1;
                }
                i = paths_at(s, i, path.clone(), out);
                // Skip an `as name` and anything else up to the next item.
                while i < s.len() && s[i] != b',' && s[i] != b'}' {
                    i += 1;
                }
            }
        }
        let (id, j) = ident_at(s, i);
        if id.is_empty() {
            out.push(path);
            return j;
        }
        path.push(id);
        i = j;
        if s[i..].starts_with(b"::") {
            i += 2;
        } else {
            out.push(path);
            return i;
        }
    }
}

/// The paths in `module`'s code that start with `crate::` (true) or `super::` (false, resolved
/// against `module`), group braces expanded.
fn raw_paths(module: &str, code: &str) -> Vec<(bool, Vec<String>)> {
    let s = code.as_bytes();
    let mut raw = Vec::new();
    let mut i = 0;
    while i < s.len() {
        let word_start = i == 0 || !(s[i - 1].is_ascii_alphanumeric() || s[i - 1] == b'_');
        let mut found = Vec::new();
        let from_crate = word_start && s[i..].starts_with(b"crate::");
        if from_crate {
            i = paths_at(s, i + 7, Vec::new(), &mut found);
        } else if word_start && s[i..].starts_with(b"super::") {
            let mut base: Vec<String> = module.split("::").map(String::from).collect();
            let mut j = i;
            while s[j..].starts_with(b"super::") {
                base.pop();
                j += 7;
            }
            i = paths_at(s, j, base, &mut found);
        } else {
            i += 1;
        }
        raw.extend(found.into_iter().map(|p| (from_crate, p)));
    }
    raw
}

/// The modules `module` refers to, resolved to the longest known module prefix.
fn references(module: &str, code: &str, known: &BTreeSet<String>) -> BTreeSet<String> {
    let raw = raw_paths(module, code).into_iter().map(|(_, p)| p);
    let mut out = BTreeSet::new();
    for path in raw {
        let mut best = None;
        for n in 1..=path.len() {
            let m = path[..n].join("::");
            if known.contains(&m) {
                best = Some(m);
            }
        }
        if let Some(m) = best {
            out.insert(m);
        }
    }
    out
}

/// Every module of the crate but its root, by name, as code ([`code_only`]).
fn sources() -> BTreeMap<String, String> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files
        .iter()
        .map(|f| (module_of(&src, f), f))
        .filter(|(m, _)| m != "lib")
        .map(|(m, f)| (m, code_only(&std::fs::read_to_string(f).unwrap())))
        .collect()
}

fn contains(outer: &str, inner: &str) -> bool {
    inner == outer || inner.starts_with(&format!("{outer}::"))
}

#[test]
fn no_module_imports_from_a_layer_above_and_there_are_no_circles() {
    let code = sources();
    let known: BTreeSet<String> = code.keys().cloned().collect();
    let mut problems = Vec::new();
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, text) in &code {
        let Some(h) = layer(m) else {
            problems.push(format!("{m}: a top-level module that is in no layer"));
            continue;
        };
        for r in references(m, text, &known) {
            let rh = layer(&r).unwrap();
            if rh > h {
                problems.push(format!("{m} (layer {h}) uses {r} (layer {rh})"));
            }
            if !contains(m, &r) && !contains(&r, m) {
                edges.entry(m.clone()).or_default().insert(r);
            }
        }
    }
    // Circles: a module that reaches itself through modules outside it.
    for start in edges.keys() {
        let mut seen = BTreeSet::new();
        let mut stack: Vec<(String, Vec<String>)> = vec![(start.clone(), vec![start.clone()])];
        while let Some((m, path)) = stack.pop() {
            for next in edges.get(&m).into_iter().flatten() {
                if next == start {
                    let mut ring = path.clone();
                    ring.push(start.clone());
                    problems.push(format!("import circle: {}", ring.join(" -> ")));
                } else if seen.insert(next.clone()) {
                    let mut p = path.clone();
                    p.push(next.clone());
                    stack.push((next.clone(), p));
                }
            }
        }
    }
    problems.sort();
    problems.dedup();
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// `crate::X` paths whose first step is not one of the crate's modules: the crate root's `pub use`
/// shortcuts (`crate::Mapping`), which hide the layer they come from.
fn root_shortcuts(code: &str, modules: &BTreeSet<String>) -> BTreeSet<String> {
    raw_paths("", code)
        .into_iter()
        .filter(|(from_crate, _)| *from_crate)
        .filter_map(|(_, p)| p.first().cloned())
        .filter(|first| !modules.contains(first))
        .collect()
}

#[test]
fn modules_name_the_module_they_use_not_a_crate_root_shortcut() {
    let tops: BTreeSet<String> = LAYERS.iter().map(|(n, _)| n.to_string()).collect();
    let mut problems = Vec::new();
    for (m, code) in sources() {
        for name in root_shortcuts(&code, &tops) {
            problems.push(format!("{m} uses crate::{name}; name its module instead"));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Whether `parent`'s code uses an item of its child module `child` (a path `child::…`,
/// `self::child::…` or `crate::…::child::…`) other than by re-exporting it (`pub use`,
/// `pub(crate) use`).
fn parent_uses_child(parent_code: &str, parent: &str, child: &str) -> bool {
    // The code without its re-exports.
    let mut code = String::new();
    let mut rest = parent_code;
    while let Some(i) = ["pub use ", "pub(crate) use ", "pub(super) use "]
        .iter()
        .filter_map(|p| rest.find(p))
        .min()
    {
        code.push_str(&rest[..i]);
        rest = rest[i..].split_once(';').map_or("", |(_, r)| r);
    }
    code.push_str(rest);
    let s = code.as_bytes();
    let through_crate = format!("crate::{parent}::");
    code.match_indices(&format!("{child}::")).any(|(i, _)| {
        let before = &s[..i];
        let word_start = i == 0 || !(s[i - 1].is_ascii_alphanumeric() || s[i - 1] == b'_');
        (word_start && !before.ends_with(b"::"))
            || before.ends_with(b"self::")
            || before.ends_with(through_crate.as_bytes())
    })
}

/// Two-way ties between a folder's `mod.rs` and its files: a child module that uses an item
/// of its parent (`super::X`, `use super::*`, `crate::parent::X`) while the parent uses the
/// child's items back (not only re-exporting them).  A type the files share may live in
/// `mod.rs` (the child then uses its parent one way); a parent that also calls into the child
/// makes the two one tangle.
fn parent_ties(code: &BTreeMap<String, String>) -> BTreeSet<String> {
    let known: BTreeSet<String> = code.keys().cloned().collect();
    let mut ties = BTreeSet::new();
    for (m, text) in code {
        let Some((parent, name)) = m.rsplit_once("::") else {
            continue;
        };
        // Tests of the parent (a `tests.rs`, or a file's `#[cfg(test)]` module at its end,
        // where `super` is the file itself) are not ties.
        let text = text.split("#[cfg(test)]").next().unwrap_or("");
        let parent_code = code[parent].split("#[cfg(test)]").next().unwrap_or("");
        if name != "tests"
            && references(m, text, &known).contains(parent)
            && parent_uses_child(parent_code, parent, name)
        {
            ties.insert(format!("{m} <-> {parent}"));
        }
    }
    ties
}

#[test]
fn no_file_and_its_parent_use_each_other() {
    let code = sources();
    let ties = parent_ties(&code);
    assert!(
        ties.is_empty(),
        "a file and its folder's mod.rs use each other (move what they share to a file of its \
         own): {ties:?}"
    );
}

#[test]
fn the_checker_sees_what_it_must() {
    let known: BTreeSet<String> = ["a", "a::b", "a::c", "d"].map(String::from).into();
    let code = code_only(
        "use crate::a::{b::X, c};\n// crate::d in a comment\nlet s = \"crate::d\";\nsuper::c::f();",
    );
    let got = references("a::b", &code, &known);
    assert_eq!(got, ["a::b", "a::c"].map(String::from).into());
    assert_eq!(layer("jobs::render::raster"), Some(7));
    let tops: BTreeSet<String> = ["base", "mappings"].map(String::from).into();
    let code = code_only("use crate::Mapping;\nlet e = crate::base::error::Error::x();\nuse crate::{mappings::X, Result};");
    assert_eq!(
        root_shortcuts(&code, &tops),
        ["Mapping", "Result"].map(String::from).into()
    );
    assert_eq!(layer("nowhere"), None);
    // A parent that calls into its child, and one that only re-exports it.
    assert!(parent_uses_child(
        "use rows::{a, b};\nfn f() { rows::a(); }",
        "p",
        "rows"
    ));
    assert!(parent_uses_child(
        "fn f() { crate::p::rows::a(); }",
        "p",
        "rows"
    ));
    assert!(!parent_uses_child(
        "pub use rows::{a, b};\nmod rows;",
        "p",
        "rows"
    ));
    assert!(!parent_uses_child(
        "fn f() { other::rows::a(); }",
        "p",
        "rows"
    ));
    let code: BTreeMap<String, String> = [
        (
            "p",
            "mod c;\nmod d;\npub struct S;\nfn f() { c::g(); }\npub use d::T;",
        ),
        ("p::c", "use super::S;\npub fn g() {}"),
        ("p::d", "use super::S;\npub struct T;"),
    ]
    .map(|(m, c)| (m.to_string(), code_only(c)))
    .into();
    assert_eq!(parent_ties(&code), ["p::c <-> p"].map(String::from).into());
}
