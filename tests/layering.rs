//! Modules depend one way. Parses every source file under src/ (syn) for
//! the `crate::` and `super::` paths it names (test items excluded: a test
//! may reach anywhere) and fails on a cycle, between the crate's top-level modules and
//! between the submodules of one module. The layers, leaf first:
//! layout <- settings, method <- scene <- field <- render <- the commands.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module path of a source file relative to src/: `field/quad.rs` is
/// `["field", "quad"]`, `field/mod.rs` is `["field"]`.
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if stem != "mod" && stem != "lib" {
        parts.push(stem.to_string());
    }
    parts
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module paths a file's non-test code names, resolved to absolute
/// paths (`crate::a::b`, and `super::b` or `super::super::b` from within
/// the module): every `use` tree, groups included (`use super::{a, b}`),
/// and every path in code, types and macro arguments. Items under
/// `#[cfg(test)]` are skipped wherever they stand in the file.
fn references(source: &str, own: &[String]) -> Vec<Vec<String>> {
    use syn::visit::Visit;

    struct Paths<'a> {
        own: &'a [String],
        out: Vec<Vec<String>>,
    }

    impl Paths<'_> {
        /// A path's leading segments: `crate` or `super`s, then the module.
        fn add(&mut self, segments: &[String]) {
            let mut base: Vec<String> = match segments.first().map(String::as_str) {
                Some("crate") => Vec::new(),
                Some("super") => self.own.to_vec(),
                _ => return,
            };
            let mut rest = &segments[1..];
            if segments[0] == "super" {
                base.pop();
                while rest.first().is_some_and(|s| s == "super") {
                    base.pop();
                    rest = &rest[1..];
                }
            }
            if let Some(name) = rest.first().filter(|n| n.as_str() != "self" && n.as_str() != "*") {
                base.push(name.clone());
                self.out.push(base);
            }
        }

        fn use_tree(&mut self, prefix: &mut Vec<String>, tree: &syn::UseTree) {
            match tree {
                syn::UseTree::Path(p) => {
                    prefix.push(p.ident.to_string());
                    self.use_tree(prefix, &p.tree);
                    prefix.pop();
                }
                syn::UseTree::Name(n) => {
                    prefix.push(n.ident.to_string());
                    self.add(prefix);
                    prefix.pop();
                }
                syn::UseTree::Rename(r) => {
                    prefix.push(r.ident.to_string());
                    self.add(prefix);
                    prefix.pop();
                }
                syn::UseTree::Glob(_) => {
                    prefix.push("*".into());
                    self.add(prefix);
                    prefix.pop();
                }
                syn::UseTree::Group(g) => {
                    for t in &g.items {
                        self.use_tree(prefix, t);
                    }
                }
            }
        }
    }

    fn is_test(attrs: &[syn::Attribute]) -> bool {
        attrs.iter().any(|a| a.path().is_ident("cfg") && a.meta.require_list().is_ok_and(|l| l.tokens.to_string() == "test"))
    }

    impl<'ast> Visit<'ast> for Paths<'_> {
        fn visit_item(&mut self, item: &'ast syn::Item) {
            let attrs: &[syn::Attribute] = match item {
                syn::Item::Mod(m) => &m.attrs,
                syn::Item::Fn(f) => &f.attrs,
                syn::Item::Use(u) => &u.attrs,
                syn::Item::Impl(i) => &i.attrs,
                syn::Item::Struct(s) => &s.attrs,
                syn::Item::Const(c) => &c.attrs,
                _ => &[],
            };
            if !is_test(attrs) {
                syn::visit::visit_item(self, item);
            }
        }

        fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
            self.use_tree(&mut Vec::new(), &u.tree);
        }

        fn visit_path(&mut self, path: &'ast syn::Path) {
            let segments: Vec<String> = path.segments.iter().map(|s| s.ident.to_string()).collect();
            self.add(&segments);
            syn::visit::visit_path(self, path);
        }

        fn visit_macro(&mut self, mac: &'ast syn::Macro) {
            // Macro arguments are tokens, not syntax: `crate :: a` in them.
            let tokens: Vec<String> = mac.tokens.to_string().split_whitespace().map(String::from).collect();
            for (i, t) in tokens.iter().enumerate() {
                if (t == "crate" || t == "super") && tokens.get(i + 1).is_some_and(|c| c == "::") {
                    let mut segments = vec![t.clone()];
                    let mut j = i + 2;
                    while let Some(name) = tokens.get(j) {
                        segments.push(name.trim_matches(|c: char| !(c.is_alphanumeric() || c == '_')).to_string());
                        if tokens.get(j + 1).is_none_or(|c| c != "::") {
                            break;
                        }
                        j += 2;
                    }
                    self.add(&segments);
                }
            }
            syn::visit::visit_macro(self, mac);
        }
    }

    let file = syn::parse_file(source).unwrap_or_else(|e| panic!("{}: {e}", own.join("::")));
    let mut paths = Paths { own, out: Vec::new() };
    paths.visit_file(&file);
    paths.out
}

/// A cycle in `graph`, if any, as the modules along it.
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(n: &str, graph: &BTreeMap<String, BTreeSet<String>>, state: &mut BTreeMap<String, u8>, stack: &mut Vec<String>) -> Option<Vec<String>> {
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in graph.get(n).into_iter().flatten() {
            match state.get(m.as_str()).copied().unwrap_or(0) {
                1 => {
                    let start = stack.iter().position(|s| s == m).unwrap();
                    let mut cycle = stack[start..].to_vec();
                    cycle.push(m.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(m, graph, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if state.get(n.as_str()).copied().unwrap_or(0) == 0
            && let Some(c) = visit(n, graph, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

#[test]
fn no_module_depends_on_itself_through_others() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    // Edges between siblings: for a file in module path p naming path q,
    // at the first level where they differ (within their common parent).
    let mut graphs: BTreeMap<Vec<String>, BTreeMap<String, BTreeSet<String>>> = BTreeMap::new();
    let mut edges = 0;
    for file in &files {
        let rel = file.strip_prefix(&src).unwrap();
        if rel == Path::new("main.rs") {
            continue; // the binary: the top of every chain
        }
        let own = module_path(rel);
        for target in references(&std::fs::read_to_string(file).unwrap(), &own) {
            let common = own.iter().zip(&target).take_while(|(a, b)| a == b).count();
            if common >= own.len() || common >= target.len() {
                continue; // itself, or one of its own submodules
            }
            let parent = own[..common].to_vec();
            graphs.entry(parent).or_default().entry(own[common].clone()).or_default().insert(target[common].clone());
            edges += 1;
        }
    }
    assert!(edges > 20, "only {edges} module references found: the scan is broken");
    for (parent, graph) in &graphs {
        if let Some(cycle) = find_cycle(graph) {
            panic!("modules of crate::{} depend in a cycle: {}", parent.join("::"), cycle.join(" -> "));
        }
    }
    // The scan sees the layers it is meant to check.
    let top = &graphs[&Vec::new()];
    assert!(top["field"].contains("scene") && top["render"].contains("field"), "{top:?}");
}
