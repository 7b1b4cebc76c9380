//! The reversible discrete Lagrange–d'Alembert integrator (`hamel_sim::dla`) on the systems
//! of McLachlan & Perlmutter (2006):
//! * the contact oscillator, q = (x, y, z), ẋ + y ż = 0, H = ½(|v|² + |q|² + ε x²z²), step
//!   2 sin(π/40), energy 1.5 with H_y = ½(ẏ² + y²) = 0.5, ε = 0 and 0.1: over 10⁶ steps the
//!   energy error stays bounded with no trend, H_y and H − H_y bounded; the left-point
//!   variant (not reversible) loses the x–z motion's energy within 2·10⁴ steps;
//! * the Chaplygin sleigh, whose asymptotic speed and heading have closed forms: the errors
//!   fall as h².

use hamel_sim::dla::{Dla, Nonholonomic, Variant, energy};
use nalgebra::DMatrix;

struct ContactOscillator {
    epsilon: f64,
}

impl Nonholonomic for ContactOscillator {
    fn dim(&self) -> usize {
        3
    }
    fn constraints(&self) -> usize {
        1
    }
    fn mass(&self, _q: &[f64], m: &mut DMatrix<f64>) {
        m.fill_with_identity();
    }
    fn force(&self, q: &[f64], _v: &[f64], f: &mut [f64]) {
        let (x, z) = (q[0], q[2]);
        f[0] = -x - self.epsilon * x * z * z;
        f[1] = -q[1];
        f[2] = -z - self.epsilon * x * x * z;
    }
    fn constraint_matrix(&self, q: &[f64], a: &mut DMatrix<f64>) {
        a[(0, 0)] = 1.0;
        a[(0, 1)] = 0.0;
        a[(0, 2)] = q[1];
    }
    fn potential(&self, q: &[f64]) -> f64 {
        let (x, y, z) = (q[0], q[1], q[2]);
        0.5 * (x * x + y * y + z * z + self.epsilon * x * x * z * z)
    }
}

/// What a long run shows: the energy error's spread and trend over the last 90 %, and the
/// largest deviations of H_y and H − H_y in the first and the last tenth.
struct LongRun {
    /// E − E₀ at the end.
    end: f64,
    spread: f64,
    trend: f64,
    h_y: [f64; 2],
    rest: [f64; 2],
    constraint: f64,
}

fn long_run(epsilon: f64, variant: Variant, steps: usize) -> LongRun {
    let system = ContactOscillator { epsilon };
    let h = 2.0 * (std::f64::consts::PI / 40.0).sin();
    let mut dla = Dla::new(&system, h, variant);
    // y = 1, ẏ = 0 (H_y = 0.5); x = z = 0, ż = 1, ẋ = −y ż = −1 (H = 1.5).
    let (mut q, mut v) = ([0.0, 1.0, 0.0], [-1.0, 0.0, 1.0]);
    let e0 = energy(&system, &q, &v);
    assert!((e0 - 1.5).abs() < 1e-15);
    let h_y = |q: &[f64; 3], v: &[f64; 3]| 0.5 * (v[1] * v[1] + q[1] * q[1]);
    let hy0 = h_y(&q, &v);
    let (mut samples, mut hy, mut rest) = (Vec::new(), Vec::new(), Vec::new());
    let mut constraint: f64 = 0.0;
    for k in 1..=steps {
        dla.step(&mut q, &mut v)
            .unwrap_or_else(|e| panic!("step {k}: {e}"));
        if k % 10 == 0 {
            let e = energy(&system, &q, &v);
            samples.push((k as f64 * h, e - e0));
            hy.push(h_y(&q, &v) - hy0);
            rest.push(e - h_y(&q, &v) - (e0 - hy0));
            constraint = constraint.max((v[0] + q[1] * v[2]).abs());
        }
    }
    let tail = &samples[samples.len() / 10..];
    let (spread, trend) = fit(tail);
    let tenth = hy.len() / 10;
    let most = |x: &[f64]| x.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    LongRun {
        end: samples.last().unwrap().1,
        spread,
        trend,
        h_y: [most(&hy[..tenth]), most(&hy[hy.len() - tenth..])],
        rest: [most(&rest[..tenth]), most(&rest[rest.len() - tenth..])],
        constraint,
    }
}

/// (max − min, |slope| × duration) of a least-squares line through `points`.
fn fit(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let (mt, me) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (t, e)| (a + t / n, b + e / n));
    let (mut stt, mut ste) = (0.0, 0.0);
    for (t, e) in points {
        stt += (t - mt) * (t - mt);
        ste += (t - mt) * (e - me);
    }
    let slope = ste / stt;
    let duration = points.last().unwrap().0 - points[0].0;
    let (lo, hi) = points.iter().fold((f64::MAX, f64::MIN), |(l, h), (_, e)| {
        (l.min(*e), h.max(*e))
    });
    (hi - lo, (slope * duration).abs())
}

#[test]
fn the_contact_oscillator_keeps_its_energy_bounded_over_a_million_steps() {
    for epsilon in [0.0, 0.1] {
        let r = long_run(epsilon, Variant::Reversible, 1_000_000);
        eprintln!(
            "reversible, ε = {epsilon}: energy error spread {:.2e}, trend over the last 90 % {:.2e}; |ΔH_y| {:.2e} (first tenth) {:.2e} (last); |Δ(H − H_y)| {:.2e} {:.2e}; |ẋ + y ż| ≤ {:.1e}",
            r.spread, r.trend, r.h_y[0], r.h_y[1], r.rest[0], r.rest[1], r.constraint
        );
        assert!(r.trend < r.spread, "ε = {epsilon}: the energy drifts");
        assert!(r.spread < 1e-2, "ε = {epsilon}: {}", r.spread);
        assert!(
            r.h_y[1] < 2.0 * r.h_y[0] + 1e-12 && r.h_y[1] < 0.05,
            "H_y grows"
        );
        assert!(
            r.rest[1] < 2.0 * r.rest[0] + 1e-12 && r.rest[1] < 0.05,
            "H − H_y grows"
        );
        assert!(r.constraint < 1e-13, "{}", r.constraint);
    }
}

#[test]
fn the_left_point_variant_drifts() {
    for epsilon in [0.0, 0.1] {
        let r = long_run(epsilon, Variant::LeftPoint, 20_000);
        eprintln!(
            "left point, ε = {epsilon}: E − E₀ at the end {:.3e}; |ΔH_y| {:.2e} {:.2e}; |Δ(H − H_y)| {:.2e} {:.2e}",
            r.end, r.h_y[0], r.h_y[1], r.rest[0], r.rest[1]
        );
        assert!(r.end < -0.5, "ε = {epsilon}: E − E₀ = {}", r.end);
    }
}

/// The Chaplygin sleigh (m, I about the centre of mass, the knife a behind it): q = (x, y, θ),
/// M(q) as in models/chaplygin_sleigh.toml, no potential, ẋ sin θ − ẏ cos θ = 0.
struct Sleigh {
    m: f64,
    i: f64,
    a: f64,
}

impl Nonholonomic for Sleigh {
    fn dim(&self) -> usize {
        3
    }
    fn constraints(&self) -> usize {
        1
    }
    fn mass(&self, q: &[f64], m: &mut DMatrix<f64>) {
        let (s, c) = q[2].sin_cos();
        let ma = self.m * self.a;
        *m = DMatrix::from_row_slice(
            3,
            3,
            &[
                self.m,
                0.0,
                -ma * s, //
                0.0,
                self.m,
                ma * c, //
                -ma * s,
                ma * c,
                self.i + ma * self.a,
            ],
        );
    }
    fn force(&self, q: &[f64], v: &[f64], f: &mut [f64]) {
        let (s, c) = q[2].sin_cos();
        f[0] = 0.0;
        f[1] = 0.0;
        f[2] = -self.m * self.a * v[2] * (v[0] * c + v[1] * s);
    }
    fn constraint_matrix(&self, q: &[f64], a: &mut DMatrix<f64>) {
        let (s, c) = q[2].sin_cos();
        a[(0, 0)] = s;
        a[(0, 1)] = -c;
        a[(0, 2)] = 0.0;
    }
    fn potential(&self, _q: &[f64]) -> f64 {
        0.0
    }
}

/// m v̇ = m a ω², (I + m a²) ω̇ = −m a v ω: with k = m a/(I + m a²), V² = 2E/m and
/// c₀ = atanh(v₀/V), v = V tanh(kVt + c₀) and θ = ω₀ cosh c₀/(kV) (gd(kVt + c₀) − gd c₀),
/// gd u = 2 atan(tanh(u/2)).
fn sleigh_closed_form(s: &Sleigh, v0: f64, w0: f64, t: f64) -> (f64, f64) {
    let k = s.m * s.a / (s.i + s.m * s.a * s.a);
    let e = 0.5 * s.m * v0 * v0 + 0.5 * (s.i + s.m * s.a * s.a) * w0 * w0;
    let big_v = (2.0 * e / s.m).sqrt();
    let c0 = (v0 / big_v).atanh();
    let gd = |u: f64| 2.0 * (0.5 * u).tanh().atan();
    let u = k * big_v * t + c0;
    (
        big_v * u.tanh(),
        w0 * c0.cosh() / (k * big_v) * (gd(u) - gd(c0)),
    )
}

#[test]
fn the_chaplygin_sleighs_asymptotic_speed_and_heading_converge_as_h_squared() {
    let sleigh = Sleigh {
        m: 1.0,
        i: 0.5,
        a: 0.5,
    };
    let (v0, w0, t_end) = (1.0, 1.0, 20.0);
    let (v_exact, theta_exact) = sleigh_closed_form(&sleigh, v0, w0, t_end);
    let mut errors = Vec::new();
    for steps in [200, 400, 800, 1600] {
        let h = t_end / steps as f64;
        let mut dla = Dla::new(&sleigh, h, Variant::Reversible);
        let (mut q, mut v) = ([0.0, 0.0, 0.0], [v0, 0.0, w0]);
        let e0 = energy(&sleigh, &q, &v);
        let mut constraint: f64 = 0.0;
        for _ in 0..steps {
            dla.step(&mut q, &mut v).unwrap();
            constraint = constraint.max((v[0] * q[2].sin() - v[1] * q[2].cos()).abs());
        }
        let speed = v[0] * q[2].cos() + v[1] * q[2].sin();
        let e = energy(&sleigh, &q, &v);
        let err = ((speed - v_exact).abs(), (q[2] - theta_exact).abs());
        eprintln!(
            "sleigh, h = {h:.4}: speed {speed:.10} (exact {v_exact:.10}), heading {:.10} (exact {theta_exact:.10}), errors {:.2e} {:.2e}, energy error {:.1e}, constraint {constraint:.1e}",
            q[2],
            err.0,
            err.1,
            (e - e0).abs()
        );
        assert!(constraint < 1e-14);
        errors.push(err);
    }
    for pair in errors.windows(2) {
        let (speed, heading) = (pair[0].0 / pair[1].0, pair[0].1 / pair[1].1);
        eprintln!("halving h divides the errors by {speed:.3} (speed), {heading:.3} (heading)");
        assert!((3.5..4.5).contains(&heading), "heading: {heading}");
        assert!((3.5..4.5).contains(&speed), "speed: {speed}");
    }
}

/// `dla::integrate`: outputs on the step grid are full steps (the same states as stepping by
/// hand, to the bit), an output off the grid shortens the step before it, an output before
/// the time reached and too many steps are errors carrying the outputs reached.
#[test]
fn a_run_steps_onto_its_outputs() {
    let sleigh = Sleigh {
        m: 1.0,
        i: 0.5,
        a: 0.5,
    };
    let (q0, v0) = ([0.0, 0.0, 0.0], [1.0, 0.0, 1.0]);
    let h = 0.05;
    let run = hamel_sim::dla::integrate(
        &sleigh,
        (h, Variant::Reversible),
        (0.0, &q0, &v0),
        &[0.0, 0.5, 1.0, 1.02],
        1000,
    )
    .unwrap();
    assert_eq!(run.steps, 21);
    assert_eq!(run.q[0], q0);
    let (mut q, mut v) = (q0, v0);
    let mut dla = Dla::new(&sleigh, h, Variant::Reversible);
    for k in 1..=20 {
        dla.step(&mut q, &mut v).unwrap();
        if k == 10 {
            assert_eq!(run.q[1], q);
        }
    }
    assert_eq!((&run.q[2], &run.v[2]), (&q[..], &v[..]));
    dla.set_step(0.02);
    dla.step(&mut q, &mut v).unwrap();
    assert!((run.q[3].iter().zip(&q)).all(|(a, b)| (a - b).abs() < 1e-15));

    let back = hamel_sim::dla::integrate(
        &sleigh,
        (h, Variant::Reversible),
        (0.0, &q0, &v0),
        &[0.5, 0.25],
        1000,
    )
    .unwrap_err();
    assert!(matches!(
        back.error,
        hamel_sim::dla::DlaError::OutputOrder(_)
    ));
    assert_eq!(back.partial.t, [0.5]);
    let many = hamel_sim::dla::integrate(
        &sleigh,
        (h, Variant::Reversible),
        (0.0, &q0, &v0),
        &[0.5, 1.0],
        15,
    )
    .unwrap_err();
    assert!(many.to_string().contains("max_steps = 15"), "{many}");
    assert_eq!(many.partial.t, [0.5]);
}

/// The sleigh, saying that it does not depend on x and y and depends on θ with period 2π.
struct Classified(Sleigh);

impl Nonholonomic for Classified {
    fn dim(&self) -> usize {
        3
    }
    fn constraints(&self) -> usize {
        1
    }
    fn mass(&self, q: &[f64], m: &mut DMatrix<f64>) {
        self.0.mass(q, m)
    }
    fn force(&self, q: &[f64], v: &[f64], f: &mut [f64]) {
        self.0.force(q, v, f)
    }
    fn constraint_matrix(&self, q: &[f64], a: &mut DMatrix<f64>) {
        self.0.constraint_matrix(q, a)
    }
    fn potential(&self, q: &[f64]) -> f64 {
        self.0.potential(q)
    }
    fn coordinate(&self, k: usize) -> hamel_sim::dla::Coordinate {
        use hamel_sim::dla::Coordinate;
        [
            Coordinate::Absent,
            Coordinate::Absent,
            Coordinate::Periodic(2.0 * std::f64::consts::PI),
        ][k]
    }
}

/// Far from the origin (x, y = ±10⁹ m, θ a million turns on), a run keeps every digit of its
/// steps: the coordinates the sleigh does not depend on are moved back to zero before each
/// step and θ within π of it (`dla::Positions`), so the motion relative to the start is the
/// one from the origin, to round-off of the offsets; without that, the steps' increments of
/// x and y (about 0.01 m on an ulp of 1.2e-7 m) would keep five digits.
#[test]
fn a_run_far_from_the_origin_keeps_its_digits() {
    let sleigh = Classified(Sleigh {
        m: 1.0,
        i: 0.5,
        a: 0.5,
    });
    let turns = 2e6 * std::f64::consts::PI;
    let run = |q0: [f64; 3]| {
        hamel_sim::dla::integrate(
            &sleigh,
            (0.01, Variant::Reversible),
            (0.0, &q0, &[0.8 * 0.3f64.cos(), 0.8 * 0.3f64.sin(), 1.0]),
            &[5.0],
            10_000,
        )
        .unwrap()
    };
    let (near, far) = (run([0.0, 0.0, 0.3]), run([1e9, -1e9, turns + 0.3]));
    let moved = [far.q[0][0] - 1e9, far.q[0][1] + 1e9, far.q[0][2] - turns];
    let speeds = |v: &[f64], w: &[f64]| (0..3).map(|k| (v[k] - w[k]).abs()).fold(0.0, f64::max);
    for k in 0..3 {
        // the offsets' own rounding: an ulp of 1e9 is 1.2e-7
        assert!(
            (moved[k] - near.q[0][k]).abs() < 1e-6,
            "{k}: {moved:?} {:?}",
            &near.q[0]
        );
    }
    // θ₀ itself is 0.3 to an ulp of 6e6 (9e-10): the velocities follow to a few of those
    let kept = speeds(&far.v[0], &near.v[0]);
    assert!(kept < 1e-8, "{kept:e}");
    // the same run stepping with the coordinates as they are loses digits at every step
    let plain = hamel_sim::dla::integrate(
        &sleigh.0,
        (0.01, Variant::Reversible),
        (
            0.0,
            &[1e9, -1e9, turns + 0.3],
            &[0.8 * 0.3f64.cos(), 0.8 * 0.3f64.sin(), 1.0],
        ),
        &[5.0],
        10_000,
    )
    .unwrap();
    let lost = speeds(&plain.v[0], &near.v[0]);
    eprintln!(
        "velocities at t = 5 far from the origin: {kept:.1e} off, {lost:.1e} without recentring"
    );
    assert!(lost > 100.0 * kept, "{lost:e} against {kept:e}");
}
