//! Matrices over a field of expressions: products, exact inverse, determinant and rank.

use crate::CasError;
use crate::field::{Ex, Field, Poly};
use crate::manifold::Manifold;

/// A dense matrix of expressions, row-major.
#[derive(Clone, PartialEq)]
pub struct Matrix {
    rows: usize,
    cols: usize,
    data: Vec<Ex>,
}

impl std::fmt::Debug for Matrix {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "Matrix {}x{} [", self.rows, self.cols)?;
        for i in 0..self.rows {
            let row: Vec<String> = (0..self.cols).map(|j| self[(i, j)].to_string()).collect();
            writeln!(f, "  [{}]", row.join(", "))?;
        }
        write!(f, "]")
    }
}

impl std::ops::Index<(usize, usize)> for Matrix {
    type Output = Ex;
    fn index(&self, (i, j): (usize, usize)) -> &Ex {
        &self.data[i * self.cols + j]
    }
}

impl std::ops::IndexMut<(usize, usize)> for Matrix {
    fn index_mut(&mut self, (i, j): (usize, usize)) -> &mut Ex {
        &mut self.data[i * self.cols + j]
    }
}

impl Matrix {
    /// Build entry by entry.
    pub fn from_fn(rows: usize, cols: usize, mut f: impl FnMut(usize, usize) -> Ex) -> Matrix {
        let mut data = Vec::with_capacity(rows * cols);
        for i in 0..rows {
            for j in 0..cols {
                data.push(f(i, j));
            }
        }
        Matrix { rows, cols, data }
    }

    /// Build entry by entry, stopping at the first error.
    pub fn try_from_fn<E>(
        rows: usize,
        cols: usize,
        mut f: impl FnMut(usize, usize) -> Result<Ex, E>,
    ) -> Result<Matrix, E> {
        let mut data = Vec::with_capacity(rows * cols);
        for i in 0..rows {
            for j in 0..cols {
                data.push(f(i, j)?);
            }
        }
        Ok(Matrix { rows, cols, data })
    }

    /// The zero matrix.
    pub fn zeros(field: &Field, rows: usize, cols: usize) -> Matrix {
        Matrix::from_fn(rows, cols, |_, _| field.zero())
    }

    /// The identity matrix.
    pub fn identity(field: &Field, n: usize) -> Matrix {
        Matrix::from_fn(n, n, |i, j| if i == j { field.one() } else { field.zero() })
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// The transpose.
    pub fn transpose(&self) -> Matrix {
        Matrix::from_fn(self.cols, self.rows, |i, j| self[(j, i)].clone())
    }

    /// Entrywise map.
    pub fn map(&self, mut f: impl FnMut(&Ex) -> Ex) -> Matrix {
        Matrix {
            rows: self.rows,
            cols: self.cols,
            data: self.data.iter().map(&mut f).collect(),
        }
    }

    /// Entrywise derivative with respect to coordinate `q_i`.
    pub fn diff(&self, i: usize) -> Matrix {
        self.map(|e| e.diff(i))
    }

    /// The product `self · other`.
    pub fn mul(&self, other: &Matrix) -> Matrix {
        assert_eq!(self.cols, other.rows, "matrix product dimensions");
        Matrix::from_fn(self.rows, other.cols, |i, j| {
            let mut acc: Option<Ex> = None;
            for k in 0..self.cols {
                let (a, b) = (&self[(i, k)], &other[(k, j)]);
                if a.is_zero() || b.is_zero() {
                    continue;
                }
                let t = a * b;
                acc = Some(match acc {
                    Some(s) => &s + &t,
                    None => t,
                });
            }
            acc.unwrap_or_else(|| self.data[0].field().zero())
        })
    }

    /// The sum.
    pub fn add(&self, other: &Matrix) -> Matrix {
        assert_eq!((self.rows, self.cols), (other.rows, other.cols));
        Matrix::from_fn(self.rows, self.cols, |i, j| &self[(i, j)] + &other[(i, j)])
    }

    /// The difference.
    pub fn sub(&self, other: &Matrix) -> Matrix {
        assert_eq!((self.rows, self.cols), (other.rows, other.cols));
        Matrix::from_fn(self.rows, self.cols, |i, j| &self[(i, j)] - &other[(i, j)])
    }

    /// Every entry times `s`.
    pub fn scale(&self, s: &Ex) -> Matrix {
        self.map(|e| e * s)
    }

    /// `self` stacked above `other`.
    pub fn vstack(&self, other: &Matrix) -> Matrix {
        assert_eq!(self.cols, other.cols);
        let mut data = self.data.clone();
        data.extend(other.data.iter().cloned());
        Matrix {
            rows: self.rows + other.rows,
            cols: self.cols,
            data,
        }
    }

    /// Columns `from..to`.
    pub fn columns(&self, from: usize, to: usize) -> Matrix {
        Matrix::from_fn(self.rows, to - from, |i, j| self[(i, from + j)].clone())
    }

    /// Rows `from..to`.
    pub fn row_range(&self, from: usize, to: usize) -> Matrix {
        Matrix::from_fn(to - from, self.cols, |i, j| self[(from + i, j)].clone())
    }

    /// Every entry is zero.
    pub fn is_zero(&self) -> bool {
        self.data.iter().all(Ex::is_zero)
    }

    /// Entries in row-major order.
    pub fn entries(&self) -> &[Ex] {
        &self.data
    }

    /// Gaussian elimination on a copy: returns (row echelon form, rank, determinant for square
    /// matrices). Pivots are chosen among the exactly-nonzero entries of the column, smallest
    /// first (the fewest terms), to keep intermediate expressions small; `pivotable` may refuse
    /// more (the entries that vanish on a constraint manifold). Stops with
    /// [`CasError::TooLarge`] when its work outgrows `budget` ([`Budget`]).
    fn eliminate(
        &self,
        augment: Option<&Matrix>,
        budget: &mut Budget,
        pivotable: &dyn Fn(&Ex) -> bool,
    ) -> Result<(Matrix, Option<Matrix>, usize, Ex), CasError> {
        let field = self.data[0].field();
        let mut a = self.clone();
        let mut b = augment.cloned();
        let mut det = field.one();
        // The determinant (a product of pivots) is formed for square matrices only.
        let square = a.rows == a.cols;
        let mut rank = 0;
        let mut row = 0;
        for col in 0..a.cols {
            if row == a.rows {
                break;
            }
            let pivot = (row..a.rows)
                .filter(|&r| !a[(r, col)].is_zero() && pivotable(&a[(r, col)]))
                .min_by_key(|&r| a[(r, col)].size());
            let Some(p) = pivot else {
                det = field.zero();
                continue;
            };
            if p != row {
                for j in 0..a.cols {
                    a.data.swap(p * a.cols + j, row * a.cols + j);
                }
                if let Some(b) = b.as_mut() {
                    for j in 0..b.cols {
                        b.data.swap(p * b.cols + j, row * b.cols + j);
                    }
                }
                det = -det;
            }
            let pv = a[(row, col)].clone();
            budget.progress(row, a.rows);
            if square {
                budget.charge(&det, &pv)?;
                det = &det * &pv;
            }
            let inv = pv.inv()?;
            for j in 0..a.cols {
                budget.charge(&a[(row, j)], &inv)?;
                a[(row, j)] = &a[(row, j)] * &inv;
            }
            if let Some(b) = b.as_mut() {
                for j in 0..b.cols {
                    budget.charge(&b[(row, j)], &inv)?;
                    b[(row, j)] = &b[(row, j)] * &inv;
                }
            }
            for r in 0..a.rows {
                if r == row || a[(r, col)].is_zero() {
                    continue;
                }
                let factor = a[(r, col)].clone();
                for j in 0..a.cols {
                    if !a[(row, j)].is_zero() {
                        a[(r, j)] = budget.update(&a[(r, j)], &factor, &a[(row, j)])?;
                    }
                }
                if let Some(b) = b.as_mut() {
                    for j in 0..b.cols {
                        if !b[(row, j)].is_zero() {
                            b[(r, j)] = budget.update(&b[(r, j)], &factor, &b[(row, j)])?;
                        }
                    }
                }
            }
            rank += 1;
            row += 1;
        }
        if a.rows != a.cols || rank < a.rows {
            det = field.zero();
        }
        Ok((a, b, rank, det))
    }

    /// The rank over the field of expressions (exact), or [`CasError::TooLarge`] past
    /// [`ELIMINATION_WORK`].
    pub fn rank(&self) -> Result<usize, CasError> {
        if self.data.is_empty() {
            return Ok(0);
        }
        let mut budget = Budget::new(&self.data[0].field(), ELIMINATION_WORK);
        Ok(self.eliminate(None, &mut budget, &|_| true)?.2)
    }

    /// The determinant of a square matrix (exact), or [`CasError::TooLarge`] past
    /// [`ELIMINATION_WORK`].
    pub fn det(&self) -> Result<Ex, CasError> {
        assert_eq!(self.rows, self.cols, "determinant of a non-square matrix");
        Ok(self
            .eliminate(
                None,
                &mut Budget::new(&self.data[0].field(), ELIMINATION_WORK),
                &|_| true,
            )?
            .3)
    }

    /// The inverse and the determinant of a square matrix; `None` when the determinant is
    /// identically zero; [`CasError::TooLarge`] when Gauss–Jordan outgrows
    /// [`ELIMINATION_WORK`].
    ///
    /// By fraction-free elimination in the half-angle ring ([`crate::bareiss`]); fields with
    /// square-root kernels by Gauss–Jordan in the field, each step in lowest terms.
    pub fn inverse(&self) -> Result<Option<(Matrix, Ex)>, CasError> {
        assert_eq!(self.rows, self.cols, "inverse of a non-square matrix");
        let field = self.data[0].field();
        let entries: Vec<(&Poly, &Poly)> = self.data.iter().map(|e| (&e.num, &e.den)).collect();
        if let Ok(result) = crate::bareiss::inverse(field.inner(), self.rows, &entries) {
            let ex = |(num, den): (Poly, Poly)| Ex {
                f: field.0.clone(),
                num,
                den,
            };
            return Ok(result.map(|(inv, det)| {
                let mut it = inv.into_iter();
                let m = Matrix::from_fn(self.rows, self.cols, |_, _| ex(it.next().expect("n²")));
                (m, ex(det))
            }));
        }
        self.gauss_jordan(&mut Budget::new(&field, ELIMINATION_WORK))
    }

    /// [`Matrix::inverse`] by Gauss–Jordan over the field, every step in lowest terms.
    pub(crate) fn inverse_gauss_jordan(&self) -> Result<Option<(Matrix, Ex)>, CasError> {
        self.gauss_jordan(&mut Budget::new(&self.data[0].field(), ELIMINATION_WORK))
    }

    /// Whether the row `row` (1×n) is a combination c·self of the rows of `self` (k×n),
    /// decided exactly: Gauss–Jordan on selfᵀ c = rowᵀ, consistent when every equation left
    /// after the k pivots has a remainder that is zero in normal form.
    pub fn combination(&self, row: &Matrix) -> Result<Combination, CasError> {
        self.combination_where(row, &|e: &Ex| e.is_zero())
    }

    /// [`Matrix::combination`] on the constraint manifold `m`: row = Σ_j c_j(q) self_j where
    /// m's constraint holds. Pivots are entries that do not vanish on m, so the c_j are
    /// defined on it; the remainders must vanish on m ([`Manifold::vanishes`]). `DependentRows`
    /// when the rows of `self` are dependent on m.
    pub fn combination_on(&self, row: &Matrix, m: &Manifold) -> Result<Combination, CasError> {
        self.combination_where(row, &|e: &Ex| m.vanishes(e))
    }

    fn combination_where(
        &self,
        row: &Matrix,
        zero: &dyn Fn(&Ex) -> bool,
    ) -> Result<Combination, CasError> {
        assert_eq!(
            (row.rows, row.cols),
            (1, self.cols),
            "a row of the same width"
        );
        if self.rows == 0 {
            return Ok(if row.data.iter().all(zero) {
                Combination::Of(Vec::new())
            } else {
                Combination::Not
            });
        }
        let field = self.data[0].field();
        let (_, rhs, rank, _) = self.transpose().eliminate(
            Some(&row.transpose()),
            &mut Budget::new(&field, ELIMINATION_WORK),
            &|e| !zero(e),
        )?;
        if rank < self.rows {
            return Ok(Combination::DependentRows(rank));
        }
        let rhs = rhs.expect("augmented");
        if (self.rows..self.cols).any(|r| !zero(&rhs[(r, 0)])) {
            return Ok(Combination::Not);
        }
        Ok(Combination::Of(
            (0..self.rows).map(|r| rhs[(r, 0)].clone()).collect(),
        ))
    }

    fn gauss_jordan(&self, budget: &mut Budget) -> Result<Option<(Matrix, Ex)>, CasError> {
        let field = self.data[0].field();
        let id = Matrix::identity(&field, self.rows);
        let (_, inv, rank, det) = self.eliminate(Some(&id), budget, &|_| true)?;
        if rank < self.rows {
            return Ok(None);
        }
        Ok(Some((inv.expect("augmented"), det)))
    }
}

/// Whether a row is a combination of others ([`Matrix::combination`]).
#[derive(Debug)]
pub enum Combination {
    /// row = Σ_j c_j row_j with these c_j, exactly.
    Of(Vec<Ex>),
    /// Not a combination: a remainder is not zero.
    Not,
    /// The rows it was to combine are not independent (their rank).
    DependentRows(usize),
}

/// The default budget of exact elimination in the field, in units of [`Budget`]: far above
/// what the bundled models' eliminations use (at most a few thousand units).
pub const ELIMINATION_WORK: usize = 2_000_000;

/// The largest single product an elimination forms, size(x)·size(y): 10⁴, products of two
/// 100-term expressions. In a field with a square-root kernel, lowest terms of larger ones
/// cost seconds each: the bicycle's dependent block (entries of 126 terms with the front
/// contact's kernel) spent 94 s on 12 products of about 1.6·10⁴ units
/// (docs/design/bicycle-derivation-speed.md).
pub const ELIMINATION_PRODUCT: usize = 10_000;

/// The charge per unit in a field with square-root kernels. Measured on the bicycle: about
/// 0.4 ms per unit there, against microseconds without kernels; with this weight its first
/// product of a 126-term entry stops the elimination.
pub const KERNEL_WEIGHT: usize = 100;

/// The work of an exact elimination, counted deterministically as Σ size(x)·size(y) over the
/// products it forms (sizes in terms of numerator and denominator): the cost of a product, and
/// of the gcd that brings it to lowest terms, grows with it. Past the limit, or before one
/// product larger than [`ELIMINATION_PRODUCT`], the elimination stops with
/// [`CasError::TooLarge`], so the caller can decide another way (a certified evaluation, a
/// structured form) instead of waiting.
pub struct Budget {
    limit: usize,
    weight: usize,
    work: usize,
    started: std::time::Instant,
}

impl Budget {
    /// A budget of `limit` units for elimination in `field`. In a field with square-root
    /// kernels every product is charged [`KERNEL_WEIGHT`] times: lowest terms there take gcds
    /// in an algebraic extension.
    pub fn new(field: &Field, limit: usize) -> Budget {
        let fi = field.inner();
        let kernels = fi
            .relations
            .borrow()
            .iter()
            .any(|(v, _)| fi.kernel_var.contains(v));
        Budget {
            limit,
            weight: if kernels { KERNEL_WEIGHT } else { 1 },
            work: 0,
            started: std::time::Instant::now(),
        }
    }

    fn charge(&mut self, x: &Ex, y: &Ex) -> Result<(), CasError> {
        let product = x
            .size()
            .saturating_mul(y.size())
            .saturating_mul(self.weight);
        self.work = self.work.saturating_add(product);
        if self.work > self.limit || product > ELIMINATION_PRODUCT {
            log::debug!(
                "elimination stopped after {:.3} s: work {} > {}",
                self.started.elapsed().as_secs_f64(),
                self.work,
                self.limit
            );
            return Err(CasError::TooLarge(self.limit));
        }
        Ok(())
    }

    /// target − factor·entry, charged.
    fn update(&mut self, target: &Ex, factor: &Ex, entry: &Ex) -> Result<Ex, CasError> {
        self.charge(factor, entry)?;
        let product = factor * entry;
        self.charge(target, &product)?;
        Ok(target - &product)
    }

    fn progress(&self, row: usize, rows: usize) {
        log::debug!(
            "elimination: pivot {} of {rows}, work {} after {:.3} s",
            row + 1,
            self.work,
            self.started.elapsed().as_secs_f64()
        );
    }
}
