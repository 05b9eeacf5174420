//! The core's folders are layers: a module imports modules of its own layer and of lower ones,
//! never of a higher one, and no chain of imports comes back to where it started.
//!
//! Read from the sources: every `crate::` path in code (comments left out) is an import of the
//! module it names; a name that a module re-exports (`pub use` in `lib.rs` or a folder's
//! `mod.rs`) counts as an import of the module that defines it. Test modules (`mod tests { .. }`
//! or a `tests.rs` file) may build their inputs with higher layers (a PointMap, fitted normals),
//! but take part in the cycle check.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The layers, lowest first, by top-level module.
const LAYERS: [&[&str]; 6] =
    [&["error", "cancel", "parallel", "pose"], &["grids"], &["visibility"], &["maps"], &["icp"], &["search"]];

/// A module's source without comments, split into its code and its test module.
struct Source {
    code: String,
    tests: String,
}

fn join(prefix: &str, name: &str) -> String {
    if prefix.is_empty() {
        name.to_string()
    } else {
        format!("{prefix}::{name}")
    }
}

/// Every module under `dir` by path (`""` for the crate root, `"icp"` for `icp/mod.rs`).
fn read_modules(dir: &Path, prefix: &str, out: &mut BTreeMap<String, Source>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_str().unwrap().to_string();
        if path.is_dir() {
            read_modules(&path, &join(prefix, &name), out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let text = std::fs::read_to_string(&path).unwrap();
            let text: String =
                text.lines().map(|l| l.split("//").next().unwrap()).collect::<Vec<_>>().join("\n");
            // A module's tests: its `mod tests { .. }`, or the whole of a `tests.rs` file.
            let split = if name == "tests" { 0 } else { text.find("mod tests {").unwrap_or(text.len()) };
            let (code, tests) = text.split_at(split);
            let module =
                if name == "mod" || name == "lib" { prefix.to_string() } else { join(prefix, &name) };
            out.insert(module, Source { code: code.to_string(), tests: tests.to_string() });
        }
    }
}

/// What `crate::<path>` names: the deepest module on the path, or, when the next name is
/// re-exported there, the module it comes from.
fn resolve(modules: &BTreeMap<String, Source>, path: &[&str]) -> String {
    let mut module = String::new();
    for (i, name) in path.iter().enumerate() {
        let deeper = join(&module, name);
        if modules.contains_key(&deeper) {
            module = deeper;
            continue;
        }
        for line in modules[&module].code.lines().filter_map(|l| l.trim().strip_prefix("pub use ")) {
            let line = line.trim_end_matches(';');
            let (base, items) = match line.split_once("::{") {
                Some((base, items)) => (base, items.trim_end_matches('}')),
                None => line.rsplit_once("::").unwrap(),
            };
            if items.split(',').any(|item| item.trim() == *name) {
                let from: Vec<&str> = match base.strip_prefix("crate::") {
                    Some(absolute) => absolute.split("::").collect(),
                    None => module.split("::").chain(base.split("::")).filter(|s| !s.is_empty()).collect(),
                };
                return resolve(modules, &[&from[..], &path[i..]].concat());
            }
        }
        break;
    }
    module
}

/// Module -> the modules its code (and, `with_tests`, its tests) imports.
fn imports(modules: &BTreeMap<String, Source>, with_tests: bool) -> BTreeMap<String, BTreeSet<String>> {
    let mut graph = BTreeMap::new();
    for (module, source) in modules {
        let text = if with_tests { format!("{}{}", source.code, source.tests) } else { source.code.clone() };
        let mut targets = BTreeSet::new();
        for (at, _) in text.match_indices("crate::") {
            let rest = &text[at + "crate::".len()..];
            let end =
                rest.find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).unwrap_or(rest.len());
            let path: Vec<&str> = rest[..end].split("::").filter(|s| !s.is_empty()).collect();
            let target = resolve(modules, &path);
            if !target.is_empty() && target != *module {
                targets.insert(target);
            }
        }
        graph.insert(module.clone(), targets);
    }
    graph
}

fn sources() -> BTreeMap<String, Source> {
    let mut modules = BTreeMap::new();
    read_modules(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"), "", &mut modules);
    modules
}

#[test]
fn no_module_imports_a_module_of_a_higher_layer() {
    let layer = |module: &str| {
        let top = module.split("::").next().unwrap();
        LAYERS.iter().position(|l| l.contains(&top)).unwrap_or_else(|| panic!("{top} is in no layer"))
    };
    let modules = sources();
    assert!(modules.len() > 30, "{} modules read", modules.len());
    for (module, targets) in imports(&modules, false).iter().filter(|(m, _)| !m.is_empty()) {
        for target in targets {
            assert!(layer(target) <= layer(module), "{module} imports {target}, a higher layer");
        }
    }
}

#[test]
fn the_module_graph_has_no_cycle() {
    let graph = imports(&sources(), true);
    // Depth-first search; `path` is the chain of imports being followed.
    fn visit(
        m: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        done: &mut BTreeSet<String>,
        path: &mut Vec<String>,
    ) {
        if let Some(start) = path.iter().position(|p| p == m) {
            panic!("import cycle: {} -> {m}", path[start..].join(" -> "));
        }
        if done.contains(m) {
            return;
        }
        path.push(m.to_string());
        for next in &graph[m] {
            visit(next, graph, done, path);
        }
        path.pop();
        done.insert(m.to_string());
    }
    let mut done = BTreeSet::new();
    for module in graph.keys() {
        visit(module, &graph, &mut done, &mut Vec::new());
    }
}
