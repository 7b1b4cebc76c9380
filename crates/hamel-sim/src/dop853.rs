//! DOP853: Dormand–Prince 8(5,3) with its seventh-order continuous extension.
//!
//! Tableau, error estimators and dense-output coefficients: P. J. Prince and J. R. Dormand,
//! "High order embedded Runge–Kutta formulae", J. Comput. Appl. Math. 7 (1981); Hairer,
//! Nørsett & Wanner, "Solving ODEs I", §II.5 and §II.6, with the coefficients exactly as in
//! Hairer's dop853.f (`C2`…`C16`, `A21`…`A1615`, `B1`…`B12`, `BHH1`…`BHH3`, `ER1`…`ER12`,
//! `D41`…`D716`). The error estimate combines the fifth- and third-order embedded solutions
//! as dop853.f does; controller parameters (safety 0.9, 1/3 ≤ h_new/h ≤ 6, β = 0) are its
//! defaults.
#![allow(
    clippy::excessive_precision,
    reason = "coefficients are kept digit for digit as printed in dop853.f"
)]

use crate::control::{Controller, Tolerances};
use crate::explicit::{Stages, Tableau, rows};
use crate::step::{AdaptiveStep, Interpolant};
use crate::system::{Evaluator, OdeSystem, StepFailure};

/// Stages 1–12 of the method, stage 13 = f(t + h, y_new) (first of the next step), and the
/// three extra stages 14–16 of the continuous extension.
const TABLEAU: Tableau = Tableau {
    c: &[
        0.0,
        0.526001519587677318785587544488e-01,
        0.789002279381515978178381316732e-01,
        0.118350341907227396726757197510e+00,
        0.281649658092772603273242802490e+00,
        0.333333333333333333333333333333e+00,
        0.25e+00,
        0.307692307692307692307692307692e+00,
        0.651282051282051282051282051282e+00,
        0.6e+00,
        0.857142857142857142857142857142e+00,
        1.0,
        1.0,
        0.1e+00,
        0.2e+00,
        0.777777777777777777777777777778e+00,
    ],
    a: &[
        &[],
        &[5.26001519587677318785587544488e-2],
        &[
            1.97250569845378994544595329183e-2,
            5.91751709536136983633785987549e-2,
        ],
        &[
            2.95875854768068491816892993775e-2,
            0.0,
            8.87627564304205475450678981324e-2,
        ],
        &[
            2.41365134159266685502369798665e-1,
            0.0,
            -8.84549479328286085344864962717e-1,
            9.24834003261792003115737966543e-1,
        ],
        &[
            3.7037037037037037037037037037e-2,
            0.0,
            0.0,
            1.70828608729473871279604482173e-1,
            1.25467687566822425016691814123e-1,
        ],
        &[
            3.7109375e-2,
            0.0,
            0.0,
            1.70252211019544039314978060272e-1,
            6.02165389804559606850219397283e-2,
            -1.7578125e-2,
        ],
        &[
            3.70920001185047927108779319836e-2,
            0.0,
            0.0,
            1.70383925712239993810214054705e-1,
            1.07262030446373284651809199168e-1,
            -1.53194377486244017527936158236e-2,
            8.27378916381402288758473766002e-3,
        ],
        &[
            6.24110958716075717114429577812e-1,
            0.0,
            0.0,
            -3.36089262944694129406857109825e0,
            -8.68219346841726006818189891453e-1,
            2.75920996994467083049415600797e1,
            2.01540675504778934086186788979e1,
            -4.34898841810699588477366255144e1,
        ],
        &[
            4.77662536438264365890433908527e-1,
            0.0,
            0.0,
            -2.48811461997166764192642586468e0,
            -5.90290826836842996371446475743e-1,
            2.12300514481811942347288949897e1,
            1.52792336328824235832596922938e1,
            -3.32882109689848629194453265587e1,
            -2.03312017085086261358222928593e-2,
        ],
        &[
            -9.3714243008598732571704021658e-1,
            0.0,
            0.0,
            5.18637242884406370830023853209e0,
            1.09143734899672957818500254654e0,
            -8.14978701074692612513997267357e0,
            -1.85200656599969598641566180701e1,
            2.27394870993505042818970056734e1,
            2.49360555267965238987089396762e0,
            -3.0467644718982195003823669022e0,
        ],
        &[
            2.27331014751653820792359768449e0,
            0.0,
            0.0,
            -1.05344954667372501984066689879e1,
            -2.00087205822486249909675718444e0,
            -1.79589318631187989172765950534e1,
            2.79488845294199600508499808837e1,
            -2.85899827713502369474065508674e0,
            -8.87285693353062954433549289258e0,
            1.23605671757943030647266201528e1,
            6.43392746015763530355970484046e-1,
        ],
        // Row 13 holds the eighth-order weights b: stage 13 is f(t + h, y_new).
        &[
            5.42937341165687622380535766363e-2,
            0.0,
            0.0,
            0.0,
            0.0,
            4.45031289275240888144113950566e0,
            1.89151789931450038304281599044e0,
            -5.8012039600105847814672114227e0,
            3.1116436695781989440891606237e-1,
            -1.52160949662516078556178806805e-1,
            2.01365400804030348374776537501e-1,
            4.47106157277725905176885569043e-2,
        ],
        &[
            5.61675022830479523392909219681e-2,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            2.53500210216624811088794765333e-1,
            -2.46239037470802489917441475441e-1,
            -1.24191423263816360469010140626e-1,
            1.5329179827876569731206322685e-1,
            8.20105229563468988491666602057e-3,
            7.56789766054569976138603589584e-3,
            -8.298e-3,
        ],
        &[
            3.18346481635021405060768473261e-2,
            0.0,
            0.0,
            0.0,
            0.0,
            2.83009096723667755288322961402e-2,
            5.35419883074385676223797384372e-2,
            -5.49237485713909884646569340306e-2,
            0.0,
            0.0,
            -1.08347328697249322858509316994e-4,
            3.82571090835658412954920192323e-4,
            -3.40465008687404560802977114492e-4,
            1.41312443674632500278074618366e-1,
        ],
        &[
            -4.28896301583791923408573538692e-1,
            0.0,
            0.0,
            0.0,
            0.0,
            -4.69762141536116384314449447206e0,
            7.68342119606259904184240953878e0,
            4.06898981839711007970213554331e0,
            3.56727187455281109270669543021e-1,
            0.0,
            0.0,
            0.0,
            -1.39902416515901462129418009734e-3,
            2.9475147891527723389556272149e0,
            -9.15095847217987001081870187138e0,
        ],
    ],
};

/// Eighth-order weights.
const B: &[f64] = TABLEAU.a[12];

/// Third-order weights `BHH1` (stage 1), `BHH2` (stage 9), `BHH3` (stage 12).
const BHH: [f64; 12] = [
    0.244094488188976377952755905512e+00,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.733846688281611857341361741547e+00,
    0.0,
    0.0,
    0.220588235294117647058823529412e-01,
];

/// `b − b̂`: eighth- minus fifth-order weights (`ER1`, `ER6`…`ER12`).
const ER: [f64; 12] = [
    0.1312004499419488073250102996e-01,
    0.0,
    0.0,
    0.0,
    0.0,
    -0.1225156446376204440720569753e+01,
    -0.4957589496572501915214079952e+00,
    0.1664377182454986536961530415e+01,
    -0.3503288487499736816886487290e+00,
    0.3341791187130174790297318841e+00,
    0.8192320648511571246570742613e-01,
    -0.2235530786388629525884427845e-01,
];

/// Dense-output coefficients `D4j`…`D7j` over the 16 stages.
const D: [[f64; 16]; 4] = [
    [
        -0.84289382761090128651353491142e+01,
        0.0,
        0.0,
        0.0,
        0.0,
        0.56671495351937776962531783590e+00,
        -0.30689499459498916912797304727e+01,
        0.23846676565120698287728149680e+01,
        0.21170345824450282767155149946e+01,
        -0.87139158377797299206789907490e+00,
        0.22404374302607882758541771650e+01,
        0.63157877876946881815570249290e+00,
        -0.88990336451333310820698117400e-01,
        0.18148505520854727256656404962e+02,
        -0.91946323924783554000451984436e+01,
        -0.44360363875948939664310572000e+01,
    ],
    [
        0.10427508642579134603413151009e+02,
        0.0,
        0.0,
        0.0,
        0.0,
        0.24228349177525818288430175319e+03,
        0.16520045171727028198505394887e+03,
        -0.37454675472269020279518312152e+03,
        -0.22113666853125306036270938578e+02,
        0.77334326684722638389603898808e+01,
        -0.30674084731089398182061213626e+02,
        -0.93321305264302278729567221706e+01,
        0.15697238121770843886131091075e+02,
        -0.31139403219565177677282850411e+02,
        -0.93529243588444783865713862664e+01,
        0.35816841486394083752465898540e+02,
    ],
    [
        0.19985053242002433820987653617e+02,
        0.0,
        0.0,
        0.0,
        0.0,
        -0.38703730874935176555105901742e+03,
        -0.18917813819516756882830838328e+03,
        0.52780815920542364900561016686e+03,
        -0.11573902539959630126141871134e+02,
        0.68812326946963000169666922661e+01,
        -0.10006050966910838403183860980e+01,
        0.77771377980534432092869265740e+00,
        -0.27782057523535084065932004339e+01,
        -0.60196695231264120758267380846e+02,
        0.84320405506677161018159903784e+02,
        0.11992291136182789328035130030e+02,
    ],
    [
        -0.25693933462703749003312586129e+02,
        0.0,
        0.0,
        0.0,
        0.0,
        -0.15418974869023643374053993627e+03,
        -0.23152937917604549567536039109e+03,
        0.35763911791061412378285349910e+03,
        0.93405324183624310003907691704e+02,
        -0.37458323136451633156875139351e+02,
        0.10409964950896230045147246184e+03,
        0.29840293426660503123344363579e+02,
        -0.43533456590011143754432175058e+02,
        0.96324553959188282948394950600e+02,
        -0.39177261675615439165231486172e+02,
        -0.14972683625798562581422125276e+03,
    ],
];

/// `b − b̂₃`: eighth- minus third-order weights (dop853.f subtracts the two sums).
const B_MINUS_BHH: [f64; 12] = {
    let mut d = [0.0; 12];
    let mut j = 0;
    while j < 12 {
        d[j] = B[j] - BHH[j];
        j += 1;
    }
    d
};

rows! {
    A1 = TABLEAU.a[1];
    A2 = TABLEAU.a[2];
    A3 = TABLEAU.a[3];
    A4 = TABLEAU.a[4];
    A5 = TABLEAU.a[5];
    A6 = TABLEAU.a[6];
    A7 = TABLEAU.a[7];
    A8 = TABLEAU.a[8];
    A9 = TABLEAU.a[9];
    A10 = TABLEAU.a[10];
    A11 = TABLEAU.a[11];
    /// The eighth-order weights (row 12: stage 13 is f at the new point).
    B_ROW = B;
    A13 = TABLEAU.a[13];
    A14 = TABLEAU.a[14];
    A15 = TABLEAU.a[15];
    ERR3 = &B_MINUS_BHH;
    ERR5 = &ER;
    D4 = &D[0];
    D5 = &D[1];
    D6 = &D[2];
    D7 = &D[3];
}

/// The DOP853 stepper: eleven evaluations per attempt, one more per accepted step
/// (`f(t + h, y_new)`), and three more for a step whose continuous extension is needed.
pub(crate) struct Dop853 {
    stages: Stages,
    dense: Dense8,
    /// The two error sums, then a dense-output sum, per component.
    scratch: [Vec<f64>; 2],
}

/// Continuous extension over the last accepted step (dop853.f `CONTD8`): the eight
/// coefficients `RCONT` of each component together.
struct Dense8 {
    r: Vec<f64>,
}

impl Dop853 {
    pub(crate) fn new(n: usize) -> Self {
        Dop853 {
            stages: Stages::new(16, n),
            dense: Dense8 {
                r: vec![0.0; 8 * n],
            },
            scratch: [vec![0.0; n], vec![0.0; n]],
        }
    }
}

impl AdaptiveStep for Dop853 {
    fn order(&self) -> u32 {
        8
    }

    fn controller(&self, beta: Option<f64>, h_max: f64) -> Controller {
        let beta = beta.unwrap_or(0.0);
        Controller::new(0.9, 0.333, 6.0, beta, 1.0 / 8.0 - 0.2 * beta, h_max)
    }

    fn start(&mut self, f0: &[f64]) {
        self.stages.set(0, f0);
    }

    fn attempt<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        tol: &Tolerances,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &mut [f64],
    ) -> Result<f64, StepFailure> {
        let (st, c) = (&mut self.stages, TABLEAU.c);
        st.stage(ev, (&A1, c[1]), t, y, h, 1)?;
        st.stage(ev, (&A2, c[2]), t, y, h, 2)?;
        st.stage(ev, (&A3, c[3]), t, y, h, 3)?;
        st.stage(ev, (&A4, c[4]), t, y, h, 4)?;
        st.stage(ev, (&A5, c[5]), t, y, h, 5)?;
        st.stage(ev, (&A6, c[6]), t, y, h, 6)?;
        st.stage(ev, (&A7, c[7]), t, y, h, 7)?;
        st.stage(ev, (&A8, c[8]), t, y, h, 8)?;
        st.stage(ev, (&A9, c[9]), t, y, h, 9)?;
        st.stage(ev, (&A10, c[10]), t, y, h, 10)?;
        st.stage(ev, (&A11, c[11]), t, y, h, 11)?;
        st.combine(y, h, &B_ROW, y_new);
        let [e3, e5] = &mut self.scratch;
        st.sum(&ERR3, e3);
        st.sum(&ERR5, e5);
        let (mut err5, mut err3) = (0.0, 0.0);
        for i in 0..y.len() {
            let sk = tol.scale(y[i], y_new[i]);
            err3 += (e3[i] / sk).powi(2);
            err5 += (e5[i] / sk).powi(2);
        }
        let deno = err5 + 0.01 * err3;
        let deno = if deno > 0.0 { deno } else { 1.0 };
        Ok(h.abs() * err5 / (y.len() as f64 * deno).sqrt())
    }

    fn accept<S: OdeSystem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, S>,
        t: f64,
        y: &[f64],
        h: f64,
        y_new: &[f64],
        dense: bool,
    ) -> Result<(), StepFailure> {
        self.stages.evaluate_at(ev, 12, t + h, y_new)?;
        if dense {
            let (st, c) = (&mut self.stages, TABLEAU.c);
            st.stage(ev, (&A13, c[13]), t, y, h, 13)?;
            st.stage(ev, (&A14, c[14]), t, y, h, 14)?;
            st.stage(ev, (&A15, c[15]), t, y, h, 15)?;
            let (k0, k12) = (st.k(0), st.k(12));
            for (i, r) in self.dense.r.chunks_exact_mut(8).enumerate() {
                let ydiff = y_new[i] - y[i];
                let bspl = h * k0[i] - ydiff;
                r[0] = y[i];
                r[1] = ydiff;
                r[2] = bspl;
                r[3] = ydiff - h * k12[i] - bspl;
            }
            let (d, r) = (&mut self.scratch[0], &mut self.dense.r);
            st.sum(&D4, d);
            Dense8::put(r, 4, h, d);
            st.sum(&D5, d);
            Dense8::put(r, 5, h, d);
            st.sum(&D6, d);
            Dense8::put(r, 6, h, d);
            st.sum(&D7, d);
            Dense8::put(r, 7, h, d);
        }
        self.stages.copy(12, 0);
        Ok(())
    }

    fn interpolant(&self) -> Option<&dyn Interpolant> {
        Some(&self.dense)
    }
}

impl Dense8 {
    /// Coefficient `m` of every component: `h · d`.
    fn put(r: &mut [f64], m: usize, h: f64, d: &[f64]) {
        for (r, di) in r.chunks_exact_mut(8).zip(d) {
            r[m] = h * di;
        }
    }
}

impl Interpolant for Dense8 {
    fn interpolate(&self, theta: f64, out: &mut [f64]) {
        let s = theta;
        let s1 = 1.0 - s;
        for (o, r) in out.iter_mut().zip(self.r.chunks_exact(8)) {
            let conpar = r[4] + s * (r[5] + s1 * (r[6] + s * r[7]));
            *o = r[0] + s * (r[1] + s1 * (r[2] + s * (r[3] + s1 * conpar)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{
        assert_order, dense_error_after_one_step, global_error_fixed, quadrature_defect,
        row_sum_defect,
    };

    #[test]
    fn tableau_rows_sum_to_nodes() {
        assert!(
            row_sum_defect(&TABLEAU) < 1e-13,
            "{}",
            row_sum_defect(&TABLEAU)
        );
    }

    #[test]
    fn weights_satisfy_quadrature_conditions() {
        let c = &TABLEAU.c[..12];
        assert!(quadrature_defect(B, c, 8) < 1e-13);
        let b5: Vec<f64> = B.iter().zip(ER).map(|(b, e)| b - e).collect();
        assert!(quadrature_defect(&b5, c, 5) < 1e-13);
        assert!(quadrature_defect(&BHH, c, 3) < 1e-15);
        assert!(
            quadrature_defect(&BHH, c, 4) > 1e-3,
            "the third-order estimator is only order 3"
        );
    }

    #[test]
    fn fixed_step_order_is_eight() {
        let e1 = global_error_fixed(&mut Dop853::new(2), 0.25);
        let e2 = global_error_fixed(&mut Dop853::new(2), 0.125);
        assert_order(e1, e2, 8.0, 0.5);
    }

    #[test]
    fn dense_output_has_local_order_eight() {
        // Observed ≈ 7.55 here, approaching 8 (7.8) at half these steps.
        let e1 = dense_error_after_one_step(&mut Dop853::new(2), 0.2, 0.3);
        let e2 = dense_error_after_one_step(&mut Dop853::new(2), 0.1, 0.3);
        assert_order(e1, e2, 8.0, 0.6);
    }
}
