//! The daemon's modules form layers (and so do the shared and client crates'):
//! no module imports, directly or through others, a module that imports it back.
//!
//! A module is a file of `daemon/src` (a folder's `mod.rs`, or `x.rs` beside a
//! folder `x/`, is the folder's module); an import is any `crate::a::b` path in
//! the file's text before its `#[cfg(test)]` part (doc links included: a link
//! up the layers is a dependency of the reader's, too). [`REMAINING`] lists
//! circles accepted for now (none); any other fails the test.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Circles accepted for now, each as its sorted module names.
const REMAINING: &[&[&str]] = &[];

fn modules(src: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let rel = path.strip_prefix(src).unwrap().to_string_lossy().to_string();
            if path.is_dir() {
                if rel != "bin" {
                    stack.push(path);
                }
                continue;
            }
            let Some(stem) = rel.strip_suffix(".rs") else { continue };
            let mut parts: Vec<&str> = stem.split('/').collect();
            let last = *parts.last().unwrap();
            if matches!(stem, "main" | "lib") || last == "tests" || last.ends_with("tests") {
                continue;
            }
            if last == "mod" {
                parts.pop();
            }
            out.insert(parts.join("::"), std::fs::read_to_string(&path).unwrap());
        }
    }
    out
}

fn imports(mods: &BTreeMap<String, String>) -> BTreeMap<String, BTreeSet<String>> {
    let mut graph = BTreeMap::new();
    for (name, text) in mods {
        let text = text.split("#[cfg(test)]").next().unwrap();
        let mut to = BTreeSet::new();
        for (i, _) in text.match_indices("crate::") {
            let path: String =
                text[i + 7..].chars().take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':').collect();
            let parts: Vec<&str> = path.split("::").filter(|p| !p.is_empty()).collect();
            // The longest prefix that is a module.
            if let Some(target) =
                (1..=parts.len()).rev().map(|n| parts[..n].join("::")).find(|cand| mods.contains_key(cand))
            {
                let nested = name.starts_with(&format!("{target}::")) || target.starts_with(&format!("{name}::"));
                if target != *name && !nested {
                    to.insert(target);
                }
            }
        }
        graph.insert(name.clone(), to);
    }
    graph
}

/// The strongly connected components of more than one module (Tarjan).
fn circles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct Walk<'a> {
        graph: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        out: Vec<Vec<String>>,
    }
    impl<'a> Walk<'a> {
        fn visit(&mut self, v: &'a str) {
            let i = self.index.len();
            self.index.insert(v, i);
            self.low.insert(v, i);
            self.stack.push(v);
            for w in &self.graph[v] {
                if !self.index.contains_key(w.as_str()) {
                    self.visit(w);
                    let low = self.low[v].min(self.low[w.as_str()]);
                    self.low.insert(v, low);
                } else if self.stack.contains(&w.as_str()) {
                    let low = self.low[v].min(self.index[w.as_str()]);
                    self.low.insert(v, low);
                }
            }
            if self.low[v] == self.index[v] {
                let mut component = Vec::new();
                while let Some(w) = self.stack.pop() {
                    component.push(w.to_string());
                    if w == v {
                        break;
                    }
                }
                if component.len() > 1 {
                    component.sort();
                    self.out.push(component);
                }
            }
        }
    }
    let mut walk = Walk { graph, index: BTreeMap::new(), low: BTreeMap::new(), stack: Vec::new(), out: Vec::new() };
    for v in graph.keys() {
        if !walk.index.contains_key(v.as_str()) {
            walk.visit(v);
        }
    }
    walk.out.sort();
    walk.out
}

#[test]
fn the_daemon_modules_import_each_other_in_no_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let found = circles(&imports(&modules(&src)));
    let mut expected: Vec<Vec<String>> = REMAINING.iter().map(|c| c.iter().map(|m| m.to_string()).collect()).collect();
    expected.sort();
    assert_eq!(found, expected, "import circles between the daemon's modules");
}

/// The same rule for the crates below and beside the daemon.
#[test]
fn the_shared_and_client_modules_import_each_other_in_no_circle() {
    for krate in ["shared", "client"] {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(krate).join("src");
        let found = circles(&imports(&modules(&src)));
        assert!(found.is_empty(), "import circles between the modules of {krate}: {found:?}");
    }
}

#[test]
fn the_check_sees_a_circle() {
    let mods: BTreeMap<String, String> = [
        ("a".to_string(), "use crate::b::X;".to_string()),
        ("b".to_string(), "/// [`crate::c`]\nfn f() {}".to_string()),
        ("c".to_string(), "use crate::a;\n#[cfg(test)]\nuse crate::d;".to_string()),
        ("d".to_string(), "use crate::c;".to_string()),
        ("e".to_string(), "use crate::e::inner;".to_string()),
    ]
    .into();
    assert_eq!(circles(&imports(&mods)), vec![vec!["a".to_string(), "b".to_string(), "c".to_string()]]);
}
