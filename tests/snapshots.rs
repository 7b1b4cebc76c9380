//! Snapshots of `hamel derive`, `hamel reduce` and `hamel search` (their JSON reports, and
//! `hamel derive`'s printed text) for
//! every bundled model: derive and reduce for every quasi-velocity choice, reduce and search
//! for the coordinates the paper eliminates (`common::ELIMINATE`).
//!
//! The text is the derivation's normal form, which does not depend on the order in which
//! symbols were created, on test order or on threads. Entries longer than 2000 characters (the
//! unicycle's and the wheeled bar's Q run to megabytes) are replaced by their length and a
//! 64-bit FNV-1a digest, so any change still fails the snapshot while the files stay readable.
//! The CAS runs in-process, on its one worker thread.

mod common;

use common::{eliminate, models};
use hamel_model::Model;

fn fnv1a(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

fn digest_long_strings(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::String(s) if s.chars().count() > 2000 => {
            *s = format!(
                "<{} characters, fnv1a64 {:016x}>",
                s.chars().count(),
                fnv1a(s)
            );
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(digest_long_strings),
        serde_json::Value::Object(o) => o.values_mut().for_each(digest_long_strings),
        _ => {}
    }
}

fn snapshot_of(model: &Model, choice: &str) -> String {
    let d = hamel_derive::derive(model, Some(choice)).unwrap();
    // With the size of every object, so that swell shows up as a failing diff.
    let mut v = serde_json::to_value(d.json()).unwrap();
    digest_long_strings(&mut v);
    serde_json::to_string_pretty(&v).unwrap()
}

#[test]
fn derive_json_snapshots() {
    for model in models() {
        for choice in &model.choices {
            let name = format!("derive__{}__{}", model.name, choice.name);
            insta::assert_snapshot!(name, snapshot_of(&model, &choice.name));
        }
    }
}

/// `text` with its lines longer than 2000 characters digested.
fn digest_lines(text: &str) -> String {
    let lines: Vec<String> = text
        .lines()
        .map(|l| {
            let mut v = serde_json::Value::String(l.to_string());
            digest_long_strings(&mut v);
            v.as_str().unwrap().to_string()
        })
        .collect();
    lines.join("\n")
}

/// `hamel derive`'s text: every entry in its printing form (collected, factored, named), the
/// where-list at the end. Lines longer than 2000 characters are digested as above.
#[test]
fn printed_text_snapshots() {
    for model in models() {
        for choice in &model.choices {
            let d = hamel_derive::derive(&model, Some(&choice.name)).unwrap();
            // The entries printing reads first are those the text shows, in its order.
            let recorded = std::cell::RefCell::new(Vec::new());
            d.to_text_with(&|e, _| recorded.borrow_mut().push(std::ptr::from_ref(e)));
            let shown: Vec<_> = d.shown().into_iter().map(std::ptr::from_ref).collect();
            assert_eq!(
                shown,
                recorded.into_inner(),
                "{} {}",
                model.name,
                choice.name
            );
            reads_alike(&d, &format!("{} {}", model.name, choice.name));
            let text = hamel_print::derivation::text(&d).unwrap();
            let name = format!("printed__{}__{}", model.name, choice.name);
            insta::assert_snapshot!(name, digest_lines(&text));
        }
    }
}

/// Printing reads the polynomials the computer algebra exported as it would read their trees:
/// the same fractions, the atoms numbered in the same order (entry after entry, as a sheet
/// reads them), and each tree is the one written from its polynomials.
fn reads_alike(d: &hamel_derive::Derivation, what: &str) {
    use hamel_print::{Atoms, Fraction};
    let vocabulary = hamel_print::derivation::vocabulary(d);
    let mut by_tree = Atoms::new(vocabulary.clone());
    let mut by_canonical = Atoms::new(vocabulary);
    let mut read = 0;
    for e in d.shown() {
        let Some(c) = &e.canonical else { continue };
        assert_eq!(c.to_expr(), e.expr, "{what}: {}", e.text);
        let tree = Fraction::from_expr(&e.expr, &mut by_tree).unwrap();
        let canonical = Fraction::from_canonical(c, &mut by_canonical);
        assert_eq!(
            canonical.normalised(),
            tree.normalised(),
            "{what}: {}",
            e.text
        );
        read += 1;
    }
    assert!(read > 0, "{what}: no exported polynomials");
    let keys = |a: &Atoms| {
        (0..a.len())
            .map(|i| a.get(i).key.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(keys(&by_canonical), keys(&by_tree), "{what}");
}

/// `hamel reduce`'s text: the reduced system in printing forms, with its where-list.
#[test]
fn printed_reduce_snapshots() {
    for model in models() {
        let p = eliminate(&model);
        for choice in &model.choices {
            let r = hamel_reduce::reduce(&model, Some(&choice.name), &p).unwrap();
            let text = hamel_print::reduction::text(&r, &model).unwrap();
            let name = format!("printed_reduce__{}__{}", model.name, choice.name);
            insta::assert_snapshot!(name, digest_lines(&text));
        }
    }
}

fn json(value: &impl serde::Serialize) -> String {
    let mut v = serde_json::to_value(value).unwrap();
    digest_long_strings(&mut v);
    serde_json::to_string_pretty(&v).unwrap()
}

#[test]
fn reduce_json_snapshots() {
    for model in models() {
        let p = eliminate(&model);
        for choice in &model.choices {
            let r = hamel_reduce::reduce(&model, Some(&choice.name), &p).unwrap();
            let name = format!("reduce__{}__{}", model.name, choice.name);
            insta::assert_snapshot!(name, json(&r));
        }
    }
}

#[test]
fn search_json_snapshots() {
    for model in models() {
        let options = hamel_reduce::SearchOptions {
            // Far above any seed example's search (< 3 s), so the budget never cuts a
            // snapshot short.
            budget: std::time::Duration::from_secs(600),
            max_candidates: 12,
        };
        let mut r =
            hamel_reduce::search(&model, &eliminate(&model), options, Box::new(|_| {})).unwrap();
        assert!(!r.stop.budget(), "{:?}", r.stop);
        r.seconds = 0.0; // wall time: not part of the snapshot
        insta::assert_snapshot!(format!("search__{}", model.name), json(&r));
    }
}

#[test]
fn derivations_do_not_depend_on_what_ran_before() {
    // The same derivation after other models (other symbols created, other fields built)
    // prints the same text.
    let all = models();
    let knife = all.iter().find(|m| m.name == "knife").unwrap();
    let first = snapshot_of(knife, "general");
    for m in all.iter().rev() {
        let _ = snapshot_of(m, &m.choices[0].name);
    }
    assert_eq!(first, snapshot_of(knife, "general"));
}
