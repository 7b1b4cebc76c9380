//! docs/architecture.md is true to the code where a test can tell (issue 59): its section
//! "Crate dependencies" lists every crate of the workspace with the hamel crates it depends on
//! (`?` for an optional dependency), and which crates link the computer algebra with their
//! default features. Both are read from the Cargo.toml files and compared.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A crate's hamel dependencies (`name?` when optional) and its default features' optional
/// dependencies.
struct Manifest {
    deps: BTreeSet<String>,
    defaults: BTreeSet<String>,
}

/// Every crate of the workspace (the root package is `hamel`), read from its Cargo.toml.
fn manifests() -> BTreeMap<String, Manifest> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut paths = vec![root.join("Cargo.toml")];
    for e in std::fs::read_dir(root.join("crates")).unwrap() {
        paths.push(e.unwrap().path().join("Cargo.toml"));
    }
    paths.iter().map(|p| read(p)).collect()
}

fn read(path: &Path) -> (String, Manifest) {
    let text = std::fs::read_to_string(path).unwrap();
    let t: toml::Table = text.parse().unwrap();
    let name = t["package"]["name"].as_str().unwrap().to_string();
    let deps = t.get("dependencies").and_then(|d| d.as_table());
    let deps: BTreeSet<String> = deps
        .into_iter()
        .flatten()
        .filter(|(k, _)| k.starts_with("hamel-"))
        .map(|(k, v)| {
            let optional = v.get("optional").and_then(|o| o.as_bool()) == Some(true);
            if optional { format!("{k}?") } else { k.clone() }
        })
        .collect();
    let features = t.get("features").and_then(|f| f.as_table());
    let defaults: BTreeSet<String> = features
        .map(|f| default_deps(f, "default"))
        .unwrap_or_default();
    (name, Manifest { deps, defaults })
}

/// The optional dependencies feature `feature` turns on (`dep:NAME`, through other features).
fn default_deps(features: &toml::Table, feature: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let Some(list) = features.get(feature).and_then(|v| v.as_array()) else {
        return out;
    };
    for item in list.iter().filter_map(|v| v.as_str()) {
        match item.strip_prefix("dep:") {
            Some(dep) => {
                out.insert(dep.to_string());
            }
            None if features.contains_key(item) => out.extend(default_deps(features, item)),
            None => {}
        }
    }
    out
}

/// The crates that link hamel-cas with their default features.
fn linking_the_cas(m: &BTreeMap<String, Manifest>) -> BTreeSet<String> {
    let on = |name: &str| -> Vec<String> {
        let man = &m[name];
        (man.deps.iter())
            .filter_map(|d| match d.strip_suffix('?') {
                Some(opt) => man.defaults.contains(opt).then(|| opt.to_string()),
                None => Some(d.clone()),
            })
            .collect()
    };
    let reaches = |start: &str| {
        let mut seen = BTreeSet::new();
        let mut todo = vec![start.to_string()];
        while let Some(n) = todo.pop() {
            if seen.insert(n.clone()) {
                todo.extend(on(&n));
            }
        }
        seen.contains("hamel-cas")
    };
    m.keys().filter(|n| reaches(n)).cloned().collect()
}

/// The section's lines: `- \`NAME\`: DEP, DEP?` (or `none`), and `CAS: NAME, NAME`.
fn documented() -> (BTreeMap<String, BTreeSet<String>>, BTreeSet<String>) {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/architecture.md"))
            .unwrap();
    let start = text
        .find("## Crate dependencies")
        .expect("docs/architecture.md has a section `## Crate dependencies`");
    let section = &text[start..];
    let section = &section[..section[3..].find("\n## ").map_or(section.len(), |i| i + 3)];
    let list = |s: &str| -> BTreeSet<String> {
        s.split(',')
            .map(|d| d.trim().trim_matches('`').to_string())
            .filter(|d| !d.is_empty() && d != "none")
            .collect()
    };
    let mut deps = BTreeMap::new();
    let mut cas = BTreeSet::new();
    for line in section.lines() {
        if let Some(rest) = line.strip_prefix("- `")
            && let Some((name, after)) = rest.split_once("`:")
        {
            deps.insert(name.to_string(), list(after.trim_end_matches('.')));
        } else if let Some(rest) = line.strip_prefix("Linking the computer algebra:") {
            cas = list(rest.trim_end_matches('.'));
        }
    }
    (deps, cas)
}

#[test]
fn the_architecture_lists_every_crates_dependencies_as_the_manifests_do() {
    let m = manifests();
    let (deps, cas) = documented();
    let actual: BTreeMap<String, BTreeSet<String>> =
        m.iter().map(|(k, v)| (k.clone(), v.deps.clone())).collect();
    for (name, want) in &actual {
        assert_eq!(
            deps.get(name),
            Some(want),
            "docs/architecture.md, `## Crate dependencies`: `{name}` depends on {want:?}"
        );
    }
    let extra: Vec<&String> = deps.keys().filter(|k| !actual.contains_key(*k)).collect();
    assert!(
        extra.is_empty(),
        "documented crates that do not exist: {extra:?}"
    );
    assert_eq!(
        cas,
        linking_the_cas(&m),
        "docs/architecture.md: the crates linking the computer algebra"
    );
}
