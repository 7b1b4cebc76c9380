//! Lowest terms by the half-angle parametrisation: what makes the normal form canonical.
//!
//! The field's polynomials live in Z[…, s, c, …]/(s² + c² − 1), one pair (s, c) = (sin u, cos u)
//! per base angle u. That ring is a domain but not a unique factorisation domain
//! (s·s = (1 − c)(1 + c)), so a gcd computed there does not find every common factor. The map
//! s ↦ 2t/(1 + t²), c ↦ (1 − t²)/(1 + t²), t = tan(u/2), is injective into the rational
//! functions of the *half-angle ring* Z[…, t, …], a unique factorisation domain, where lowest
//! terms are unique ([`to_half`]).
//!
//! Back ([`from_half`]): given f/g in lowest terms, take per angle
//! k = ⌈max(deg_t f, deg_t g)/2⌉ and divide both by (1 + t²)^k; each t^j/(1 + t²)^k (j ≤ 2k) is
//! ((1 − c)/2)^⌊j/2⌋ (s/2)^(j mod 2) ((1 + c)/2)^(k − ⌈j/2⌉), a polynomial of degree ≤ 1 in s.
//! The result is a deterministic function of the unique f/g: equal values get identical N/D
//! ([`canonical`]). A polynomial comes back as itself.
//!
//! Arithmetic stays in (s, c), where sparse trigonometric polynomials are compact; only lowest
//! terms go through t. Factoring for printing ([`trig_factors`]) also goes through t, where
//! factorisation is unique, and regroups the factors into polynomials in (s, c).

use std::collections::HashMap;

use symbolica::prelude::*;

use crate::field::{FieldInner, Poly, VarKind};

/// The variables of the half-angle ring and their correspondence with the field's.
pub(crate) struct HalfRing {
    /// The zero polynomial of the half-angle ring (carries its variable list).
    pub zero: Poly,
    /// Field variable → half-angle-ring variable (sin u and cos u → t of u).
    pub of_var: Vec<usize>,
    /// Angle → its t.
    pub t: Vec<usize>,
    /// Half-angle-ring variable → field variable (`None` for a t).
    pub back: Vec<Option<usize>>,
}

impl HalfRing {
    /// The half-angle ring for field variables of these kinds; `ring(n)` makes the zero
    /// polynomial of a ring with n variables.
    pub fn new(kinds: &[VarKind], ring: impl Fn(usize) -> Poly) -> HalfRing {
        let (mut of_var, mut t, mut back) = (Vec::new(), Vec::new(), Vec::new());
        for (v, k) in kinds.iter().enumerate() {
            match k {
                VarKind::Sin(a) | VarKind::Cos(a) => {
                    if t.len() <= *a {
                        t.resize(*a + 1, usize::MAX);
                    }
                    if t[*a] == usize::MAX {
                        t[*a] = back.len();
                        back.push(None);
                    }
                    of_var.push(t[*a]);
                }
                _ => {
                    of_var.push(back.len());
                    back.push(Some(v));
                }
            }
        }
        HalfRing {
            zero: ring(back.len()),
            of_var,
            t,
            back,
        }
    }

    fn var(&self, v: usize) -> Poly {
        let mut e = vec![0u16; self.back.len()];
        e[v] = 1;
        self.zero.monomial(Integer::from(1), e)
    }

    /// 1 + t² for angle `a`.
    fn h(&self, a: usize) -> Poly {
        let t = self.var(self.t[a]);
        &self.zero.one() + &(&t * &t)
    }
}

fn pow(p: &Poly, k: usize, one: &Poly) -> Poly {
    (0..k).fold(one.clone(), |acc, _| &acc * p)
}

/// True when a sin or cos variable occurs in `p`.
pub(crate) fn has_angles(f: &FieldInner, p: &Poly) -> bool {
    f.angles
        .iter()
        .any(|a| p.degree(a.sin) > 0 || p.degree(a.cos) > 0)
}

/// A field polynomial p as f/∏(1 + t_a²)^(m_a): returns f in the half-angle ring and m, the
/// total degree of p in (sin u_a, cos u_a) per angle.
pub(crate) fn to_half(f: &FieldInner, p: &Poly) -> (Poly, Vec<usize>) {
    let hr = &f.half;
    let m: Vec<usize> = f
        .angles
        .iter()
        .map(|av| {
            p.into_iter()
                .map(|t| (t.exponents[av.sin] + t.exponents[av.cos]) as usize)
                .max()
                .unwrap_or(0)
        })
        .collect();
    // Group by the (sin, cos) exponents of every angle: p = Σ_K s^i c^j p_K.
    let mut groups: HashMap<Vec<(u16, u16)>, Poly> = HashMap::new();
    let mut exps = vec![0u16; hr.back.len()];
    for term in p {
        exps.iter_mut().for_each(|e| *e = 0);
        let key: Vec<(u16, u16)> = f
            .angles
            .iter()
            .map(|av| (term.exponents[av.sin], term.exponents[av.cos]))
            .collect();
        for (v, &e) in term.exponents.iter().enumerate() {
            if e > 0 && hr.back[hr.of_var[v]].is_some() {
                exps[hr.of_var[v]] = e;
            }
        }
        groups
            .entry(key)
            .or_insert_with(|| hr.zero.clone())
            .append_monomial(term.coefficient.clone(), &exps);
    }
    let one = hr.zero.one();
    let mut memo: HashMap<(usize, u16, u16), Poly> = HashMap::new();
    let mut keys: Vec<&Vec<(u16, u16)>> = groups.keys().collect();
    keys.sort();
    let mut out = hr.zero.clone();
    for key in keys {
        let mut term = groups[key].clone();
        for (a, &(i, j)) in key.iter().enumerate() {
            if m[a] == 0 {
                continue;
            }
            let image = memo.entry((a, i, j)).or_insert_with(|| {
                // s^i c^j (1 + t²)^(m − i − j) with s ↦ 2t, c ↦ 1 − t²
                let t = hr.var(hr.t[a]);
                let s = &t * &hr.zero.constant(Integer::from(2));
                let c = &one - &(&t * &t);
                let rest = m[a] - (i + j) as usize;
                &(&pow(&s, i as usize, &one) * &pow(&c, j as usize, &one))
                    * &pow(&hr.h(a), rest, &one)
            });
            term = &term * image;
        }
        out = &out + &term;
    }
    (out, m)
}

/// The image of t^j/(1 + t²)^k for angle `a`, times 2^k: (1 − c)^⌊j/2⌋ s^(j mod 2)
/// (1 + c)^(k − ⌈j/2⌉).
fn half_angle_monomial(f: &FieldInner, a: usize, j: usize, k: usize) -> Poly {
    let av = &f.angles[a];
    let (s, c) = (f.var_poly(av.sin), f.var_poly(av.cos));
    let one = f.one();
    let odd = if j % 2 == 1 { s } else { one.clone() };
    &(&odd * &pow(&(&one - &c), j / 2, &one)) * &pow(&(&one + &c), k - j.div_ceil(2), &one)
}

/// 2^k·f/∏(1 + t_a²)^(k_a) as a field polynomial (f in the half-angle ring, deg_t f ≤ 2k_a).
fn to_field(f: &FieldInner, p: &Poly, ks: &[usize]) -> Poly {
    let hr = &f.half;
    let angles: Vec<usize> = (0..ks.len()).filter(|&a| ks[a] > 0).collect();
    let mut groups: HashMap<Vec<u16>, Poly> = HashMap::new();
    let mut exps = vec![0u16; f.nvars()];
    for term in p {
        exps.iter_mut().for_each(|e| *e = 0);
        let key: Vec<u16> = angles.iter().map(|&a| term.exponents[hr.t[a]]).collect();
        for (w, &e) in term.exponents.iter().enumerate() {
            if let (true, Some(v)) = (e > 0, hr.back[w]) {
                exps[v] = e;
            }
        }
        groups
            .entry(key)
            .or_insert_with(|| f.zero.clone())
            .append_monomial(term.coefficient.clone(), &exps);
    }
    let mut memo: HashMap<(usize, u16), Poly> = HashMap::new();
    let mut keys: Vec<&Vec<u16>> = groups.keys().collect();
    keys.sort();
    let mut out = f.zero.clone();
    for key in keys {
        let mut term = groups[key].clone();
        for (&a, &j) in angles.iter().zip(key) {
            let m = memo
                .entry((a, j))
                .or_insert_with(|| half_angle_monomial(f, a, j as usize, ks[a]));
            term = &term * m;
        }
        out = &out + &term;
    }
    out
}

/// k_a = ⌈max(deg_t f, deg_t g)/2⌉ per angle.
fn half_degrees(f: &FieldInner, polys: &[&Poly]) -> Vec<usize> {
    f.half
        .t
        .iter()
        .map(|&t| {
            let d = polys
                .iter()
                .map(|p| p.degree(t) as usize)
                .max()
                .unwrap_or(0);
            d.div_ceil(2)
        })
        .collect()
}

/// f/g in lowest terms (half-angle ring) back to the field: N/D with the ratio f/g, N and D of
/// degree ≤ 1 in each sin, without common integer content, D's leading coefficient positive.
pub(crate) fn from_half(f: &FieldInner, num: &Poly, den: &Poly) -> (Poly, Poly) {
    let ks = half_degrees(f, &[num, den]);
    let (mut n, mut d) = (to_field(f, num, &ks), to_field(f, den, &ks));
    if n.is_zero() {
        return (n, f.one());
    }
    let g = f.constant(n.content()).gcd(&f.constant(d.content()));
    if !g.is_one() {
        n = n.quot_rem(&g, false).0;
        d = d.quot_rem(&g, false).0;
    }
    if d.lcoeff().is_negative() {
        (-n, -d)
    } else {
        (n, d)
    }
}

/// The half-angle images of N and D over one denominator: (f, g) with N/D = f/g.
fn half_pair(f: &FieldInner, n: &Poly, d: &Poly) -> (Poly, Poly) {
    let hr = &f.half;
    let one = hr.zero.one();
    let (mut fn_, mn) = to_half(f, n);
    let (mut gd, md) = to_half(f, d);
    // N/D = fn/∏h^mn · ∏h^md/gd
    for a in 0..f.angles.len() {
        let h = hr.h(a);
        if md[a] > mn[a] {
            fn_ = &fn_ * &pow(&h, md[a] - mn[a], &one);
        } else if mn[a] > md[a] {
            gd = &gd * &pow(&h, mn[a] - md[a], &one);
        }
    }
    (fn_, gd)
}

/// The canonical form of N/D (D ≠ 0, both reduced): lowest terms in the half-angle ring, back
/// in the field ([`from_half`]).
pub(crate) fn canonical(f: &FieldInner, n: &Poly, d: &Poly) -> (Poly, Poly) {
    let (fn_, gd) = half_pair(f, n, d);
    let g = fn_.gcd(&gd);
    if g.is_one() {
        from_half(f, &fn_, &gd)
    } else {
        from_half(f, &fn_.quot_rem(&g, false).0, &gd.quot_rem(&g, false).0)
    }
}

/// A field polynomial's half-angle image factored: f = content · ∏ pᵢ^eᵢ, with the degrees m.
pub(crate) struct HalfFactors {
    /// Integer content and sign, as a constant of the half-angle ring.
    pub content: Poly,
    /// Irreducible factors with positive leading coefficients, and multiplicities.
    pub primes: Vec<(Poly, u32)>,
    /// p = f/∏(1 + t_a²)^(m_a).
    pub m: Vec<usize>,
}

/// Factor the half-angle image of a field polynomial.
pub(crate) fn half_factors(f: &FieldInner, p: &Poly) -> HalfFactors {
    let (image, m) = to_half(f, p);
    let mut content = f.half.zero.one();
    let mut primes = Vec::new();
    for (q, e) in image.factor() {
        if q.is_constant() {
            content = &content * &pow(&q, e, &f.half.zero.one());
        } else if q.lcoeff().is_negative() {
            if e % 2 == 1 {
                content = -content;
            }
            primes.push((-q, e as u32));
        } else {
            primes.push((q, e as u32));
        }
    }
    HalfFactors { content, primes, m }
}

/// num / (c · ∏ bᵢ^eᵢ) in canonical form, given the factorisations of the bᵢ: trial division
/// of the numerator's image by the known prime factors of the denominator's, instead of a gcd;
/// with the half-angle factorisation of the resulting denominator (for printing it factored
/// without factoring it again).
pub(crate) fn canonical_over_factored(
    f: &FieldInner,
    num: &Poly,
    c: &Poly,
    dens: &[(&HalfFactors, u32)],
) -> (Poly, Poly, HalfFactors) {
    let hr = &f.half;
    let one = hr.zero.one();
    let (mut n, mn) = to_half(f, num);
    // Denominator: c' · ∏ p^E · ∏ h_a^H (H may be negative: h_a then moves to the numerator).
    let mut cden = hr.zero.constant(c.lcoeff());
    let mut primes: Vec<(Poly, i64)> = Vec::new();
    let mut hexp: Vec<i64> = mn.iter().map(|&m| m as i64).collect();
    let hs: Vec<Poly> = (0..f.angles.len()).map(|a| hr.h(a)).collect();
    for (hf, e) in dens {
        let e = *e as usize;
        cden = &cden * &pow(&hf.content, e, &one);
        for (a, &m) in hf.m.iter().enumerate() {
            hexp[a] -= (m * e) as i64;
        }
        for (p, k) in &hf.primes {
            let k = (*k as usize * e) as i64;
            if let Some(a) = hs.iter().position(|h| h == p) {
                hexp[a] += k;
            } else if let Some(slot) = primes.iter_mut().find(|(q, _)| q == p) {
                slot.1 += k;
            } else {
                primes.push((p.clone(), k));
            }
        }
    }
    for (a, h) in hs.iter().enumerate() {
        if hexp[a] < 0 {
            n = &n * &pow(h, (-hexp[a]) as usize, &one);
            hexp[a] = 0;
        } else {
            primes.push((h.clone(), hexp[a]));
        }
    }
    let mut den = cden.clone();
    for (p, k) in &mut primes {
        while *k > 0 {
            let (q, r) = n.quot_rem(p, false);
            if !r.is_zero() {
                break;
            }
            n = q;
            *k -= 1;
        }
        den = &den * &pow(p, *k as usize, &one);
    }
    // The field denominator D = 2^k·den/∏h^k (up to content) has the image D·∏h^(m_D):
    // den's primes, with h's exponent moved by m_D − k.
    let ks = half_degrees(f, &[&n, &den]);
    let (num, d) = from_half(f, &n, &den);
    let m: Vec<usize> = f
        .angles
        .iter()
        .map(|av| {
            d.into_iter()
                .map(|t| (t.exponents[av.sin] + t.exponents[av.cos]) as usize)
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out: Vec<(Poly, u32)> = Vec::new();
    for (a, h) in hs.iter().enumerate() {
        let k = primes.iter().find(|(p, _)| p == h).map_or(0, |(_, k)| *k);
        let e = m[a] as i64 - ks[a] as i64 + k;
        if e > 0 {
            out.push((h.clone(), e as u32));
        }
    }
    out.extend(
        primes
            .into_iter()
            .filter(|(p, k)| *k > 0 && !hs.contains(p))
            .map(|(p, k)| (p, k as u32)),
    );
    let hf = HalfFactors {
        content: cden,
        primes: out,
        m,
    };
    (num, d, hf)
}

/// A field polynomial p (a canonical numerator or denominator) as κ · ∏ Tᵢ^eᵢ with Tᵢ
/// polynomials in (sin, cos) of degree ≤ 1 in each sin, primitive with positive leading
/// coefficients, from the unique factorisation of its half-angle image: each prime of even
/// degree in every t is one Tᵢ; the primes of odd degree are taken one by one while the degree
/// budget allows and together otherwise (split again by factoring in (s, c)); what remains of
/// the budget is (1 + cos u)^r (the zeros at u = π). `None` when p has no angle or κ is not
/// an integer.
pub(crate) fn trig_factors(f: &FieldInner, p: &Poly) -> Option<(Integer, Vec<(Poly, u32)>)> {
    if !has_angles(f, p) {
        return None;
    }
    trig_factors_of(f, p, &half_factors(f, p))
}

/// [`trig_factors`] given the half-angle factorisation `hf` of `p`.
pub(crate) fn trig_factors_of(
    f: &FieldInner,
    p: &Poly,
    hf: &HalfFactors,
) -> Option<(Integer, Vec<(Poly, u32)>)> {
    let hs: Vec<Poly> = (0..f.angles.len()).map(|a| f.half.h(a)).collect();
    let mut budget: Vec<i64> = hf.m.iter().map(|&m| m as i64).collect();
    let degs = |q: &Poly| -> Vec<i64> { f.half.t.iter().map(|&t| q.degree(t) as i64).collect() };
    let mut out: Vec<(Poly, u32)> = Vec::new();
    let mut odd: Vec<(Poly, u32)> = Vec::new();
    for (q, e) in &hf.primes {
        if let Some(a) = hs.iter().position(|h| h == q) {
            budget[a] -= *e as i64;
            continue;
        }
        let d = degs(q);
        if d.iter().all(|x| x % 2 == 0) {
            let ks: Vec<usize> = d.iter().map(|&x| (x / 2) as usize).collect();
            for (a, k) in ks.iter().enumerate() {
                budget[a] -= *k as i64 * *e as i64;
            }
            out.push((to_field(f, q, &ks), *e));
        } else {
            odd.push((q.clone(), *e));
        }
    }
    // The odd primes: alone while the rest still fits, then together.
    let one = f.half.zero.one();
    let mut rest = odd
        .iter()
        .fold(one.clone(), |acc, (q, e)| &acc * &pow(q, *e as usize, &one));
    for (q, e) in &odd {
        let own: Vec<i64> = degs(q).iter().map(|x| (x + 1) / 2 * *e as i64).collect();
        let without = rest.quot_rem(&pow(q, *e as usize, &one), false).0;
        let need: Vec<i64> = degs(&without).iter().map(|x| (x + 1) / 2).collect();
        if (0..budget.len()).all(|a| own[a] + need[a] <= budget[a]) {
            let ks: Vec<usize> = degs(q).iter().map(|x| ((x + 1) / 2) as usize).collect();
            out.push((to_field(f, q, &ks), *e));
            for a in 0..budget.len() {
                budget[a] -= own[a];
            }
            rest = without;
        }
    }
    if !rest.is_constant() {
        let ks: Vec<usize> = degs(&rest).iter().map(|x| ((x + 1) / 2) as usize).collect();
        for (a, k) in ks.iter().enumerate() {
            budget[a] -= *k as i64;
        }
        for (t, e) in to_field(f, &rest, &ks).factor() {
            if !t.is_constant() {
                out.push((t, e as u32));
            }
        }
    }
    for (a, &r) in budget.iter().enumerate() {
        if r > 0 {
            let av = &f.angles[a];
            out.push((&f.one() + &f.var_poly(av.cos), r as u32));
        }
    }
    // Primitive, positive leading coefficients; κ = p / ∏ Tᵢ^eᵢ exactly.
    let mut prod = f.one();
    for (t, e) in &mut out {
        let c = f.constant(t.content());
        *t = t.quot_rem(&c, false).0;
        if t.lcoeff().is_negative() {
            *t = -t.clone();
        }
        prod = f.reduce(&prod * &pow(t, *e as usize, &f.one()));
    }
    let (kappa, r) = p.quot_rem(&prod, false);
    (r.is_zero() && kappa.is_constant()).then(|| (kappa.lcoeff(), out))
}
