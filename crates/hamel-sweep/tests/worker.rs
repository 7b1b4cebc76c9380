//! The `hamel-sweep` worker against the library: a study of the bicycle made in-process (its one
//! symbolic pass, on this test's CAS thread) and exported, then run by the worker in its own
//! process, gives the same sweep, byte for byte, as the study run in-process; the worker never
//! starts Symbolica; damaged or missing study files are errors that name them; and the worker's
//! own dependency graph (built alone) has no computer algebra.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use hamel_model::Model;
use hamel_study::{Point, Range, Study};

struct Quiet;
impl hamel_study::Progress for Quiet {
    fn start(&self, _: u64) {}
    fn tick(&self) {}
    fn finish(&self) {}
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn worker(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hamel-sweep"))
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn the_worker_runs_an_exported_study_as_the_library_does() {
    let model = Model::load(root().join("models/whipple_bicycle.toml")).unwrap();
    let study = Study::prepare(&model, None, "upright").unwrap();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("hamel-sweep");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bicycle.study.json");
    std::fs::write(&file, serde_json::to_string(&study.export()).unwrap()).unwrap();
    let base = Point([("c".to_string(), 0.1)].into_iter().collect());
    let range = Range::parse("v=0:10:21").unwrap();
    let want = study.run(&base, &[range], &Quiet).unwrap().json();
    let out = dir.join("sweep.json");
    let o = worker(&[
        file.to_str().unwrap(),
        "--sweep",
        "v=0:10:21",
        "--set",
        "c=0.1",
        "--format",
        "json",
        "--output",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), want);
    let printed = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert!(
        !printed.contains("Symbolica"),
        "the worker started Symbolica: {printed}"
    );

    let damaged = dir.join("damaged.json");
    let text = std::fs::read_to_string(&file).unwrap();
    std::fs::write(&damaged, text.replacen("hamel-study/1", "hamel-study/0", 1)).unwrap();
    for (bad, want) in [
        (damaged.to_str().unwrap(), "format"),
        ("/no/such/study.json", "cannot read"),
    ] {
        let o = worker(&[bad]);
        assert_eq!(o.status.code(), Some(1), "{bad}");
        assert!(
            stderr(&o).contains(bad) && stderr(&o).contains(want),
            "{bad}: {}",
            stderr(&o)
        );
    }
}

#[test]
fn the_worker_alone_has_no_computer_algebra() {
    let tree = Command::new(env!("CARGO"))
        .args([
            "tree",
            "--offline",
            "-p",
            "hamel-sweep",
            "-e",
            "normal",
            "--prefix",
            "none",
        ])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(tree.status.success(), "{}", stderr(&tree));
    let tree = String::from_utf8_lossy(&tree.stdout);
    assert!(tree.contains("hamel-study"), "{tree}");
    assert!(
        !tree.contains("symbolica") && !tree.contains("hamel-cas"),
        "{tree}"
    );
}
