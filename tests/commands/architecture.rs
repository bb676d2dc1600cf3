//! docs/architecture.md's dependency table is the code's: each library module's dependencies on
//! the others, read from its `crate::…` paths, are exactly the ones the table lists, and they
//! form no cycle. A page that says what a module knows nothing about is only worth reading if
//! it stays true.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

type Graph = BTreeMap<String, BTreeSet<String>>;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The library's top-level modules: every entry of src/ but the binary's.
fn modules() -> BTreeSet<String> {
    fs::read_dir(Path::new(ROOT).join("src"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|name| !matches!(name.as_str(), "main.rs" | "lib.rs" | "commands"))
        .map(|name| name.trim_end_matches(".rs").to_string())
        .collect()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    if dir.is_file() {
        out.push(dir.to_path_buf());
        return;
    }
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The text of a source file that is built outside tests: unit-test files and the inline
/// `#[cfg(test)] mod tests` at a file's end are left out, and so are comments.
fn shipped_text(path: &Path) -> String {
    let name = path.file_name().unwrap().to_str().unwrap();
    if name == "tests.rs" || name.ends_with("_tests.rs") {
        return String::new();
    }
    let text = fs::read_to_string(path).unwrap();
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(at) => &text[..at],
        None => &text[..],
    };
    text.lines()
        .map(|line| line.split("//").next().unwrap())
        .collect::<Vec<_>>()
        .join("\n")
}

/// The modules `text` names through `crate::NAME` or `crate::{NAME, …}`.
fn named_modules(text: &str, modules: &BTreeSet<String>) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    for (at, _) in text.match_indices("crate::") {
        let rest = &text[at + "crate::".len()..];
        let words: Vec<&str> = if let Some(group) = rest.strip_prefix('{') {
            let group = &group[..group.find('}').unwrap_or(group.len())];
            group
                .split(',')
                .map(|item| item.trim().split("::").next().unwrap().trim())
                .collect()
        } else {
            let end = rest
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            vec![&rest[..end]]
        };
        found.extend(
            words
                .into_iter()
                .filter(|w| modules.contains(*w))
                .map(String::from),
        );
    }
    found
}

fn code_graph() -> Graph {
    let modules = modules();
    let mut graph = Graph::new();
    for module in &modules {
        let src = Path::new(ROOT).join("src");
        let path = if src.join(module).is_dir() {
            src.join(module)
        } else {
            src.join(format!("{module}.rs"))
        };
        let mut files = Vec::new();
        rust_files(&path, &mut files);
        let mut deps = BTreeSet::new();
        for file in files {
            deps.extend(named_modules(&shipped_text(&file), &modules));
        }
        deps.remove(module);
        graph.insert(module.clone(), deps);
    }
    graph
}

/// The table under "### Dependencies": `| module | depends on |`, names in backticks, "—"
/// for none.
fn documented_graph() -> Graph {
    let page = fs::read_to_string(Path::new(ROOT).join("docs/architecture.md")).unwrap();
    let start = page
        .find("### Dependencies")
        .expect("docs/architecture.md has a \"### Dependencies\" table");
    let names = |cell: &str| -> BTreeSet<String> {
        cell.split('`')
            .skip(1)
            .step_by(2)
            .map(String::from)
            .collect()
    };
    page[start..]
        .lines()
        .skip_while(|line| !line.starts_with('|'))
        .take_while(|line| line.starts_with('|'))
        .skip(2)
        .map(|row| {
            let cells: Vec<&str> = row.split('|').collect();
            let module = names(cells[1]).into_iter().next().expect("a module name");
            (module, names(cells[2]))
        })
        .collect()
}

fn cycle(graph: &Graph) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        graph: &Graph,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(at) = path.iter().position(|n| n == node) {
            return Some(path[at..].to_vec());
        }
        if done.contains(node) {
            return None;
        }
        path.push(node.to_string());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(found) = visit(next, graph, path, done) {
                return Some(found);
            }
        }
        path.pop();
        done.insert(node.to_string());
        None
    }
    let mut done = BTreeSet::new();
    graph
        .keys()
        .find_map(|node| visit(node, graph, &mut Vec::new(), &mut done))
}

#[test]
fn the_documented_dependencies_are_the_codes() {
    let code = code_graph();
    let documented = documented_graph();
    let mut wrong = Vec::new();
    for module in code
        .keys()
        .chain(documented.keys())
        .collect::<BTreeSet<_>>()
    {
        let (said, done) = (documented.get(module), code.get(module));
        if said != done {
            wrong.push(format!(
                "`{module}`: the page says {said:?}, the code uses {done:?}"
            ));
        }
    }
    assert!(
        wrong.is_empty(),
        "docs/architecture.md's dependency table is out of date:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_modules_depend_on_each_other_without_a_cycle() {
    assert_eq!(cycle(&code_graph()), None);
}

#[test]
fn the_dependency_reader_sees_grouped_and_plain_paths() {
    let modules: BTreeSet<String> = ["plan", "robot", "pose"].map(String::from).into();
    let text = "use crate::{plan::Trajectory, robot};\nlet x = crate::pose::wrap(1.0);";
    assert_eq!(named_modules(text, &modules), modules);
    assert_eq!(
        cycle(&Graph::from([
            ("a".into(), BTreeSet::from(["b".into()])),
            ("b".into(), BTreeSet::from(["a".into()])),
        ])),
        Some(vec!["a".to_string(), "b".to_string()])
    );
}
