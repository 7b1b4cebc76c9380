//! `evals MODE N`: N evaluations of the Whipple bicycle's generated core at the bundled scene's
//! kind of state (lean 0.05, steer 0.02, 5 m/s), for timing one version of the core against
//! another with farm-bench (docs/models/whipple_bicycle.md, "What the smaller code costs"):
//!
//!     git archive REV generated/whipple_bicycle__benchmark | tar -x -C /tmp/old
//!     cp bench/bicycle_core_evals.rs /tmp/old/generated/whipple_bicycle__benchmark/src/bin/evals.rs
//!     (cd /tmp/old/generated/whipple_bicycle__benchmark && cargo build --release --offline --bin evals)
//!     # the same for the core now, then
//!     farm-bench -n 7 --vs 'OLD/target/release/evals full 20000' -- NEW/target/release/evals full 20000
//!
//! MODE: `full` = `full_into` (f64, repeated in double-double where its error estimate asks),
//! `f64` = `structured_unchecked::<f64>` (the f64 pass alone), `jacobian` = `reduced_jacobian`.
//! Prints a sum of the results, so that nothing is optimised away.
use hamel_generated::{Parameters, full_into, reduced_jacobian, structured_unchecked};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let n: usize = a[2].parse().unwrap();
    let p = Parameters::default();
    let mut y = [
        0.0f64,
        0.0,
        0.0,
        0.05,
        0.0,
        0.02,
        0.0,
        0.0,
        0.1,
        -0.1,
        -16.666666666666668,
    ];
    let mut dy = [0.0; 11];
    let mut acc = 0.0;
    for i in 0..n {
        y[3] = 0.05 + 1e-12 * i as f64;
        match a[1].as_str() {
            "full" => {
                full_into(&y, &mut dy, &p).unwrap();
                acc += dy[8];
            }
            "f64" => {
                acc += structured_unchecked::<f64>(&y[..8], &y[8..], &p, false)
                    .unwrap()
                    .eta_dot[0];
            }
            _ => {
                let x = [y[3], y[4], y[5], y[8], y[9], y[10]];
                acc += reduced_jacobian(&x, &p).unwrap()[0][0];
            }
        }
    }
    println!("{acc:e}");
}
