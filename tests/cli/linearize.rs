//! `hamel linearize`: sweeps, maps, figures, and nothing written on errors.

#[allow(unused_imports)]
use super::*;

/// `hamel linearize`: the bicycle's sweep as JSON in the shape (points with their
/// eigenvalues, crossings with their kinds, the matrices), its figure, and a small map; errors
/// (an unknown steady motion, a plot without a sweep, an unknown swept name) exit 1 and write
/// nothing.
#[test]
fn linearize_writes_sweeps_maps_and_figures_and_nothing_on_errors() {
    let dir = scratch("linearize");
    let (json, svg) = (dir.join("sweep.json"), dir.join("fig.svg"));
    let model = "models/whipple_bicycle.toml";
    let args = [
        "linearize",
        model,
        "--steady",
        "upright",
        "--sweep",
        "v=0:10:21",
    ];
    let more = [
        "--format",
        "json",
        "--output",
        json.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ];
    let o = hamel(&[&args[..], &more[..]].concat(), None);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["parameter"], "v");
    let points = v["points"].as_array().unwrap();
    assert_eq!(points.len(), 21);
    assert!(
        points
            .iter()
            .all(|p| p["eigenvalues"].as_array().unwrap().len() == 4),
        "{v}"
    );
    let kinds: Vec<&str> = v["crossings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["hopf", "real_zero"]);
    let weave = v["crossings"][0]["value"].as_f64().unwrap();
    assert!((weave - 4.29238253634111).abs() < 1e-10, "{weave}");
    assert!(
        v["matrices"]["m"].is_array() && v["matrices"]["gravity"]["parameter"] == "g",
        "{v}"
    );
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));

    let map = dir.join("map.json");
    let o = hamel(
        &[
            "linearize",
            model,
            "--steady",
            "upright",
            "--sweep",
            "v=3:7:5",
            "--sweep",
            "c=0.04:0.12:3",
            "--format",
            "json",
            "--output",
            map.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&map).unwrap()).unwrap();
    let rows = m["values"].as_array().unwrap();
    assert_eq!((rows.len(), rows[0].as_array().unwrap().len()), (3, 5));
    assert_eq!(
        m["stability"][1][2], "asymptotic",
        "the benchmark (c = 0.08) at 5 m/s: {m}"
    );

    let out = dir.join("bad.json");
    for (bad, want) in [
        (
            vec!["--steady", "rolling"],
            "no steady motion named `rolling`",
        ),
        (
            vec!["--steady", "upright", "--plot", "x.svg"],
            "--plot draws a sweep or a map",
        ),
        (
            vec!["--steady", "upright", "--sweep", "speed=0:1:3"],
            "`speed` is neither a parameter",
        ),
        (
            vec!["--steady", "upright", "--sweep", "d1=0:1:3"],
            "derived parameter",
        ),
    ] {
        let o = hamel(
            &[
                &["linearize", model, "--output", out.to_str().unwrap()][..],
                &bad[..],
            ]
            .concat(),
            None,
        );
        assert_eq!(o.status.code(), Some(1), "{bad:?}");
        assert!(stderr(&o).contains(want), "{bad:?}: {}", stderr(&o));
        assert!(
            !out.exists() && !Path::new("x.svg").exists(),
            "{bad:?} wrote something"
        );
    }
}
