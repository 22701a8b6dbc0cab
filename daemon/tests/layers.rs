//! The daemon's modules form layers (and so do the shared and client crates'):
//! no module imports, directly or through others, a module that imports it back.
//!
//! A module is a file of `daemon/src` or `core/src` (the estimator, which the
//! daemon re-exports under the same names; a folder's `mod.rs`, or `x.rs`
//! beside a folder `x/`, is the folder's module). An import is any `crate::a::b`,
//! `super::b` or `self::b` path (with one level of braces, `crate::{a, b::C}`)
//! in the file's text before its `#[cfg(test)]` part (doc links included: a
//! link up the layers is a dependency of the reader's, too). A module holds its
//! children: it imports each of them, and so whatever they import; a child's
//! import of its own ancestor is not an edge (it is inside it). [`REMAINING`]
//! lists circles accepted for now (none); any other fails the test, naming the
//! imports inside it.

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

/// The module paths a `use`/path text names after its prefix: `a::b::C`,
/// or each item of `{a::X, b::{Y, Z}}` (one level of braces each).
fn paths_after(text: &str) -> Vec<String> {
    let ident = |c: char| c.is_alphanumeric() || c == '_' || c == ':';
    let head: String = text.chars().take_while(|c| ident(*c)).collect();
    let rest = &text[head.len()..];
    if !rest.starts_with('{') {
        return vec![head];
    }
    let (mut depth, mut items, mut item) = (0, Vec::new(), String::new());
    for c in rest.chars() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    break;
                }
            }
            ',' if depth == 1 => items.push(std::mem::take(&mut item)),
            _ if depth == 1 => item.push(c),
            _ => {}
        }
    }
    items.push(item);
    items.iter().map(|i| format!("{head}{}", i.trim().chars().take_while(|c| ident(*c)).collect::<String>())).collect()
}

/// The parent module of `name` (`""` for a top-level one).
fn parent(name: &str) -> &str {
    name.rfind("::").map_or("", |i| &name[..i])
}

/// Who imports whom: `crate::`, `super::` and `self::` paths (a module's
/// import of its own ancestor is not an edge: it is inside it), and each
/// module's edge to its children (a module holds its children: what they
/// import, it imports).
fn imports(mods: &BTreeMap<String, String>) -> BTreeMap<String, BTreeSet<String>> {
    let mut graph: BTreeMap<String, BTreeSet<String>> = mods.keys().map(|m| (m.clone(), BTreeSet::new())).collect();
    for (name, text) in mods {
        let text = text.split("#[cfg(test)]").next().unwrap();
        let mut named = Vec::new();
        for (i, _) in text.match_indices("crate::") {
            named.extend(paths_after(&text[i + 7..]));
        }
        for (i, _) in text.match_indices("super::").filter(|(i, _)| !text[..*i].ends_with("super::")) {
            let mut base = parent(name).to_string();
            let mut rest = &text[i + 7..];
            while let Some(r) = rest.strip_prefix("super::") {
                base = parent(&base).to_string();
                rest = r;
            }
            named.extend(
                paths_after(rest).into_iter().map(|p| if base.is_empty() { p } else { format!("{base}::{p}") }),
            );
        }
        for (i, _) in text.match_indices("self::").filter(|(i, _)| !text[..*i].ends_with(':')) {
            named.extend(paths_after(&text[i + 6..]).into_iter().map(|p| format!("{name}::{p}")));
        }
        for path in named {
            let parts: Vec<&str> = path.split("::").filter(|p| !p.is_empty()).collect();
            // The longest prefix that is a module.
            let Some(target) = (1..=parts.len()).rev().map(|n| parts[..n].join("::")).find(|c| mods.contains_key(c))
            else {
                continue;
            };
            let ancestor = name.starts_with(&format!("{target}::"));
            if target != *name && !ancestor {
                graph.get_mut(name).unwrap().insert(target);
            }
        }
        let up = parent(name);
        if mods.contains_key(up) {
            graph.get_mut(up).unwrap().insert(name.clone());
        }
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

/// The imports inside each circle, `a -> b`, for the failure message.
fn inside(graph: &BTreeMap<String, BTreeSet<String>>, circles: &[Vec<String>]) -> String {
    let edges = circles.iter().flat_map(|c| {
        c.iter().flat_map(move |a| graph[a].iter().filter(|b| c.contains(b)).map(move |b| format!("{a} -> {b}")))
    });
    edges.collect::<Vec<_>>().join(", ")
}

/// The daemon's modules and the estimator's (`fusion-core`, which the daemon
/// re-exports under the same names: its `crate::engine` is the core's), as one
/// graph.
fn daemon_and_core() -> BTreeMap<String, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut mods = modules(&root.join("src"));
    for (name, text) in modules(&root.join("../core/src")) {
        assert!(mods.insert(name.clone(), text).is_none(), "module {name} in both crates");
    }
    mods
}

#[test]
fn the_daemon_modules_import_each_other_in_no_circle() {
    let mods = daemon_and_core();
    assert!(mods.contains_key("engine") && mods.contains_key("live"), "both crates read");
    let graph = imports(&mods);
    let found = circles(&graph);
    let mut expected: Vec<Vec<String>> = REMAINING.iter().map(|c| c.iter().map(|m| m.to_string()).collect()).collect();
    expected.sort();
    assert_eq!(found, expected, "import circles between the daemon's modules: {}", inside(&graph, &found));
}

/// The same rule for the crates below and beside the daemon.
#[test]
fn the_shared_and_client_modules_import_each_other_in_no_circle() {
    for krate in ["shared", "client"] {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(krate).join("src");
        let found = circles(&imports(&modules(&src)));
        let graph = imports(&modules(&src));
        assert!(found.is_empty(), "import circles between the modules of {krate}: {}", inside(&graph, &found));
    }
}

/// The graph of the top-level modules (`model` for `model::ins::aux`): an
/// import between two modules is one between their top-level ones. A
/// circle here is an import that runs back up a layer even where no module
/// imports its importer back (`model::ins::aux` using a type of
/// `measurement::pose` while `measurement` fuses into `model`).
fn top_level(graph: &BTreeMap<String, BTreeSet<String>>) -> BTreeMap<String, BTreeSet<String>> {
    let top = |m: &str| m.split("::").next().unwrap().to_string();
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (a, targets) in graph {
        let entry = out.entry(top(a)).or_default();
        entry.extend(targets.iter().map(|b| top(b)).filter(|b| *b != top(a)));
    }
    out
}

/// No import runs back up a layer: the top-level modules of the daemon and
/// the core, of the shared crate and of the client form no circle either.
#[test]
fn no_import_runs_back_up_a_layer() {
    let daemon = imports(&daemon_and_core());
    let mut crates = vec![("daemon and core", top_level(&daemon))];
    for krate in ["shared", "client"] {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(krate).join("src");
        crates.push((krate, top_level(&imports(&modules(&src)))));
    }
    for (krate, graph) in crates {
        let found = circles(&graph);
        assert!(found.is_empty(), "imports back up a layer in {krate}: {}", inside(&graph, &found));
    }
}

/// The top-level view sees an import up through a leaf that imports nothing.
#[test]
fn the_top_level_view_sees_an_import_back_up() {
    let mods: BTreeMap<String, String> = [
        ("model".to_string(), "".to_string()),
        ("model::ins".to_string(), "".to_string()),
        ("model::ins::aux".to_string(), "use crate::measurement::pose::progress::PoseProgress;".to_string()),
        ("measurement".to_string(), "use crate::model::ins::InsState;".to_string()),
        ("measurement::pose".to_string(), "".to_string()),
        ("measurement::pose::progress".to_string(), "".to_string()),
    ]
    .into();
    let graph = imports(&mods);
    assert!(circles(&graph).is_empty(), "no circle module by module");
    assert_eq!(circles(&top_level(&graph)), vec![vec!["measurement".to_string(), "model".to_string()]]);
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

/// A circle through a child (its parent holds it) and through `super::` and
/// braced paths is seen; a child's use of its parent alone is none.
#[test]
fn the_check_sees_circles_through_children_and_super() {
    let mods: BTreeMap<String, String> = [
        ("model".to_string(), "//! holds its children".to_string()),
        ("model::ins".to_string(), "use super::Model;".to_string()),
        ("model::ins::scale".to_string(), "/// fused by `crate::measurement::odometry`".to_string()),
        ("measurement".to_string(), "".to_string()),
        ("measurement::odometry".to_string(), "use crate::{frames, model::ins::State};".to_string()),
        ("sim".to_string(), "".to_string()),
        ("sim::imu".to_string(), "use super::scenario::{Arrival, gaussian3};".to_string()),
        ("sim::scenario".to_string(), "use super::{imu::ImuSim, trajectory};".to_string()),
        ("sim::trajectory".to_string(), "use super::super::sim::Stop;".to_string()),
        ("frames".to_string(), "".to_string()),
    ]
    .into();
    let found = circles(&imports(&mods));
    let expected: Vec<Vec<String>> = vec![
        vec!["measurement::odometry".into(), "model::ins".into(), "model::ins::scale".into()],
        vec!["sim::imu".into(), "sim::scenario".into()],
    ];
    assert_eq!(found, expected);
}
