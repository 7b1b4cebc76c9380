//! `hamel search`: candidates, progress, and a budget that is a wall.

#[allow(unused_imports)]
use super::*;

#[test]
fn search_writes_json_candidates_and_reports_progress() {
    let dir = scratch("search_json");
    let file = dir.join("knife.json");
    let o = hamel(
        &[
            "search",
            "models/knife.toml",
            "--eliminate",
            "x,y,theta",
            "--format",
            "json",
            "--progress",
            "always",
            "--output",
            file.to_str().unwrap(),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // Plain progress lines on a non-terminal stderr, ending with a summary.
    assert!(stderr(&o).contains("search: done,"), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let candidates = v["candidates"].as_array().unwrap();
    assert!(!candidates.is_empty());
    for c in candidates {
        assert!(c["name"].is_string());
        assert_eq!(c["eliminated"], serde_json::json!(["x", "y", "theta"]));
        assert!(c["free_functions"].is_array());
        let eta = c["eta"].as_array().unwrap();
        assert_eq!(eta.len(), 2);
        assert!(eta.iter().all(|e| e.as_str().unwrap().contains("der(")));
        // The TOML block is ready to paste: it parses and names the same rows.
        let t: toml::Value = toml::from_str(c["toml"].as_str().unwrap()).unwrap();
        let name = c["name"].as_str().unwrap();
        assert_eq!(
            t["quasi_velocities"][name]["eta"].as_array().unwrap().len(),
            2
        );
    }
    // The knife's z11 = cos θ, z12 = sin θ is among them.
    assert!(candidates.iter().any(|c| {
        c["eta"]
            .as_array()
            .unwrap()
            .iter()
            .any(|e| e == "cos(theta)*der(x) + sin(theta)*der(y)")
    }));
    assert_eq!(v["stop"]["reason"], "completed");
}

#[test]
fn search_honours_its_budget_and_rejects_a_bad_one() {
    let dir = scratch("search_budget");
    let file = dir.join("out.json");
    let args = |budget: &'static str| {
        vec![
            "search",
            "models/unicycle_rider.toml",
            "--eliminate",
            "xC,yC,phi,psi",
            "--format",
            "json",
            budget,
        ]
    };
    let mut a = args("--budget=0.05");
    a.extend(["--output", file.to_str().unwrap()]);
    let o = hamel(&a, None);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let reason = v["stop"]["reason"].as_str().unwrap();
    assert!(
        reason == "budget" || reason == "budget_during_check",
        "{reason}"
    );
    // Far fewer candidates generated than the full search (which generates over a hundred).
    let generated: u64 = v["families"]
        .as_object()
        .unwrap()
        .values()
        .map(|f| f["generated"].as_u64().unwrap())
        .sum();
    assert!(generated < 50, "{generated}");

    let _ = std::fs::remove_file(&file);
    let mut a = args("--budget=-1");
    a.extend(["--output", file.to_str().unwrap()]);
    let o = hamel(&a, None);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("--budget must be a positive number"),
        "{}",
        stderr(&o)
    );
    assert!(!file.exists(), "no partial output");
}

#[test]
fn search_budget_is_a_wall_even_during_an_exact_check() {
    // The snakeboard eliminating x, y, θ, ψ: the ansatz finds its candidates in about a second,
    // then the exact check of the family with unknown functions takes minutes.
    let dir = scratch("search_wall");
    let file = dir.join("out.json");
    let budget = 5.0;
    let (o, took) = hamel_timed(&[
        "search",
        "models/snakeboard.toml",
        "--eliminate",
        "x,y,theta,psi",
        "--budget",
        "5",
        "--format",
        "json",
        "--output",
        file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The whole command, set-up and the abandoned check included, within the budget + 2 s.
    assert!(
        took.as_secs_f64() < budget + 2.0,
        "took {:.2} s with a budget of {budget} s",
        took.as_secs_f64()
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let stop = &v["stop"];
    assert!(
        stop["reason"] == "budget_during_check" || stop["reason"] == "budget",
        "{stop}"
    );
    if stop["reason"] == "budget_during_check" {
        assert!(!stop["eta"].as_array().unwrap().is_empty(), "{stop}");
    }
    // What was found before the deadline is reported, each a pasteable choice.
    let candidates = v["candidates"].as_array().unwrap();
    assert!(!candidates.is_empty());
    for c in candidates {
        assert_eq!(
            c["eliminated"],
            serde_json::json!(["x", "y", "theta", "psi"])
        );
        let t: toml::Table = c["toml"].as_str().unwrap().parse().unwrap();
        assert!(
            t["quasi_velocities"]
                .as_table()
                .unwrap()
                .contains_key(c["name"].as_str().unwrap())
        );
    }
    // Symbolica's notice is passed through, and the next command runs (the worker's
    // Symbolica instance ended with it).
    let o = hamel(&["derive", "models/knife.toml", "--format", "json"], None);
    assert!(o.status.success(), "{}", stderr(&o));
}
