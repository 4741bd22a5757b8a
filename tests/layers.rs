//! The crate's top-level modules form layers: a module uses only modules below it, never
//! one that uses it back. This test reads every file under `src/`, takes the `crate::…`
//! paths it names (in `use` lines, `crate::{a, b}` groups and inline paths, outside
//! comments) as edges from the file's top-level module to the named one, and fails on any
//! cycle in that graph, printing each cycle with the files that make its edges.
//!
//! Test code is left out (files `tests.rs` and `*_tests.rs`, and every `#[cfg(test)]`
//! item): a test may set up its case with a higher layer, as a unit test of the executor
//! runs a whole pipeline to make its inputs, the way a crate's dev-dependencies may depend
//! on the crate.
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// module -> used module -> files (relative to src/) that use it.
type Graph = BTreeMap<String, BTreeMap<String, BTreeSet<String>>>;

/// The text of `src` without `//` line comments (doc comments included) and `/* */`
/// blocks; string literals are kept as they are (a `crate::` inside one would count).
fn strip_comments(src: &str) -> String {
    let mut out = String::with_capacity(src.len());
    let mut rest = src;
    let mut in_string = false;
    while let Some(c) = rest.chars().next() {
        if in_string {
            if rest.starts_with("\\\"") || rest.starts_with("\\\\") {
                out.push_str(&rest[..2]);
                rest = &rest[2..];
                continue;
            }
            if c == '"' {
                in_string = false;
            }
        } else if rest.starts_with("//") {
            let end = rest.find('\n').unwrap_or(rest.len());
            rest = &rest[end..];
            continue;
        } else if rest.starts_with("/*") {
            let end = rest.find("*/").map(|e| e + 2).unwrap_or(rest.len());
            rest = &rest[end..];
            continue;
        } else if c == '"' && !out.ends_with('\'') && !out.ends_with("'\\") {
            // (not the char literals '"' and '\"')
            in_string = true;
        }
        out.push(c);
        rest = &rest[c.len_utf8()..];
    }
    out
}

/// `code` without the items marked `#[cfg(test)]` (a `mod x;` line, or an item up to its
/// matching closing brace).
fn strip_test_items(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let item = &rest[at..];
        let (semi, brace) = (item.find(';'), item.find('{'));
        let end = match (semi, brace) {
            (Some(s), b) if b.is_none_or(|b| s < b) => s + 1,
            (_, Some(b)) => {
                let mut depth = 0usize;
                let mut end = item.len();
                for (i, c) in item[b..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = b + i + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                end
            }
            _ => item.len(),
        };
        rest = &item[end..];
    }
    out.push_str(rest);
    out
}

/// The top-level modules that `code` names through `crate::`.
fn used_modules(code: &str) -> BTreeSet<String> {
    let ident = |s: &str| -> String { s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect() };
    let mut used = BTreeSet::new();
    for (at, _) in code.match_indices("crate::") {
        // `crate::` preceded by an identifier character is another path (`laydown_crate::`).
        if code[..at].chars().next_back().is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let after = code[at + "crate::".len()..].trim_start();
        if let Some(group) = after.strip_prefix('{') {
            // `crate::{a::x, b, c::{y, z}}`: the first segment of every item at depth 0
            let (mut depth, mut item_start) = (0usize, true);
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => item_start = true,
                    c if item_start && !c.is_whitespace() => {
                        item_start = false;
                        let name = ident(&group[i..]);
                        if !name.is_empty() {
                            used.insert(name);
                        }
                    }
                    _ => {}
                }
            }
        } else {
            let name = ident(after);
            if !name.is_empty() {
                used.insert(name);
            }
        }
    }
    used
}

/// The module graph of every `.rs` file under `src/` (lib.rs and main.rs, which only
/// declare and call the modules, left out).
fn module_graph(src: &Path) -> Graph {
    fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    let mut files = vec![];
    walk(src, &mut files);
    let mut graph = Graph::new();
    for f in files {
        let rel = f.strip_prefix(src).unwrap().to_string_lossy().replace('\\', "/");
        let top = rel.split('/').next().unwrap().trim_end_matches(".rs").to_string();
        let name = rel.rsplit('/').next().unwrap();
        if top == "lib" || top == "main" || name == "tests.rs" || name.ends_with("_tests.rs") || rel.contains("/tests/") {
            continue;
        }
        let code = strip_test_items(&strip_comments(&std::fs::read_to_string(&f).unwrap()));
        let edges = graph.entry(top.clone()).or_default();
        for used in used_modules(&code) {
            if used != top && used != "self" && used != "super" {
                edges.entry(used).or_default().insert(rel.clone());
            }
        }
    }
    graph
}

/// The shortest cycle start -> ... -> start inside `component` (breadth first).
fn shortest_cycle(graph: &Graph, component: &BTreeSet<String>, start: &str) -> Vec<String> {
    let mut parent: BTreeMap<String, String> = BTreeMap::new();
    let mut queue = std::collections::VecDeque::from([start.to_string()]);
    let mut last = None;
    'search: while let Some(a) = queue.pop_front() {
        for b in graph[&a].keys().filter(|b| component.contains(*b)) {
            if b == start {
                last = Some(a.clone());
                break 'search;
            }
            if !parent.contains_key(b) {
                parent.insert(b.clone(), a.clone());
                queue.push_back(b.clone());
            }
        }
    }
    let mut middle = vec![];
    let mut at = last.expect("a module of a component is on a cycle");
    while at != start {
        middle.push(at.clone());
        at = parent[&at].clone();
    }
    middle.reverse();
    std::iter::once(start.to_string()).chain(middle).chain(std::iter::once(start.to_string())).collect()
}

/// The cycles of the graph: for every strongly connected component of more than one
/// module, shortest cycles through its modules until each module is on one, each
/// printed as `a -> b -> a` with the files that make each edge.
fn cycles(graph: &Graph) -> Vec<String> {
    let reach = |from: &str| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut todo = vec![from.to_string()];
        while let Some(n) = todo.pop() {
            for m in graph.get(&n).into_iter().flat_map(|e| e.keys()) {
                if seen.insert(m.clone()) {
                    todo.push(m.clone());
                }
            }
        }
        seen
    };
    let reachable: BTreeMap<&String, BTreeSet<String>> = graph.keys().map(|n| (n, reach(n))).collect();
    let mut covered: BTreeSet<String> = BTreeSet::new();
    let mut found = vec![];
    for n in graph.keys() {
        if covered.contains(n) || !reachable[n].contains(n) {
            continue;
        }
        // the component of n: the modules that n reaches and that reach n
        let component: BTreeSet<String> = reachable[n].iter().filter(|m| reachable.get(m).is_some_and(|r| r.contains(n))).cloned().collect();
        for m in &component {
            if covered.contains(m) {
                continue;
            }
            let path = shortest_cycle(graph, &component, m);
            covered.extend(path.iter().cloned());
            let edges: Vec<String> = path
                .windows(2)
                .map(|w| format!("  {} -> {}: {}", w[0], w[1], graph[&w[0]][&w[1]].iter().cloned().collect::<Vec<_>>().join(", ")))
                .collect();
            found.push(format!("cycle {}\n{}", path.join(" -> "), edges.join("\n")));
        }
    }
    found
}

#[test]
fn top_level_modules_have_no_import_cycles() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let graph = module_graph(&src);
    assert!(graph.len() > 10 && graph["stages"].contains_key("archive"), "the graph was not read: {graph:?}");
    let found = cycles(&graph);
    assert!(found.is_empty(), "import cycles between top-level modules:\n{}", found.join("\n"));
}

/// The parser finds what it should: groups, nested groups, inline paths; not comments or
/// other crates' paths.
#[test]
fn crate_paths_are_read_from_uses_groups_and_inline_paths() {
    let code = strip_comments(
        "use crate::a::X;\nuse crate::{b, c::{D, e::F}};\n// use crate::commented;\n/// [`crate::doc`]\nfn f() { crate::g::h(); laydown_crate::no(); let s = \"//\"; crate::after_string::x(); }",
    );
    let used: Vec<String> = used_modules(&code).into_iter().collect();
    assert_eq!(used, ["a", "after_string", "b", "c", "g"]);
}

/// Test items are cut out whole, and nothing else.
#[test]
fn test_items_are_left_out() {
    let code = "use crate::a;\n#[cfg(test)]\nmod tests;\nuse crate::b;\n#[cfg(test)]\nmod more {\n    fn f() { if x { crate::t::y(); } }\n}\nfn g() { crate::c::z(); }\n";
    let used: Vec<String> = used_modules(&strip_test_items(code)).into_iter().collect();
    assert_eq!(used, ["a", "b", "c"]);
}

/// A cycle is found and printed with the files of its edges.
#[test]
fn a_cycle_is_reported_with_its_files() {
    let mut g = Graph::new();
    let mut edge = |a: &str, b: &str, f: &str| {
        g.entry(a.into()).or_default().entry(b.into()).or_default().insert(f.into());
        g.entry(b.into()).or_default();
    };
    edge("cli", "plot", "cli.rs");
    edge("plot", "cli", "plot/mod.rs");
    edge("plot", "archive", "plot/mod.rs");
    let found = cycles(&g);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].starts_with("cycle cli -> plot -> cli") && found[0].contains("plot -> cli: plot/mod.rs"), "{}", found[0]);
}
