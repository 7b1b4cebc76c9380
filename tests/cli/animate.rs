//! `hamel simulate --animate`: the page opened in a real headless Chromium (Debian's
//! `chromium`; `.ci/run` installs it; these tests skip, saying so, where it is missing).
//!
//! The page reports, through `#probe`, `window.hamel.poseAt` at every output time and a
//! quarter of the way to the next. At the output times they must equal the poses of the
//! simulation's configurations (evaluated here by `hamel_view::poses` from a run that requests
//! every coordinate) to 1e-9; in between, the interpolation of those (positions linearly,
//! rotations by nalgebra's slerp; a normalised linear blend of the quaternions fails it). The
//! render must not be blank and the browser's console must stay silent.

#[allow(unused_imports)]
use super::*;

use std::process::Stdio;
use std::time::{Duration, Instant};

use hamel_view::poses::{Pose, poses};
use nalgebra::{Quaternion, UnitQuaternion};

/// The headless browser, or None (and a message) where it is not installed.
fn chromium() -> Option<PathBuf> {
    let name = std::env::var_os("HAMEL_CHROMIUM").unwrap_or_else(|| "chromium".into());
    let found = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(&name))
            .find(|p| p.is_file())
    });
    if found.is_none() {
        eprintln!(
            "skipping: no `{}` on PATH (Debian's chromium; .ci/run installs it)",
            name.to_string_lossy()
        );
    }
    found
}

/// What the browser printed and wrote: stdout (the DOM for `--dump-dom`) and the console's
/// lines of stderr.
struct Browsed {
    stdout: String,
    console: Vec<String>,
}

/// Open `url` in headless Chromium with `args`, within a minute (its output goes to files
/// beside `profile`: a pipe that nobody reads would stall it).
fn browse(browser: &Path, url: &str, args: &[&str], profile: &Path) -> Browsed {
    let out_path = profile.with_extension("stdout");
    let err_path = profile.with_extension("stderr");
    let mut child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--enable-unsafe-swiftshader",
            "--use-angle=swiftshader",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=5000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .arg(url)
        .stdout(std::fs::File::create(&out_path).unwrap())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .stdin(Stdio::null())
        .spawn()
        .expect("chromium starts");
    let deadline = Instant::now() + Duration::from_secs(60);
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("chromium did not finish within a minute on {url}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let stderr = std::fs::read_to_string(&err_path).unwrap();
    Browsed {
        stdout: std::fs::read_to_string(&out_path).unwrap(),
        console: stderr
            .lines()
            .filter(|l| l.contains(":CONSOLE"))
            .map(str::to_string)
            .collect(),
    }
}

/// The page's `#probe` report.
fn probe(browser: &Path, page: &Path, dir: &Path) -> serde_json::Value {
    let url = format!("file://{}#probe", page.display());
    let b = browse(browser, &url, &["--dump-dom"], &dir.join("profile"));
    assert!(b.console.is_empty(), "console: {:#?}", b.console);
    let start = b
        .stdout
        .find("<pre id=\"hamel-probe\">")
        .expect("the probe")
        + 22;
    let end = start + b.stdout[start..].find("</pre>").unwrap();
    let text = b.stdout[start..end]
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&amp;", "&");
    serde_json::from_str(&text).expect("the probe is JSON")
}

/// The fraction of the screenshot's left half (the 3D view) that differs from the page's
/// background.
fn drawn_fraction(png: &Path) -> f64 {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(png).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let (w, h) = (info.width as usize, info.height as usize);
    let background = [244, 244, 242];
    let (mut drawn, mut all) = (0usize, 0usize);
    for y in h / 10..h * 8 / 10 {
        for x in 0..w / 2 {
            let p = &buf[(y * w + x) * channels..][..3];
            all += 1;
            if p.iter().zip(background).any(|(a, b)| a.abs_diff(b) > 12) {
                drawn += 1;
            }
        }
    }
    drawn as f64 / all as f64
}

/// `scene` with every coordinate of `coordinates` requested and its model path absolute.
fn requesting_everything(scene: &str, coordinates: &[String], dir: &Path) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join(scene)).unwrap();
    let models = root.join("models");
    let names: Vec<String> = coordinates.iter().map(|c| format!("\"{c}\"")).collect();
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("request") {
                format!("request = [{}]", names.join(", "))
            } else {
                l.replace("../models", models.to_str().unwrap())
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let path = dir.join("everything.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn unit(r: &serde_json::Value) -> UnitQuaternion<f64> {
    let c: Vec<f64> = (0..4).map(|i| r[i].as_f64().unwrap()).collect();
    UnitQuaternion::from_quaternion(Quaternion::new(c[0], c[1], c[2], c[3]))
}

/// The largest difference between the page's pose and `want` (position, and rotation as the
/// angle between them).
fn difference(got: &serde_json::Value, want: &Pose) -> f64 {
    let p = &got["position"];
    let dp = (0..3)
        .map(|i| (p[i].as_f64().unwrap() - want.position[i]).abs())
        .fold(0.0, f64::max);
    let w = want.rotation;
    let want_q = UnitQuaternion::from_quaternion(Quaternion::new(w[0], w[1], w[2], w[3]));
    dp.max(unit(&got["rotation"]).angle_to(&want_q))
}

/// Simulate `scene` with `--animate`, open the page, and check it against the simulation.
fn page_equals_the_simulation(scene: &str, name: &str) {
    let Some(browser) = chromium() else { return };
    let dir = scratch(&format!("animate_{name}"));
    let page = dir.join(format!("{name}.html"));
    let o = hamel(
        &["simulate", scene, "--animate", page.to_str().unwrap()],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let size = std::fs::metadata(&page).unwrap().len();
    assert!(size < 2_000_000, "{size} bytes");

    // The simulation's configurations, every coordinate requested.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model_file = std::fs::read_to_string(root.join(scene)).unwrap();
    let model_path = model_file
        .lines()
        .find_map(|l| l.strip_prefix("model = \""))
        .map(|m| root.join("scenes").join(m.trim_end_matches('"')))
        .unwrap();
    let model = hamel_model::Model::load(&model_path).unwrap();
    let m = model.mechanism.as_ref().expect("a model of bodies");
    let everything = requesting_everything(scene, &m.coordinates, &dir);
    let report = dir.join("everything.json");
    let args = [
        "simulate",
        everything.to_str().unwrap(),
        "--format",
        "json",
        "--output",
        report.to_str().unwrap(),
    ];
    let o = hamel(&args, None);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let columns: Vec<Vec<f64>> = m.coordinates.iter().map(|c| series(&report, c)).collect();
    let q_at = |i: usize| -> Vec<f64> { columns.iter().map(|c| c[i]).collect() };

    let p = probe(&browser, &page, &dir);
    assert_eq!(p["errors"], serde_json::json!([]), "{}", p["errors"]);
    assert_eq!(p["webgl"], true);
    let frames: Vec<String> = serde_json::from_value(p["frames"].clone()).unwrap();
    for b in &m.bodies {
        assert_eq!(p["bodies"][&b.name], b.frame.as_str(), "body {}", b.name);
    }
    let times = p["times"].as_array().unwrap();
    let outputs = columns[0].len();
    assert_eq!(times.len(), 2 * outputs - 1);
    let mut worst: f64 = 0.0;
    for (j, pose) in p["poses"].as_array().unwrap().iter().enumerate() {
        let (i, between_outputs) = (j / 2, j % 2 == 1);
        let here = poses(m, &q_at(i), &model.parameters).unwrap();
        let next = between_outputs.then(|| poses(m, &q_at(i + 1), &model.parameters).unwrap());
        for f in &frames {
            let want = match &next {
                None => here[f],
                Some(next) => between(&here[f], &next[f], 0.25),
            };
            worst = worst.max(difference(&pose[f], &want));
        }
    }
    assert!(worst < 1e-9, "{name}: the page's poses differ by {worst:e}");

    // A render that is not blank, and a silent console.
    let shot = dir.join(format!("{name}.png"));
    let url = format!("file://{}#t=0.3", page.display());
    let screenshot = format!("--screenshot={}", shot.display());
    let args = [screenshot.as_str(), "--window-size=1000,700"];
    let b = browse(&browser, &url, &args, &dir.join("profile"));
    assert!(b.console.is_empty(), "console: {:#?}", b.console);
    let drawn = drawn_fraction(&shot);
    assert!(
        drawn > 0.02,
        "{name}: only {drawn:.4} of the 3D view is drawn"
    );
}

/// A fraction `w` of the way between two poses: positions linearly, rotations by slerp.
fn between(a: &Pose, b: &Pose, w: f64) -> Pose {
    let q = |r: [f64; 4]| UnitQuaternion::from_quaternion(Quaternion::new(r[0], r[1], r[2], r[3]));
    let s = q(a.rotation).try_slerp(&q(b.rotation), w, 1e-12).unwrap();
    Pose {
        position: [0, 1, 2].map(|i| a.position[i] + w * (b.position[i] - a.position[i])),
        rotation: [s.w, s.i, s.j, s.k],
    }
}

#[test]
fn animate_the_bicycle_s_page_shows_the_simulation_s_poses() {
    page_equals_the_simulation("scenes/whipple_bicycle.toml", "bicycle");
}

#[test]
fn animate_the_segway_s_page_shows_the_simulation_s_poses() {
    page_equals_the_simulation("scenes/segway.toml", "segway");
}

/// A model typed by hand has nothing to draw: the page says so in place of the 3D view and
/// still plots the outputs; the browser shows it without an error.
#[test]
fn animate_a_model_without_bodies_plots_its_outputs_and_says_why() {
    let dir = scratch("animate_knife");
    let page = dir.join("knife.html");
    let o = hamel(
        &[
            "simulate",
            "scenes/knife.toml",
            "--animate",
            page.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("has no bodies, frames or wheels to draw"));
    let Some(browser) = chromium() else { return };
    let p = probe(&browser, &page, &dir);
    assert_eq!(p["errors"], serde_json::json!([]));
    assert_eq!(p["webgl"], false);
    assert_eq!(p["frames"], serde_json::json!([]));
    let plots: Vec<String> = serde_json::from_value(p["plots"].clone()).unwrap();
    assert!(plots.contains(&"theta".to_string()), "{plots:?}");
}

/// A page that cannot be written is refused before any work, naming the file and the
/// reason, and nothing is written (neither the page nor the trajectory).
#[test]
fn animate_refuses_a_page_it_cannot_write_before_simulating() {
    let dir = scratch("animate_refused");
    let csv = dir.join("out.csv");
    for (page, reason) in [
        (dir.join("missing/page.html"), "cannot write the page here"),
        (dir.join("page.txt"), "must end in .html"),
    ] {
        let args = [
            "simulate",
            "scenes/segway.toml",
            "--output",
            csv.to_str().unwrap(),
            "--animate",
            page.to_str().unwrap(),
        ];
        let o = hamel(&args, None);
        assert!(!o.status.success());
        let e = stderr(&o);
        assert!(
            e.contains(page.to_str().unwrap()) && e.contains(reason),
            "{e}"
        );
        assert!(!e.contains("dop853"), "it simulated: {e}");
        assert!(!page.exists() && !csv.exists());
    }
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(left.is_empty(), "{left:?}");
}

/// An ensemble's page shows the chosen members, labelled with their own values, each where
/// its run ended: the disk's centre at height R cos θ, θ the member's final tilt in the
/// ensemble's own result.
#[test]
fn animate_an_ensemble_shows_the_chosen_members() {
    let dir = scratch("animate_ensemble");
    let page = dir.join("disks.html");
    let csv = dir.join("disks.csv");
    let args = [
        "simulate",
        "scenes/rolling_disks.toml",
        "--output",
        csv.to_str().unwrap(),
        "--animate",
        page.to_str().unwrap(),
        "--animate-members",
        "0,2,4",
    ];
    let o = hamel(&args, None);
    assert!(o.status.success(), "{}", stderr(&o));
    // The final tilt of each member, from the ensemble's CSV (member, t, …, theta, …).
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (member, theta) = (col("member"), col("theta"));
    let mut last = std::collections::BTreeMap::new();
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        let m: usize = f[member].parse().unwrap();
        last.insert(m, f[theta].parse::<f64>().unwrap());
    }
    let Some(browser) = chromium() else { return };
    let p = probe(&browser, &page, &dir);
    assert_eq!(p["errors"], serde_json::json!([]));
    let shown = p["members"].as_array().unwrap();
    assert_eq!(shown.len(), 3);
    for (s, index) in shown.iter().zip([0usize, 2, 4]) {
        let label = s["label"].as_str().unwrap();
        assert!(
            label.starts_with(&format!("member {index} (theta = ")),
            "{label}"
        );
        let z = s["last"]["disk"]["position"][2].as_f64().unwrap();
        let want = 0.15 * last[&index].cos();
        assert!((z - want).abs() < 1e-9, "member {index}: {z} vs {want}");
    }
}
