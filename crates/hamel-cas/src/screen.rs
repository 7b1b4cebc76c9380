//! Certificates by evaluation modulo a prime: cheap proofs that a prime of the half-angle ring
//! does *not* divide the image of a field polynomial, and of the image's degree in each t.
//!
//! Evaluation at a point modulo the prime P = 2⁶¹ − 1 is a ring homomorphism. If p divides n
//! in the half-angle ring, then with every variable but one, x, at the point, p̄ divides n̄ in
//! F_P[x], provided p̄ keeps its degree in x. So a non-zero remainder of n̄ by p̄ *proves*
//! p ∤ n, and a non-zero value of a polynomial at the point proves it is not zero. A zero
//! remainder or a zero value proves nothing: the caller then decides exactly (divides, or
//! divides by 1 + cos u), so nothing is ever decided by sampling. The point is fixed
//! (deterministic), and since P ≡ 3 (mod 4), 1 + t² never vanishes in F_P.
//!
//! The image of a field polynomial N is computed from N directly, without expanding it in t:
//! N = Σ s^i c^j N_ij per angle u, and its image in t = tan(u/2) is
//! Σ N_ij (2t)^i (1 − t²)^j (1 + t²)^(m − i − j) (see [`crate::half`]).

use std::collections::HashMap;

use symbolica::prelude::*;

use crate::vars::{FieldInner, Poly, integer_to_big};

/// The prime modulus, 2⁶¹ − 1.
const P: u64 = (1 << 61) - 1;

fn mul(a: u64, b: u64) -> u64 {
    ((a as u128 * b as u128) % P as u128) as u64
}

fn add(a: u64, b: u64) -> u64 {
    (a + b) % P
}

fn neg(a: u64) -> u64 {
    (P - a) % P
}

fn pow(a: u64, mut e: u64) -> u64 {
    let (mut base, mut out) = (a, 1);
    while e > 0 {
        if e & 1 == 1 {
            out = mul(out, base);
        }
        base = mul(base, base);
        e >>= 1;
    }
    out
}

fn inv(a: u64) -> u64 {
    pow(a, P - 2)
}

fn residue(c: &Integer) -> u64 {
    let r = integer_to_big(c) % num_bigint::BigInt::from(P);
    let r: i128 = r.try_into().expect("a residue below 2^61");
    r.rem_euclid(P as i128) as u64
}

/// A univariate polynomial over F_P, coefficient k of x^k.
type Uni = Vec<u64>;

fn uni_mul(a: &Uni, b: &Uni) -> Uni {
    let mut out = vec![0; a.len() + b.len() - 1];
    for (i, &x) in a.iter().enumerate() {
        for (j, &y) in b.iter().enumerate() {
            out[i + j] = add(out[i + j], mul(x, y));
        }
    }
    out
}

fn uni_pow(a: &Uni, k: usize) -> Uni {
    (0..k).fold(vec![1], |acc, _| uni_mul(&acc, a))
}

fn degree(a: &Uni) -> Option<usize> {
    a.iter().rposition(|&x| x != 0)
}

/// True when `d` (of exact degree `dd`) does not divide `n` (proved).
fn proves_no_division(n: &Uni, d: &Uni, dd: usize) -> bool {
    let Some(mut dn) = degree(n) else {
        return false;
    };
    if dn < dd {
        return true;
    }
    let mut r = n.clone();
    let lead = inv(d[dd]);
    loop {
        let q = mul(r[dn], lead);
        for (k, &dk) in d.iter().enumerate().take(dd + 1) {
            let i = dn - dd + k;
            r[i] = add(r[i], neg(mul(q, dk)));
        }
        match degree(&r) {
            Some(x) if x >= dd => dn = x,
            Some(_) => return true,
            None => return false,
        }
    }
}

/// A fixed point: a value for every half-angle-ring variable (t_a, and the other field
/// variables), and for every field variable (sin u_a = 2t_a/(1 + t_a²), cos u_a = (1 − t_a²)/
/// (1 + t_a²)).
pub(crate) struct Point {
    half: Vec<u64>,
    field: Vec<u64>,
}

impl Point {
    pub fn new(f: &FieldInner) -> Point {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            // splitmix64
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            (z ^ (z >> 31)) % P
        };
        let half: Vec<u64> = (0..f.half.back.len()).map(|_| next()).collect();
        let mut field = vec![0; f.nvars()];
        for (w, v) in f.half.back.iter().enumerate() {
            if let Some(v) = v {
                field[*v] = half[w];
            }
        }
        for (a, av) in f.angles.iter().enumerate() {
            let t = half[f.half.t[a]];
            let t2 = mul(t, t);
            let h = inv(add(1, t2));
            field[av.sin] = mul(mul(2, t), h);
            field[av.cos] = mul(add(1, neg(t2)), h);
        }
        Point { half, field }
    }
}

/// The image in the half-angle ring of a field polynomial N times ∏ (1 + t_a²)^(extra_a), seen
/// through evaluations at a [`Point`].
pub(crate) struct FieldImage<'a> {
    f: &'a FieldInner,
    /// N.
    pub n: Poly,
    /// N's total degree in (sin u_a, cos u_a) per angle.
    pub m: Vec<usize>,
    /// The powers of 1 + t_a² the image carries beyond N's own.
    pub extra: Vec<usize>,
    coeffs: Vec<u64>,
    point: &'a Point,
    /// n̄ in each half-angle-ring variable (memo).
    memo: HashMap<usize, Uni>,
}

impl<'a> FieldImage<'a> {
    /// `None` unless N is reduced (degree ≤ 1 in every sin).
    pub fn new(
        f: &'a FieldInner,
        n: Poly,
        m: &[usize],
        extra: &[usize],
        point: &'a Point,
    ) -> Option<Self> {
        if f.angles.iter().any(|av| n.degree(av.sin) > 1) {
            return None;
        }
        Some(FieldImage {
            f,
            m: m.to_vec(),
            extra: extra.to_vec(),
            coeffs: (&n).into_iter().map(|t| residue(t.coefficient)).collect(),
            n,
            point,
            memo: HashMap::new(),
        })
    }

    /// coefficient · ∏ (values of the term's variables other than `skip`).
    fn term_value(&self, k: usize, exps: &[u16], skip: &[usize]) -> u64 {
        exps.iter()
            .enumerate()
            .filter(|(v, e)| **e > 0 && !skip.contains(v))
            .fold(self.coeffs[k], |acc, (v, &e)| {
                mul(acc, pow(self.point.field[v], e as u64))
            })
    }

    /// n̄ in the half-angle-ring variable w, up to a non-zero constant.
    fn image_in(&mut self, w: usize) -> Uni {
        if let Some(u) = self.memo.get(&w) {
            return u.clone();
        }
        let hr = &self.f.half;
        let out = match hr.back[w] {
            Some(v) => {
                let mut out = vec![0; self.n.degree(v) as usize + 1];
                for (k, t) in (&self.n).into_iter().enumerate() {
                    let e = t.exponents[v] as usize;
                    out[e] = add(out[e], self.term_value(k, t.exponents, &[v]));
                }
                out
            }
            None => self.angle_image(hr.t.iter().position(|&t| t == w).expect("a t")),
        };
        self.memo.insert(w, out.clone());
        out
    }

    /// Σ N̄_ij (2x)^i (1 − x²)^j (1 + x²)^(m + extra − i − j) for angle a.
    fn angle_image(&self, a: usize) -> Uni {
        let av = &self.f.angles[a];
        let top = self.m[a] + self.extra[a];
        let mut table = vec![[0u64; 2]; self.m[a] + 1];
        for (k, t) in (&self.n).into_iter().enumerate() {
            let (i, j) = (t.exponents[av.sin] as usize, t.exponents[av.cos] as usize);
            table[j][i] = add(
                table[j][i],
                self.term_value(k, t.exponents, &[av.sin, av.cos]),
            );
        }
        let minus = vec![1, 0, neg(1)];
        let plus = vec![1, 0, 1];
        let mut out = vec![0; 2 * top + 1];
        for (j, row) in table.iter().enumerate() {
            for (i, &c) in row.iter().enumerate() {
                if c == 0 {
                    continue;
                }
                let mut u = uni_mul(&uni_pow(&minus, j), &uni_pow(&plus, top - i - j));
                if i == 1 {
                    u.insert(0, 0);
                    u.iter_mut().for_each(|x| *x = mul(*x, 2));
                }
                for (k, x) in u.iter().enumerate() {
                    out[k] = add(out[k], mul(c, *x));
                }
            }
        }
        out
    }

    /// False only when p (a prime of the half-angle ring) is proved not to divide the image.
    pub fn may_be_divided_by(&mut self, p: &Poly) -> bool {
        let hr = &self.f.half;
        let nvars = hr.back.len();
        let by_degree = |w: &usize| p.degree(*w);
        let Some(w) = (0..nvars)
            .filter(|w| p.degree(*w) > 0)
            .max_by_key(by_degree)
        else {
            return true;
        };
        let mut pbar = vec![0; p.degree(w) as usize + 1];
        for t in p {
            let e = t.exponents[w] as usize;
            let v = t
                .exponents
                .iter()
                .enumerate()
                .filter(|(u, e)| **e > 0 && *u != w)
                .fold(residue(t.coefficient), |acc, (u, &e)| {
                    mul(acc, pow(self.point.half[u], e as u64))
                });
            pbar[e] = add(pbar[e], v);
        }
        let dd = pbar.len() - 1;
        if pbar[dd] == 0 {
            return true;
        }
        !proves_no_division(&self.image_in(w), &pbar, dd)
    }

    /// The image's degree in t_a, exactly: 2(m_a + extra_a) − r_a, where r_a is the order of N
    /// at u_a = π. With N = A + s·B (A, B free of sin u_a), r = min(2α, 2β + 1), α and β the
    /// multiplicities of the factor 1 + cos u_a in A and B (a term of even order and one of odd
    /// order cannot cancel). A non-zero value at the point proves a multiplicity zero; otherwise
    /// it is found by exact division.
    pub fn t_degree(&self, a: usize) -> usize {
        let top = 2 * (self.m[a] + self.extra[a]);
        if self.m[a] == 0 {
            return top;
        }
        let av = &self.f.angles[a];
        let at_pi = |odd: u16| -> u64 {
            (&self.n)
                .into_iter()
                .enumerate()
                .filter(|(_, t)| t.exponents[av.sin] == odd)
                .fold(0, |acc, (k, t)| {
                    let v = self.term_value(k, t.exponents, &[av.sin, av.cos]);
                    let sign = if t.exponents[av.cos] % 2 == 1 {
                        neg(v)
                    } else {
                        v
                    };
                    add(acc, sign)
                })
        };
        let (alpha, beta) = match (at_pi(0), at_pi(1)) {
            (0, _) | (_, 0) => self.multiplicities(a),
            _ => (Some(0), Some(0)),
        };
        let r = match (alpha, beta) {
            (Some(x), Some(y)) => (2 * x).min(2 * y + 1),
            (Some(x), None) => 2 * x,
            (None, Some(y)) => 2 * y + 1,
            (None, None) => 0,
        };
        top - r
    }

    /// The multiplicities of 1 + cos u_a in A and B (None for a zero part), by exact division.
    fn multiplicities(&self, a: usize) -> (Option<usize>, Option<usize>) {
        let av = &self.f.angles[a];
        let parts = self.f.split(&self.n, av.sin);
        let v = &self.f.one() + &self.f.var_poly(av.cos);
        let count = |p: Option<&Poly>| -> Option<usize> {
            let mut p = p.filter(|p| !p.is_zero())?.clone();
            let mut k = 0;
            loop {
                let (q, r) = p.quot_rem(&v, false);
                if !r.is_zero() {
                    return Some(k);
                }
                p = q;
                k += 1;
            }
        };
        (count(parts.first()), count(parts.get(1)))
    }
}
