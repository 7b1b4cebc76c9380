//! What a scene asks for: `request = [...]` resolved against the model (everything when absent).

/// What a scene asks for (`request = [...]`; everything when absent).
#[derive(Clone, Debug)]
pub struct Request {
    /// Requested coordinates, by index.
    pub coordinates: Vec<usize>,
    /// η requested.
    pub eta: bool,
    /// The energy requested.
    pub energy: bool,
    /// The constraint residual α(q)q̇ requested.
    pub constraint_residual: bool,
    /// The scene's `[expressions]` requested, by index.
    pub expressions: Vec<usize>,
    /// Coordinates the requested expressions need (kept in the state, not written).
    pub needed: Vec<usize>,
}

impl Request {
    /// Everything (the default).
    pub fn everything(ell: usize, expressions: usize) -> Request {
        Request {
            coordinates: (0..ell).collect(),
            eta: true,
            energy: true,
            constraint_residual: true,
            expressions: (0..expressions).collect(),
            needed: Vec::new(),
        }
    }

    /// Parse the names of `request`: coordinates, `eta` (or `eta1`…, which all mean η: it is
    /// integrated whole), `energy`, `constraint_residual`, the names of the scene's
    /// `expressions`. Errors name the unknown entry and list the valid ones.
    pub fn parse(
        names: &[String],
        coordinates: &[String],
        sigma: usize,
        expressions: &[String],
    ) -> Result<Request, String> {
        let mut r = Request {
            coordinates: Vec::new(),
            eta: false,
            energy: false,
            constraint_residual: false,
            expressions: Vec::new(),
            needed: Vec::new(),
        };
        for n in names {
            if let Some(k) = coordinates.iter().position(|c| c == n) {
                if !r.coordinates.contains(&k) {
                    r.coordinates.push(k);
                }
            } else if n == "eta"
                || n.strip_prefix("eta")
                    .and_then(|i| i.parse::<usize>().ok())
                    .is_some_and(|i| (1..=sigma).contains(&i))
            {
                r.eta = true;
            } else if n == "energy" {
                r.energy = true;
            } else if n == "constraint_residual" {
                r.constraint_residual = true;
            } else if let Some(i) = expressions.iter().position(|e| e == n) {
                if !r.expressions.contains(&i) {
                    r.expressions.push(i);
                }
            } else {
                return Err(format!(
                    "`{n}` is not an output of this scene: use coordinates ({}), eta (or eta1..eta{}), energy, constraint_residual{}",
                    coordinates.join(", "),
                    sigma,
                    if expressions.is_empty() {
                        ", or a name defined in [expressions]".to_string()
                    } else {
                        format!(", or an expression ({})", expressions.join(", "))
                    }
                ));
            }
        }
        r.coordinates.sort_unstable();
        Ok(r)
    }
}
