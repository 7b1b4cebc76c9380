//! What the benches of the generated cores share.

/// A deterministic sequence in [-1, 1) (a linear congruential one: no dependency needed).
pub fn uniform() -> impl FnMut() -> f64 {
    let mut s: u64 = 0x2545_f491_4f6c_dd1d;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// Criterion's point estimate of the mean, in seconds, for a benchmark of this run.
pub fn estimate(id: &str) -> Option<f64> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/criterion");
    let text = std::fs::read_to_string(dir.join(id).join("new/estimates.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    Some(v["mean"]["point_estimate"].as_f64()? * 1e-9)
}
