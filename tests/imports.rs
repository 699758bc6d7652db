//! No import circles between the files of `src/`: every `crate::` or
//! `super::` path a file names (outside its `#[cfg(test)] mod tests` and
//! comments) is an edge to the deepest file module it resolves to; edges to
//! a file's own ancestors (their `mod.rs` re-export hubs) are left out. On
//! 36f2bc7 this found the four circles issue 30 names (scene prep, deform
//! and order; exchange gather and hidden; links selective and shoot; gpu
//! gather and layout).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

fn modules(dir: &Path, root: &Path, out: &mut BTreeMap<String, String>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            modules(&p, root, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            let rel = p.strip_prefix(root).unwrap().with_extension("");
            let mut m = rel.to_string_lossy().replace('\\', "/");
            if m.ends_with("/mod") {
                m.truncate(m.len() - 4);
            }
            if m == "lib" || m == "main" {
                m.clear();
            }
            let mut text = std::fs::read_to_string(&p).unwrap();
            if let Some(i) = text.find("#[cfg(test)]\nmod tests") {
                text.truncate(i);
            }
            let code: String = text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n");
            out.insert(m, code);
        }
    }
}

/// The paths after `crate::` or `super::` in `code`, as segment lists (`super` kept).
fn paths(code: &str) -> Vec<(bool, Vec<String>)> {
    let mut out = Vec::new();
    let b = code.as_bytes();
    for kw in ["crate::", "super::"] {
        let mut at = 0;
        while let Some(i) = code[at..].find(kw) {
            let s = at + i;
            at = s + kw.len();
            if s > 0 && (b[s - 1].is_ascii_alphanumeric() || b[s - 1] == b'_') {
                continue;
            }
            let mut segs = Vec::new();
            let mut j = at;
            loop {
                let end =
                    code[j..].find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).map_or(code.len(), |k| j + k);
                if end == j {
                    break;
                }
                segs.push(code[j..end].to_string());
                if code[end..].starts_with("::") {
                    j = end + 2;
                } else {
                    break;
                }
            }
            out.push((kw == "super::", segs));
        }
    }
    out
}

#[test]
fn no_import_circles_in_src() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut mods = BTreeMap::new();
    modules(&root, &root, &mut mods);
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, code) in &mods {
        let parts: Vec<&str> = if m.is_empty() { vec![] } else { m.split('/').collect() };
        for (is_super, segs) in paths(code) {
            let mut base: Vec<String> = if is_super {
                parts[..parts.len().saturating_sub(1)].iter().map(|s| s.to_string()).collect()
            } else {
                vec![]
            };
            let mut segs = segs.as_slice();
            while segs.first().is_some_and(|s| s == "super") {
                base.pop();
                segs = &segs[1..];
            }
            let full: Vec<String> = base.into_iter().chain(segs.iter().cloned()).collect();
            let target = (1..=full.len()).rev().map(|i| full[..i].join("/")).find(|c| mods.contains_key(c));
            if let Some(t) = target {
                if t != *m && !m.starts_with(&format!("{t}/")) {
                    edges.entry(m.clone()).or_default().insert(t);
                }
            }
        }
    }
    // A cycle: a module that reaches itself.
    let mut circles = Vec::new();
    for start in edges.keys() {
        let mut stack: Vec<String> = edges[start].iter().cloned().collect();
        let mut seen = BTreeSet::new();
        while let Some(v) = stack.pop() {
            if v == *start {
                circles.push(start.clone());
                break;
            }
            if seen.insert(v.clone()) {
                stack.extend(edges.get(&v).into_iter().flatten().cloned());
            }
        }
    }
    assert!(mods.len() > 100, "read only {} files of src/", mods.len());
    assert!(circles.is_empty(), "files in import circles: {circles:?}");
}
