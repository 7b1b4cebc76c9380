//! The generated numeric cores checked in under `generated/` (and compiled together by
//! `crates/hamel-models`) are what `hamel codegen` writes today.
//!
//! For every bundled model and every quasi-velocity choice without free functions, the core is
//! generated with the paper's elimination (`common::ELIMINATE`) when `hamel reduce` proves it,
//! and for the full system otherwise. Regenerate after a change with
//! `UPDATE_GENERATED=1 cargo test --release --test codegen`. The CAS runs in-process, on its
//! one worker thread.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use hamel_codegen::registry::{Member, models_lib};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every file the generator writes, path relative to the repository root → text.
fn generate_all() -> BTreeMap<PathBuf, String> {
    let mut files = BTreeMap::new();
    let mut members = Vec::new();
    for model in common::models() {
        // as `hamel codegen` derives it: with the wheels' supports, for the constraint forces
        let model = model.with_supports().unwrap();
        let file = Path::new(&model.file)
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let asked = common::eliminate(&model);
        for choice in model.choices.iter().filter(|c| c.free_functions.is_empty()) {
            let (r, d) =
                common::reduce_with_derivation(&model, Some(&choice.name), &asked).unwrap();
            let proven = r.ground_truth.present.is_empty() && r.reduced_system.is_some();
            let (eliminated, flag) = if proven {
                (
                    hamel_reduce::coordinate_indices(&model, &asked).unwrap(),
                    format!(" --eliminate {}", asked.join(",")),
                )
            } else {
                (Vec::new(), String::new())
            };
            let command = format!(
                "hamel codegen models/{file} --eta {}{flag} --out DIR",
                choice.name
            );
            let g = hamel_codegen::generate(&d, &eliminated, &command).unwrap();
            let dir = format!("{}__{}", model.name, choice.name);
            for (path, text) in g.files {
                files.insert(Path::new("generated").join(&dir).join(path), text);
            }
            members.push(Member {
                dir,
                model: model.name.clone(),
                eta: choice.name.clone(),
                scene: String::new(),
            });
        }
    }
    for &(scene, eta, dir) in common::CLOSED_LOOPS {
        let model = common::closed_loop(scene);
        let asked = common::eliminate(&model);
        let (r, d) = common::reduce_with_derivation(&model, Some(eta), &asked).unwrap();
        assert!(r.ground_truth.present.is_empty() && r.reduced_system.is_some());
        let eliminated = hamel_reduce::coordinate_indices(&model, &asked).unwrap();
        let command = format!(
            "the closed loop of {scene} (tests/codegen.rs), --eta {eta} --eliminate {}",
            asked.join(",")
        );
        let g = hamel_codegen::generate(&d, &eliminated, &command).unwrap();
        for (path, text) in g.files {
            files.insert(Path::new("generated").join(dir).join(path), text);
        }
        members.push(Member {
            dir: dir.to_string(),
            model: model.name.clone(),
            eta: eta.to_string(),
            scene: scene.to_string(),
        });
    }
    files.insert(
        PathBuf::from("crates/hamel-models/src/lib.rs"),
        models_lib(&members).unwrap(),
    );
    files
}

fn on_disk(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let p = e.path();
        if p.is_dir() {
            if p.file_name().is_some_and(|n| n != "target") {
                on_disk(&p, out);
            }
        } else {
            out.push(p.strip_prefix(root()).unwrap().to_path_buf());
        }
    }
}

#[test]
fn checked_in_generated_code_is_what_codegen_writes() {
    let files = generate_all();
    let update = std::env::var_os("UPDATE_GENERATED").is_some();
    let mut stale = Vec::new();
    for (path, text) in &files {
        let full = root().join(path);
        let current = std::fs::read_to_string(&full).unwrap_or_default();
        if current != *text {
            if update {
                std::fs::create_dir_all(full.parent().unwrap()).unwrap();
                std::fs::write(&full, text).unwrap();
            } else {
                stale.push(path.display().to_string());
            }
        }
    }
    // Files under generated/ that the generator no longer writes.
    let mut existing = Vec::new();
    on_disk(&root().join("generated"), &mut existing);
    for p in existing {
        if !files.contains_key(&p) && p.file_name().is_some_and(|n| n != "README.md") {
            if update {
                std::fs::remove_file(root().join(&p)).unwrap();
            } else {
                stale.push(format!("{} (no longer generated)", p.display()));
            }
        }
    }
    assert!(
        stale.is_empty(),
        "generated code is out of date; run `UPDATE_GENERATED=1 cargo test --release --test codegen`:\n  {}",
        stale.join("\n  ")
    );
}
