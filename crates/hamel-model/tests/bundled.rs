//! Every bundled model reads and passes the checks that need no computer algebra.

use hamel_model::Model;

#[test]
fn every_bundled_model_loads() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models");
    let mut n = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let m = Model::load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(!m.choices.is_empty(), "{}", m.name);
            assert_eq!(m.choices.iter().map(|c| c.eta.len()).min(), Some(m.sigma()));
            n += 1;
        }
    }
    assert!(n >= 8, "found {n} models");
}
