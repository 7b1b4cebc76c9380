//! Cargo manifests of generated crates, written and edited with a TOML writer (`toml_edit`),
//! never by replacing text: every value is escaped by the writer, whatever it holds.

use toml_edit::{Array, DocumentMut, InlineTable, Item, Table, value};

/// The manifest of a generated crate: package `package` (made a valid package name by
/// [`crate::escape::package_name`]), the library `hamel_generated`, the vendored
/// `hamel-runtime` (`vendor/hamel-runtime` inside the crate), serde and serde_json, and an empty
/// `[workspace]` so that the crate is not a member of any enclosing workspace.
pub fn generated(package: &str) -> String {
    let mut doc = DocumentMut::new();
    doc["package"] = package_table(package);
    let mut lib = Table::new();
    lib["name"] = value("hamel_generated");
    lib["path"] = value("src/lib.rs");
    doc["lib"] = Item::Table(lib);
    let mut deps = Table::new();
    let mut runtime = InlineTable::new();
    runtime.insert("path", "vendor/hamel-runtime".into());
    deps["hamel-runtime"] = value(runtime);
    deps["serde"] = value(with_features("1", &["derive"]));
    deps["serde_json"] = value("1");
    doc["dependencies"] = Item::Table(deps);
    let mut workspace = Table::new();
    workspace
        .decor_mut()
        .set_prefix("\n# Standalone: not a member of any enclosing workspace.\n");
    doc["workspace"] = Item::Table(workspace);
    doc.to_string()
}

/// The manifest of the vendored numeric runtime (`vendor/hamel-runtime` in a generated crate;
/// std and libm).
pub fn runtime() -> String {
    let mut doc = DocumentMut::new();
    doc["package"] = package_table("hamel-runtime");
    let mut deps = Table::new();
    deps["libm"] = value("0.2");
    doc["dependencies"] = Item::Table(deps);
    doc.to_string()
}

/// The manifest of the vendored integrators (`hamel-sim` inside a generated crate).
pub fn simulator() -> String {
    let mut doc = DocumentMut::new();
    doc["package"] = package_table("hamel-sim");
    let mut deps = Table::new();
    deps["nalgebra"] = value("0.34");
    deps["rayon"] = value("1");
    deps["serde"] = value(with_features("1", &["derive"]));
    deps["serde_json"] = value("1");
    deps["thiserror"] = value("2");
    doc["dependencies"] = Item::Table(deps);
    doc.to_string()
}

fn package_table(name: &str) -> Item {
    let mut package = Table::new();
    package["name"] = value(crate::escape::package_name(&[name]));
    package["version"] = value("0.1.0");
    package["edition"] = value("2024");
    package["publish"] = value(false);
    Item::Table(package)
}

fn with_features(version: &str, features: &[&str]) -> InlineTable {
    let mut t = InlineTable::new();
    t.insert("version", version.into());
    t.insert(
        "features",
        Array::from_iter(features.iter().copied()).into(),
    );
    t
}

/// Edit a manifest: parse it, apply `edit`, write it back.
pub fn edit(
    text: &str,
    edit: impl FnOnce(&mut DocumentMut),
) -> Result<String, crate::CodegenError> {
    let mut doc: DocumentMut = text.parse().map_err(|e| {
        crate::CodegenError::Internal(format!("a generated manifest does not parse: {e}"))
    })?;
    edit(&mut doc);
    Ok(doc.to_string())
}

/// Add a path dependency `name = { path = "path" }`.
pub fn add_path_dependency(doc: &mut DocumentMut, name: &str, path: &str) {
    let mut dep = InlineTable::new();
    dep.insert("path", path.into());
    doc["dependencies"][name] = value(dep);
}

/// Point the dependencies on the crate's vendored copies (`path = "vendor/NAME"`) at `dir`
/// instead (`dir/NAME`): what a code cache does, whose entries share one copy of them (built
/// once in its target directory, not once an entry).
pub fn relocate_vendored(doc: &mut DocumentMut, dir: &str) {
    let Some(deps) = doc
        .get_mut("dependencies")
        .and_then(Item::as_table_like_mut)
    else {
        return;
    };
    for (_, dep) in deps.iter_mut() {
        let Some(table) = dep.as_table_like_mut() else {
            continue;
        };
        let vendored = (table.get("path").and_then(Item::as_str))
            .and_then(|p| p.strip_prefix("vendor/"))
            .map(|name| format!("{dir}/{name}"));
        if let Some(path) = vendored {
            table.insert("path", value(path));
        }
    }
}

/// Rename the package (to a valid package name, see [`crate::escape::package_name`]).
pub fn rename_package(doc: &mut DocumentMut, name: &str) {
    doc["package"]["name"] = value(crate::escape::package_name(&[name]));
}

/// Add a `[[bin]]` target.
pub fn add_binary(doc: &mut DocumentMut, name: &str, path: &str) {
    let mut bin = Table::new();
    bin["name"] = value(name);
    bin["path"] = value(path);
    match doc.get_mut("bin").and_then(Item::as_array_of_tables_mut) {
        Some(bins) => bins.push(bin),
        None => {
            let mut bins = toml_edit::ArrayOfTables::new();
            bins.push(bin);
            doc["bin"] = Item::ArrayOfTables(bins);
        }
    }
}

/// Make the library a C-ABI shared library named `name` (`lib{name}.so` on Linux): what
/// [`crate::with_c_abi`] builds for hamel's Python package.
pub fn c_library(doc: &mut DocumentMut, name: &str) {
    doc["lib"]["name"] = value(crate::escape::package_name(&[name]).replace('-', "_"));
    doc["lib"]["crate-type"] = value(Array::from_iter(["cdylib"]));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifests_parse_and_edits_keep_them_valid() {
        let text = generated("hamel-model-knife-paper\n[evil]\nx = 1");
        let read: toml::Table = text.parse().unwrap();
        assert_eq!(
            read["package"]["name"].as_str(),
            Some("hamel-model-knife-paper-evil-x-1")
        );
        assert!(read.get("evil").is_none());
        assert!(read["workspace"].as_table().unwrap().is_empty());
        let edited = edit(&text, |doc| {
            add_path_dependency(doc, "hamel-sim", "hamel-sim");
            rename_package(doc, "hamel-scene-0123");
            add_binary(doc, "scene-0123", "src/scene_main.rs");
            relocate_vendored(doc, "../vendor/0123");
        })
        .unwrap();
        let read: toml::Table = edited.parse().unwrap();
        assert_eq!(
            read["dependencies"]["hamel-sim"]["path"].as_str(),
            Some("hamel-sim")
        );
        assert_eq!(
            read["dependencies"]["hamel-runtime"]["path"].as_str(),
            Some("../vendor/0123/hamel-runtime")
        );
        assert_eq!(read["package"]["name"].as_str(), Some("hamel-scene-0123"));
        assert_eq!(read["bin"][0]["name"].as_str(), Some("scene-0123"));
        let sim: toml::Table = simulator().parse().unwrap();
        assert_eq!(sim["dependencies"]["nalgebra"].as_str(), Some("0.34"));
    }
}
