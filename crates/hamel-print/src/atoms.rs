//! The atoms of a printing form: parameters, coordinates, velocities, and functions of them.

use foldhash::HashMap;

use hamel_expr::Expr;

/// What an atom is, in the order a paper writes the factors of a product.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Kind {
    /// A parameter, or a function of parameters only (`sqrt(m)`).
    Parameter,
    /// A coordinate itself (`x`, `theta`).
    Coordinate,
    /// A function of coordinates (`sin(theta)`, `z13(phi)`).
    Function,
    /// A velocity or quasi-velocity (`der(x)`, `eta1`), or its rate.
    Velocity,
}

/// Which names are which: the model's parameters, coordinates and quasi-velocities.
#[derive(Clone, Debug, Default)]
pub struct Vocabulary {
    /// Parameter names, in the model's order.
    pub parameters: Vec<String>,
    /// Coordinate names, in the model's order.
    pub coordinates: Vec<String>,
    /// Names that are velocities although written as symbols (`eta1`, `eta1_dot`).
    pub velocities: Vec<String>,
}

/// One atom: an expression that a polynomial treats as a variable.
#[derive(Clone, Debug, PartialEq)]
pub struct Atom {
    /// The atom's expression (a symbol, `der(q)`, or a function call).
    pub expr: Expr,
    /// Its kind.
    pub kind: Kind,
    /// Its text, the key that identifies it.
    pub key: String,
    /// Its text in the model syntax as a factor of a product (`(x^(1/2))`) where that is not
    /// its key (a name or call is written as its key: `sin(theta)`).
    factor_text: Option<String>,
    /// Its LaTeX.
    pub(crate) latex: String,
    /// The [`width`](crate::width) of its LaTeX.
    pub(crate) latex_width: usize,
    /// The position of its name in the model (parameters, coordinates, velocities), for
    /// the printing order; `usize::MAX` for none.
    position: usize,
    /// Whether it is the rate of a quasi-velocity ([`Atoms::is_rate`]).
    rate: bool,
}

/// The atoms met so far, each with its index; the index order is the printing order (kind,
/// then the model's order of names, then text).
#[derive(Clone, Debug)]
pub struct Atoms {
    vocabulary: Vocabulary,
    list: Vec<Atom>,
    /// Text ↦ index.
    index: HashMap<String, usize>,
    /// Expression ↦ index, for the atoms met (what saves writing an atom's text at each of
    /// its occurrences; the text stays what identifies an atom).
    seen: HashMap<Expr, usize>,
    /// An exported atom's number ([`hamel_expr::Canonical::ids`]) ↦ index: the atoms of a
    /// derivation's entries are told apart by their numbers, their trees compared once.
    by_id: HashMap<u64, usize>,
    /// In how many terms of a sheet's entries each atom occurs (what ties between
    /// parameters are broken by when a coefficient is factored).
    weight: Vec<usize>,
    /// Each atom's place in the printing order ([`Atoms::order`]), kept as atoms are added:
    /// what sorting compares instead of the kinds, positions and texts.
    rank: Vec<u32>,
}

impl Atom {
    /// Its text in the model syntax as a factor of a product (`sin(theta)`, `(x^(1/2))`).
    pub(crate) fn text(&self) -> &str {
        self.factor_text.as_deref().unwrap_or(&self.key)
    }
}

impl Atoms {
    /// No atoms yet.
    pub fn new(vocabulary: Vocabulary) -> Atoms {
        Atoms {
            vocabulary,
            list: Vec::new(),
            // Room for a small model's atoms (growing a map rehashes it).
            index: HashMap::with_capacity_and_hasher(32, Default::default()),
            seen: HashMap::with_capacity_and_hasher(32, Default::default()),
            by_id: HashMap::with_capacity_and_hasher(32, Default::default()),
            weight: Vec::new(),
            rank: Vec::new(),
        }
    }

    /// The model's names.
    pub fn vocabulary(&self) -> &Vocabulary {
        &self.vocabulary
    }

    /// How many atoms there are.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// The atom with index `i`.
    pub fn get(&self, i: usize) -> &Atom {
        &self.list[i]
    }

    /// The index of the atom the exporter numbered `id`, whose tree is `expr`, added if new
    /// (an exported atom is met again by its number, so its tree is not kept for lookup).
    pub(crate) fn intern_numbered(&mut self, id: u64, expr: &Expr) -> usize {
        if let Some(&i) = self.by_id.get(&id) {
            return i;
        }
        let i = self.intern_by_key(expr);
        self.by_id.insert(id, i);
        i
    }

    /// The index of `expr`'s atom, added if new.
    pub fn intern(&mut self, expr: &Expr) -> usize {
        if let Some(&i) = self.seen.get(expr) {
            return i;
        }
        let i = self.intern_by_key(expr);
        self.seen.insert(expr.clone(), i);
        i
    }

    /// The index of the atom whose text is `expr`'s, added if new.
    fn intern_by_key(&mut self, expr: &Expr) -> usize {
        let key = expr.to_string();
        if let Some(&i) = self.index.get(&key) {
            return i;
        }
        let kind = self.kind_of(expr);
        let position = self.position_of(expr);
        self.index.insert(key.clone(), self.list.len());
        let rate = kind == Kind::Velocity && matches!(expr, Expr::Sym(n) if n.ends_with("_dot"));
        let latex = expr.to_latex();
        self.rank_new((kind, position, &key));
        self.list.push(Atom {
            expr: expr.clone(),
            kind,
            factor_text: (!simple(expr)).then(|| text_of(expr)),
            latex_width: crate::tex_width::width(&latex),
            latex,
            key,
            position,
            rate,
        });
        self.list.len() - 1
    }

    /// The kind of an atom's expression.
    fn kind_of(&self, expr: &Expr) -> Kind {
        let v = &self.vocabulary;
        match expr {
            Expr::Der(_) => Kind::Velocity,
            Expr::Sym(n) if v.velocities.contains(n) => Kind::Velocity,
            Expr::Sym(n) if v.coordinates.contains(n) => Kind::Coordinate,
            Expr::Sym(_) => Kind::Parameter,
            _ if self.mentions_state(expr) => Kind::Function,
            _ => Kind::Parameter,
        }
    }

    /// Whether `expr` mentions a coordinate, a velocity or a free function.
    fn mentions_state(&self, expr: &Expr) -> bool {
        let v = &self.vocabulary;
        let mut found = false;
        expr.visit(&mut |e| match e {
            Expr::Der(_) | Expr::Free { .. } => found = true,
            Expr::Sym(n) if v.coordinates.contains(n) || v.velocities.contains(n) => found = true,
            _ => {}
        });
        found
    }

    /// Whether atom `i` is the rate of a quasi-velocity (`etaN_dot`, a velocity of the
    /// vocabulary whose name ends in `_dot`).
    pub(crate) fn is_rate(&self, i: usize) -> bool {
        self.list[i].rate
    }

    /// Counts `n` more terms in which atom `i` occurs.
    pub(crate) fn weigh(&mut self, i: usize, n: usize) {
        if self.weight.len() <= i {
            self.weight.resize(i + 1, 0);
        }
        self.weight[i] += n;
    }

    /// In how many terms atom `i` occurs, as counted by [`Atoms::weigh`].
    pub(crate) fn weight(&self, i: usize) -> usize {
        self.weight.get(i).copied().unwrap_or(0)
    }

    /// The sort key of atom `i`: kind, position of its name in the model, text.
    pub fn order(&self, i: usize) -> (Kind, usize, &str) {
        let a = &self.list[i];
        (a.kind, a.position, &a.key)
    }

    /// Atom `i`'s place in the printing order: `rank(i) < rank(j)` exactly when
    /// `order(i) < order(j)` (distinct atoms have distinct texts).
    pub(crate) fn rank(&self, i: usize) -> u32 {
        self.rank[i]
    }

    /// Ranks the atom about to be added with sort key `order`: the atoms after it move up.
    fn rank_new(&mut self, order: (Kind, usize, &str)) {
        let before = (0..self.list.len())
            .filter(|&i| self.order(i) < order)
            .count();
        let r = u32::try_from(before).expect("fewer than 2^32 atoms");
        for x in &mut self.rank {
            if *x >= r {
                *x += 1;
            }
        }
        self.rank.push(r);
    }

    /// Where an atom's name stands in the model: a parameter, coordinate or velocity symbol,
    /// the velocity of a coordinate, or a function of one coordinate.
    fn position_of(&self, expr: &Expr) -> usize {
        let v = &self.vocabulary;
        let position = match expr {
            Expr::Sym(n) => v
                .parameters
                .iter()
                .chain(&v.coordinates)
                .chain(&v.velocities)
                .position(|p| p == n),
            Expr::Der(n) => v.coordinates.iter().position(|p| p == n),
            Expr::Call(_, arg) => match &**arg {
                Expr::Sym(n) => v.coordinates.iter().position(|p| p == n),
                _ => None,
            },
            _ => None,
        };
        position.unwrap_or(usize::MAX)
    }
}

/// Whether an expression is a name or a call, which a power follows without parentheses.
pub(crate) fn simple(e: &Expr) -> bool {
    matches!(
        e,
        Expr::Sym(_) | Expr::Der(_) | Expr::Call(..) | Expr::Atan2(..) | Expr::Free { .. }
    )
}

/// An atom's text as a factor of a product: a name or call as it is, a power of one with its
/// exponent, anything else in parentheses.
pub(crate) fn text_of(e: &Expr) -> String {
    match e {
        _ if simple(e) => e.to_string(),
        Expr::Pow(b, n) if simple(b) => format!("{b}^{n}"),
        _ => format!("({e})"),
    }
}
