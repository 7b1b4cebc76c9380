//! Every expression of every seed model's derivation (the canonical texts of
//! tests/snapshots/snapshots__derive__*.snap, made by `hamel derive`) has a printing form that
//! expands back to it exactly, and whose text parses back to the same printing form.

use hamel_expr::parse;
use hamel_print::{Printed, Sheet, Vocabulary, width, width_at_least};
use serde_json::Value;

fn strings(v: &Value, out: &mut Vec<String>) {
    match v {
        Value::String(s) => out.push(s.clone()),
        Value::Array(a) => a.iter().for_each(|x| strings(x, out)),
        _ => {}
    }
}

/// Names from a list, or the keys of a table (the parameters with their values).
fn names(v: &Value) -> Vec<String> {
    match v {
        Value::Array(a) => a
            .iter()
            .filter_map(|x| x.as_str().map(String::from))
            .collect(),
        Value::Object(o) => o.keys().cloned().collect(),
        _ => Vec::new(),
    }
}

#[test]
fn every_entry_of_every_seed_model_prints_exactly() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/snapshots");
    let mut checked = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if !name.starts_with("snapshots__derive__") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let json: Value = serde_json::from_str(text.splitn(3, "---\n").nth(2).unwrap()).unwrap();
        let sigma = json["sigma"].as_u64().unwrap() as usize;
        assert!(json["parameters"].is_object() && json["coordinates"].is_array());
        let vocabulary = Vocabulary {
            parameters: names(&json["parameters"]),
            coordinates: names(&json["coordinates"]),
            velocities: (1..=sigma)
                .flat_map(|i| [format!("eta{i}"), format!("eta{i}_dot")])
                .collect(),
        };
        let mut exprs = Vec::new();
        for key in [
            "a",
            "alpha",
            "z",
            "gamma",
            "a_gamma",
            "equations",
            "kinematics",
            "energy",
            "delta",
        ] {
            strings(&json[key], &mut exprs);
        }
        let mut sheet = Sheet::new(&vocabulary);
        let ids: Vec<usize> = exprs
            .iter()
            .filter_map(|e| parse(e).ok())
            .map(|p| sheet.add(&p.expr).unwrap())
            .collect();
        sheet.name_groups();
        // The check at a random point modulo a prime agrees with the exact one below.
        assert_eq!(sheet.first_mismatch(), None, "{name}");
        for &i in &ids {
            assert!(
                sheet.check(i),
                "{name}: entry {i} with names: {}",
                sheet.text(i)
            );
            // The bound by which wide groups are found without rendering them is a bound.
            let latex = sheet.latex(i);
            assert!(
                width_at_least(sheet.form(i)) <= width(&latex),
                "{name}: entry {i}: {latex}"
            );
        }
        for (j, d) in sheet.definitions().iter().enumerate() {
            let latex = sheet.definition_lines(j, usize::MAX).concat();
            assert!(width_at_least(&d.form) <= width(&latex), "{name}: {latex}");
        }
        if std::env::var_os("SHOW_PRINTED").is_some() {
            eprintln!("== {name}");
            for (n, d) in sheet.definitions_text() {
                eprintln!("  {n} = {d}");
            }
            for &i in ids.iter().take(40) {
                eprintln!("  {}", sheet.text(i));
            }
        }
        for e in exprs {
            let Ok(parsed) = parse(&e) else { continue };
            let p = Printed::new(&parsed.expr, &vocabulary)
                .unwrap_or_else(|err| panic!("{name}: {e}: {err}"));
            assert!(p.check(), "{name}: {e}\n  printed {}", p.text());
            let again = Printed::new(&parse(&p.text()).unwrap().expr, &vocabulary).unwrap();
            assert!(again.check());
            checked += 1;
        }
    }
    assert!(checked > 1000, "only {checked} expressions found");
}
