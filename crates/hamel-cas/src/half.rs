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

use crate::vars::{FieldInner, HalfRing, Poly};

impl HalfRing {
    fn var(&self, v: usize) -> Poly {
        let mut e = vec![0u16; self.back.len()];
        e[v] = 1;
        self.zero.monomial(Integer::from(1), e)
    }

    /// 1 + t² for angle `a`.
    pub(crate) fn h(&self, a: usize) -> Poly {
        let t = self.var(self.t[a]);
        &self.zero.one() + &(&t * &t)
    }
}

pub(crate) fn pow(p: &Poly, k: usize, one: &Poly) -> Poly {
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
    let m = angle_degrees(f, p);
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
    let mut terms = Vec::with_capacity(keys.len());
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
        terms.push(term);
    }
    (sum_balanced(terms, &hr.zero), m)
}

/// The sum of `terms` by halves: each term is merged about log₂(len) times, instead of the
/// len times of a running sum.
fn sum_balanced(mut terms: Vec<Poly>, zero: &Poly) -> Poly {
    while terms.len() > 1 {
        let mut next = Vec::with_capacity(terms.len().div_ceil(2));
        let mut it = terms.into_iter();
        while let Some(a) = it.next() {
            next.push(match it.next() {
                Some(b) => &a + &b,
                None => a,
            });
        }
        terms = next;
    }
    terms.pop().unwrap_or_else(|| zero.clone())
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
    finish(f, to_field(f, num, &ks), to_field(f, den, &ks))
}

/// N/D without common integer content, D's leading coefficient positive.
fn finish(f: &FieldInner, mut n: Poly, mut d: Poly) -> (Poly, Poly) {
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
    lowest_terms(f, &fn_, &gd)
}

/// The canonical N/D of the half-angle-ring quotient f/g (g ≠ 0): lowest terms there, then
/// back to the field ([`from_half`]).
pub(crate) fn lowest_terms(f: &FieldInner, fn_: &Poly, gd: &Poly) -> (Poly, Poly) {
    let g = fn_.gcd(gd);
    if g.is_one() {
        from_half(f, fn_, gd)
    } else {
        from_half(f, &fn_.quot_rem(&g, false).0, &gd.quot_rem(&g, false).0)
    }
}

/// A field polynomial's half-angle image factored: f = content · ∏ pᵢ^eᵢ, with the degrees m.
pub(crate) struct HalfFactors {
    /// Integer content and sign, as a constant of the half-angle ring.
    pub content: Poly,
    /// Irreducible factors with positive leading coefficients, and multiplicities.
    pub primes: Vec<HalfPrime>,
    /// p = f/∏(1 + t_a²)^(m_a).
    pub m: Vec<usize>,
}

/// An irreducible factor of a half-angle image, with its multiplicity and its field form.
#[derive(Clone)]
pub(crate) struct HalfPrime {
    /// The prime p of the half-angle ring (positive leading coefficient).
    pub image: Poly,
    /// Its multiplicity.
    pub exp: u32,
    /// k_a = ⌈deg_{t_a} p / 2⌉ per angle.
    pub k: Vec<usize>,
    /// 2^k·p/∏(1 + t_a²)^(k_a) as a field polynomial ([`to_field`]): the value of p/∏h^k
    /// times 2^Σk.
    pub form: Poly,
    /// The form's primitive part and integer content (a constant): form = content·primitive.
    /// Divisions go by the primitive part, which divides over the integers wherever it
    /// divides over the rationals (Gauss's lemma).
    pub primitive: Poly,
    pub content: Poly,
}

impl HalfPrime {
    fn new(f: &FieldInner, image: Poly, exp: u32) -> HalfPrime {
        let k: Vec<usize> = f
            .half
            .t
            .iter()
            .map(|&t| (image.degree(t) as usize).div_ceil(2))
            .collect();
        let form = to_field(f, &image, &k);
        let content = f.constant(form.content());
        let primitive = form.quot_rem(&content, false).0;
        HalfPrime {
            image,
            exp,
            k,
            form,
            primitive,
            content,
        }
    }
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
            primes.push(HalfPrime::new(f, -q, e as u32));
        } else {
            primes.push(HalfPrime::new(f, q, e as u32));
        }
    }
    HalfFactors { content, primes, m }
}

/// num / (c · ∏ bᵢ^eᵢ) in canonical form, given the factorisations of the bᵢ: trial division
/// of the numerator's image by the known prime factors of the denominator's, instead of a gcd;
/// with the half-angle factorisation of the resulting denominator (for printing it factored
/// without factoring it again).
///
/// The way back to the field goes through [`Preimage`]s where it can: the numerator is `num`
/// divided by the field forms of the primes that cancelled, the denominator the product of the
/// field forms of its primes, each times powers of 1 + cos u. [`to_field`] of the whole image
/// (which expands every t^j into powers of 1 ∓ cos u) is the fallback.
pub(crate) fn canonical_over_factored(
    f: &FieldInner,
    num: &Poly,
    c: &Poly,
    dens: &[(&HalfFactors, u32)],
) -> (Poly, Poly, HalfFactors) {
    canonical_over_impl(f, num, c, dens, true)
}

/// [`canonical_over_factored`]; `preimages: false` maps back by [`to_field`] only (the
/// reference the fast path is tested against).
pub(crate) fn canonical_over_impl(
    f: &FieldInner,
    num: &Poly,
    c: &Poly,
    dens: &[(&HalfFactors, u32)],
    preimages: bool,
) -> (Poly, Poly, HalfFactors) {
    let hr = &f.half;
    let one = hr.zero.one();
    let mn = angle_degrees(f, num);
    // Denominator: c' · ∏ p^E · ∏ h_a^H (H may be negative: h_a then moves to the numerator).
    let mut cden = hr.zero.constant(c.lcoeff());
    let mut primes: Vec<(HalfPrime, i64)> = Vec::new();
    let mut hexp: Vec<i64> = mn.iter().map(|&m| m as i64).collect();
    let hs: Vec<Poly> = (0..f.angles.len()).map(|a| hr.h(a)).collect();
    for (hf, e) in dens {
        let e = *e as usize;
        cden = &cden * &pow(&hf.content, e, &one);
        for (a, &m) in hf.m.iter().enumerate() {
            hexp[a] -= (m * e) as i64;
        }
        for prime in &hf.primes {
            let k = (prime.exp as usize * e) as i64;
            if let Some(a) = hs.iter().position(|h| *h == prime.image) {
                hexp[a] += k;
            } else if let Some(slot) = primes.iter_mut().find(|(q, _)| q.image == prime.image) {
                slot.1 += k;
            } else {
                primes.push((prime.clone(), k));
            }
        }
    }
    let mut extra = vec![0usize; hs.len()];
    for (a, h) in hs.iter().enumerate() {
        if hexp[a] < 0 {
            extra[a] = (-hexp[a]) as usize;
        } else {
            primes.push((HalfPrime::new(f, h.clone(), 1), hexp[a]));
        }
    }
    let point = crate::screen::Point::new(f);
    let mut state = Numerator::new(f, num, &mn, &extra, &point, preimages);
    for (p, k) in &mut primes {
        while *k > 0 && state.divide(f, p, &point) {
            *k -= 1;
        }
    }
    let (num, d, ks) = back_to_field(f, state, &cden, &primes);
    let hf = denominator_factors(f, &d, &ks, &hs, cden, &primes);
    (num, d, hf)
}

/// Per angle, the total degree of a field polynomial in (sin u, cos u).
fn angle_degrees(f: &FieldInner, p: &Poly) -> Vec<usize> {
    f.angles
        .iter()
        .map(|av| {
            p.into_iter()
                .map(|t| (t.exponents[av.sin] + t.exponents[av.cos]) as usize)
                .max()
                .unwrap_or(0)
        })
        .collect()
}

/// The numerator during trial division. While it is known as a field polynomial N, its image
/// is N·∏h^extra up to a power of 2, and divisibility is first screened by evaluation
/// ([`crate::screen`]): most trial divisions fail, and this way neither they nor the expansion
/// of N in t are done. A prime that the screen cannot rule out is divided in the field when
/// its field form divides N as plain polynomials and the degrees show that the quotient is an
/// image again; otherwise the image is formed and divided exactly, its preimage kept while
/// plain division follows it.
enum Numerator<'a> {
    Field {
        image: crate::screen::FieldImage<'a>,
        /// The value of n/∏h^(m + extra) is N·scale.
        scale: Scale,
    },
    /// The image is n·scale.
    Image {
        n: Poly,
        scale: Scale,
        pre: Option<Preimage>,
    },
}

impl<'a> Numerator<'a> {
    fn new(
        f: &'a FieldInner,
        num: &Poly,
        mn: &[usize],
        extra: &[usize],
        point: &'a crate::screen::Point,
        preimages: bool,
    ) -> Numerator<'a> {
        let image = crate::screen::FieldImage::new(f, num.clone(), mn, extra, point);
        match image {
            Some(image) if preimages => Numerator::Field {
                image,
                scale: Scale::one(f),
            },
            _ => {
                let mut pre = Preimage::of(f, num, mn);
                pre.m
                    .iter_mut()
                    .zip(extra)
                    .for_each(|(m, e)| *m += *e as i64);
                Numerator::Image {
                    n: image_of(f, num, extra),
                    scale: Scale::one(f),
                    pre: preimages.then_some(pre),
                }
            }
        }
    }

    /// Divide by the prime `p` if it divides (exact); false when it does not.
    fn divide(
        &mut self,
        f: &'a FieldInner,
        p: &HalfPrime,
        point: &'a crate::screen::Point,
    ) -> bool {
        if let Numerator::Field { image, scale } = self {
            if !image.may_be_divided_by(&p.image) {
                return false;
            }
            if let Some(next) = Self::divide_in_field(f, image, scale, p, point) {
                *self = next;
                return true;
            }
            let pre = Self::preimage(image, scale.clone());
            *self = Numerator::Image {
                n: image_of(f, &image.n, &image.extra),
                scale: scale.clone(),
                pre: Some(pre),
            };
        }
        let Numerator::Image { n, pre, .. } = self else {
            unreachable!("the image was formed above")
        };
        let (q, r) = n.quot_rem(&p.image, false);
        if !r.is_zero() {
            return false;
        }
        *n = q;
        *pre = pre.take().and_then(|x| x.divide(p));
        true
    }

    /// N = F_p·Q as plain polynomials, with deg Q ≤ m + extra − k_p in every angle: then
    /// n/p = Q·∏h^(m + extra − k_p) up to a power of 2 is a polynomial (p is primitive), so p
    /// divides n.
    fn divide_in_field(
        f: &'a FieldInner,
        image: &crate::screen::FieldImage<'a>,
        scale: &Scale,
        p: &HalfPrime,
        point: &'a crate::screen::Point,
    ) -> Option<Numerator<'a>> {
        let (q, r) = image.n.quot_rem(&p.primitive, false);
        if !r.is_zero() {
            return None;
        }
        let dq = angle_degrees(f, &q);
        let mut extra = Vec::with_capacity(dq.len());
        for (a, d) in dq.iter().enumerate() {
            let room = (image.m[a] + image.extra[a]).checked_sub(p.k[a])?;
            extra.push(room.checked_sub(*d)?);
        }
        let image = crate::screen::FieldImage::new(f, q, &dq, &extra, point)?;
        Some(Numerator::Field {
            image,
            scale: scale.divided_by(p),
        })
    }

    fn preimage(image: &crate::screen::FieldImage<'a>, scale: Scale) -> Preimage {
        Preimage {
            p: image.n.clone(),
            m: image
                .m
                .iter()
                .zip(&image.extra)
                .map(|(m, e)| (m + e) as i64)
                .collect(),
            scale,
        }
    }

    /// The degree of the image in each t.
    fn t_degrees(&self, f: &FieldInner) -> Vec<usize> {
        match self {
            Numerator::Field { image, .. } => {
                (0..f.angles.len()).map(|a| image.t_degree(a)).collect()
            }
            Numerator::Image { n, .. } => f.half.t.iter().map(|&t| n.degree(t) as usize).collect(),
        }
    }
}

/// The half-angle image of num · ∏ h_a^(extra_a).
fn image_of(f: &FieldInner, num: &Poly, extra: &[usize]) -> Poly {
    let one = f.half.zero.one();
    let (mut n, _) = to_half(f, num);
    for (a, &e) in extra.iter().enumerate() {
        if e > 0 {
            n = &n * &pow(&f.half.h(a), e, &one);
        }
    }
    n
}

/// The canonical N/D of n/(cden · ∏ p^k) (n the numerator's image), and the k_a of
/// [`from_half`].
fn back_to_field(
    f: &FieldInner,
    num: Numerator,
    cden: &Poly,
    primes: &[(HalfPrime, i64)],
) -> (Poly, Poly, Vec<usize>) {
    let den_degree: Vec<usize> = f
        .half
        .t
        .iter()
        .map(|&t| {
            primes
                .iter()
                .map(|(p, k)| p.image.degree(t) as usize * *k as usize)
                .sum()
        })
        .collect();
    let ks: Vec<usize> = num
        .t_degrees(f)
        .iter()
        .zip(&den_degree)
        .map(|(&n, &d)| n.max(d).div_ceil(2))
        .collect();
    let slow_den = || {
        let one = f.half.zero.one();
        let den = primes.iter().fold(cden.clone(), |acc, (p, k)| {
            &acc * &pow(&p.image, *k as usize, &one)
        });
        to_field(f, &den, &ks)
    };
    // The reference way: the whole image mapped back, its scale 2^e2/cont put on the
    // denominator as 1/(2^e2/cont).
    let slow = |n: Poly, scale: &Scale| {
        let two = pow(
            &f.constant(Integer::from(2)),
            scale.e2.unsigned_abs() as usize,
            &f.one(),
        );
        let (num, den) = (to_field(f, &n, &ks), &slow_den() * &scale.cont);
        if scale.e2 >= 0 {
            (&num * &two, den)
        } else {
            (num, &den * &two)
        }
    };
    let (num, den) = match num {
        Numerator::Field { image, scale } => {
            let pre = Numerator::preimage(&image, scale.clone());
            match pre.at(f, &ks) {
                Some(num) => (num, fast_den(f, cden, primes, &ks, &slow_den)),
                None => slow(image_of(f, &image.n, &image.extra), &scale),
            }
        }
        Numerator::Image { n, scale, pre } => match pre.and_then(|p| p.at(f, &ks)) {
            Some(num) => (num, fast_den(f, cden, primes, &ks, &slow_den)),
            None => slow(n, &scale),
        },
    };
    let (num, den) = finish(f, num, den);
    (num, den, ks)
}

/// to_field of the denominator's image from its primes' forms, or `slow`.
fn fast_den(
    f: &FieldInner,
    cden: &Poly,
    primes: &[(HalfPrime, i64)],
    ks: &[usize],
    slow: &dyn Fn() -> Poly,
) -> Poly {
    Preimage::of_denominator(f, cden, primes)
        .at(f, ks)
        .unwrap_or_else(slow)
}

/// The half-angle factorisation of the canonical denominator `d`, from the primes left in the
/// image of the denominator: the field denominator D = 2^k·den/∏h^k (up to content) has the
/// image D·∏h^(m_D), so den's primes with h's exponent moved by m_D − k.
fn denominator_factors(
    f: &FieldInner,
    d: &Poly,
    ks: &[usize],
    hs: &[Poly],
    cden: Poly,
    primes: &[(HalfPrime, i64)],
) -> HalfFactors {
    let m = angle_degrees(f, d);
    let mut out: Vec<HalfPrime> = Vec::new();
    for (a, h) in hs.iter().enumerate() {
        let k = primes
            .iter()
            .find(|(p, _)| p.image == *h)
            .map_or(0, |(_, k)| *k);
        let e = m[a] as i64 - ks[a] as i64 + k;
        if e > 0 {
            out.push(HalfPrime {
                exp: e as u32,
                ..HalfPrime::new(f, h.clone(), 1)
            });
        }
    }
    out.extend(
        primes
            .iter()
            .filter(|(p, k)| *k > 0 && !hs.contains(&p.image))
            .map(|(p, k)| HalfPrime {
                exp: *k as u32,
                ..p.clone()
            }),
    );
    HalfFactors {
        content: cden,
        primes: out,
        m,
    }
}

/// A rational constant 2^e2 / cont (cont a positive integer, as a constant polynomial).
#[derive(Clone)]
struct Scale {
    e2: i64,
    cont: Poly,
}

impl Scale {
    fn one(f: &FieldInner) -> Scale {
        Scale {
            e2: 0,
            cont: f.one(),
        }
    }

    /// The scale after dividing by the primitive part of `prime`'s form: the value of
    /// p/∏h^k is content·primitive/2^Σk.
    fn divided_by(&self, prime: &HalfPrime) -> Scale {
        Scale {
            e2: self.e2 + prime.k.iter().sum::<usize>() as i64,
            cont: &self.cont * &prime.content,
        }
    }
}

/// A field polynomial P standing for a half-angle image n: the value of n/∏h_a^(m_a) is
/// P·s, s a rational [`Scale`]. Since the value of 1/h_a is (1 + cos u_a)/2, [`to_field`]`(n,
/// k)`, which is 2^Σk times the value of n/∏h^k, equals P·s·2^Σm·∏(1 + cos u_a)^(k_a − m_a): a
/// product, or an exact division by powers of 1 + cos u_a (exact as plain polynomials, because
/// multiplying a reduced polynomial by one in cos u alone leaves it reduced).
struct Preimage {
    p: Poly,
    m: Vec<i64>,
    scale: Scale,
}

impl Preimage {
    /// The image n = to_half(p) with degrees m.
    fn of(f: &FieldInner, p: &Poly, m: &[usize]) -> Preimage {
        Preimage {
            p: p.clone(),
            m: m.iter().map(|&x| x as i64).collect(),
            scale: Scale::one(f),
        }
    }

    /// cden · ∏ p^k from the field forms of the primes.
    fn of_denominator(f: &FieldInner, cden: &Poly, primes: &[(HalfPrime, i64)]) -> Preimage {
        let mut out = Preimage {
            p: f.constant(cden.lcoeff()),
            m: vec![0; f.angles.len()],
            scale: Scale::one(f),
        };
        for (prime, k) in primes {
            for _ in 0..*k {
                out.p = f.reduce(&out.p * &prime.form);
                out.m
                    .iter_mut()
                    .zip(&prime.k)
                    .for_each(|(m, k)| *m += *k as i64);
                out.scale.e2 -= prime.k.iter().sum::<usize>() as i64;
            }
        }
        out
    }

    /// The preimage of n/p for a prime p that divides n: P / form(p), when that division is
    /// exact as plain polynomials (the ring of reduced polynomials is no UFD, so it may fail
    /// where the value divides: `None`, and the caller maps back by [`to_field`]).
    fn divide(self, prime: &HalfPrime) -> Option<Preimage> {
        let (q, r) = self.p.quot_rem(&prime.primitive, false);
        r.is_zero().then(|| Preimage {
            p: q,
            m: self
                .m
                .iter()
                .zip(&prime.k)
                .map(|(m, k)| m - *k as i64)
                .collect(),
            scale: self.scale.divided_by(prime),
        })
    }

    /// [`to_field`]`(n, ks)`; `None` if a division that the value makes exact is not (not
    /// expected; the caller then takes the general route).
    fn at(&self, f: &FieldInner, ks: &[usize]) -> Option<Poly> {
        let one = f.one();
        let mut p = self.p.clone();
        for (a, (&k, &m)) in ks.iter().zip(&self.m).enumerate() {
            let j = k as i64 - m;
            if j == 0 {
                continue;
            }
            let v = &one + &f.var_poly(f.angles[a].cos);
            let vj = pow(&v, j.unsigned_abs() as usize, &one);
            p = if j > 0 {
                &p * &vj
            } else {
                exact_quotient(&p, &vj)?
            };
        }
        let e = self.scale.e2 + self.m.iter().sum::<i64>();
        let two = pow(
            &f.constant(Integer::from(2)),
            e.unsigned_abs() as usize,
            &one,
        );
        if e >= 0 {
            exact_quotient(&(&p * &two), &self.scale.cont)
        } else {
            exact_quotient(&p, &(&two * &self.scale.cont))
        }
    }
}

/// p / d when d divides p as plain polynomials.
pub(crate) fn exact_quotient(p: &Poly, d: &Poly) -> Option<Poly> {
    let (q, r) = p.quot_rem(d, false);
    (r.is_zero() && &q * d == *p).then_some(q)
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
    for prime in &hf.primes {
        let (q, e) = (&prime.image, &prime.exp);
        if let Some(a) = hs.iter().position(|h| h == q) {
            budget[a] -= *e as i64;
            continue;
        }
        if degs(q).iter().all(|x| x % 2 == 0) {
            for (a, k) in prime.k.iter().enumerate() {
                budget[a] -= *k as i64 * *e as i64;
            }
            out.push((prime.form.clone(), *e));
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
