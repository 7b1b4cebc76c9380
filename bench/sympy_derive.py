#!/usr/bin/env python3
"""SymPy baseline of hamel's Boltzmann–Hamel derivation, for `hamel bench --sympy`.

    python3 bench/sympy_derive.py MODEL.toml [ETA] [--simplify] [--eta-rows JSON] [--timeout SECONDS] [--check STATE_JSON]

Reproduces hamel's algorithm (crates/hamel-derive/src/symbolic.rs): A = Hessian of T in the
velocities (or the mass matrix), α and Z = Jacobians of the constraints and of η in the
velocities, M = [Z; α], δ = det M, [Γ Θ] = M⁻¹, A_Γ = ΓᵀAΓ, forcing Γᵀ∇U, the true Q, the
paper's Q and the correction Q_corr; then checks exactly Q = Q_paper + Q_corr and energy
conservation ηᵀQ(η) − ½ Σ_k (Γη)_k ηᵀ ∂A_Γ/∂q_k η ≡ 0. Free functions of the quasi-velocities
(`z13(phi)`) are SymPy undefined functions; their derivatives appear through differentiation.

Prints one JSON line: {"model", "eta", "seconds", "split_identity", "energy_conserved",
"status": "ok" | "timeout"}; "seconds" is the wall time of the derivation and the checks
(import of SymPy, TOML reading and parsing of the expressions excluded). With --check, prints
{"eta_dot": [...], "eta_dot_paper": [...]} at the state(s) of a `hamel eval` state file instead.

Canonical simplification (one method, the same for every model):
  * at parse time sin(q), cos(q) of a coordinate q become symbols s_q, c_q (tan(q) = s_q/c_q),
    so every expression is a rational function of q, s_q, c_q, parameters, free functions (and
    the odd sqrt/exp/log kept as SymPy atoms); ∂/∂q is the chain rule
    ∂e/∂q + c_q ∂e/∂s_q − s_q ∂e/∂c_q;
  * `canon`, applied after every matrix product, derivative and final sum, is
    sp.together → numerator and denominator as sp.Poly → remainder modulo c_q² + s_q² − 1
    (division by a monic polynomial in c_q, so a unique normal form) → gcd cancellation
    (Poly.cancel, what sp.cancel does);
  * an expression is zero iff the canonical form of its numerator is 0 (exact).
With --simplify, the way a SymPy user simplifies instead: sin and cos stay functions, and `canon`
is `sp.simplify` (zero tests: `sp.simplify(e) == 0`, derivatives `sp.diff`), applied at the same
places. "a_gamma_chars" in the JSON is the total length of A_Γ's entries as SymPy prints them
(`str`, with sin(q) and cos(q) written out), the size measure `hamel derive --format json` reports.
Exit status: 0 (also on timeout, reported in the JSON), 2 bad usage or model, 3 SymPy missing.
"""
import argparse
import json
import re
import signal
import sys
import time
import tomllib

try:
    import sympy as sp
except ImportError:
    print("sympy_derive.py: SymPy is not installed (optional benchmark dependency): "
          "pip install sympy", file=sys.stderr)
    sys.exit(3)

BUILTINS = {"sqrt": sp.sqrt, "exp": sp.exp, "log": sp.log}


def fail(message):
    """A bad invocation or model: message on stderr, exit status 2."""
    print(f"sympy_derive.py: {message}", file=sys.stderr)
    sys.exit(2)


class Timeout(BaseException):
    """Raised by the alarm; a BaseException so that SymPy's `except Exception` cannot eat it."""


# ---------------------------------------------------------------------------------------------
# Model parsing: the model expression syntax -> SymPy.
class Model:
    def __init__(self, path, eta_name, trig_symbols=True, eta_rows=None):
        self.trig_symbols = trig_symbols
        with open(path, "rb") as fh:
            raw = tomllib.load(fh)
        self.name = raw["name"]
        self.coords = raw["coordinates"]
        self.params = {k: sp.Rational(str(v)) for k, v in raw.get("parameters", {}).items()}
        self.q = [sp.Symbol(c) for c in self.coords]
        self.qd = [sp.Symbol("qd_" + c) for c in self.coords]
        self.s = {q: sp.Symbol("s_" + q.name) for q in self.q}     # sin(q)
        self.c = {q: sp.Symbol("c_" + q.name) for q in self.q}     # cos(q)
        self.p = {k: sp.Symbol(k) for k in self.params}
        self.functions = {}                                        # free functions by name
        lag = raw["lagrangian"]
        if "kinetic" in lag:
            self.kinetic, self.mass = self.parse(lag["kinetic"]), None
        else:
            self.kinetic, self.mass = None, [[self.parse(e) for e in row] for row in lag["mass_matrix"]]
        self.potential = self.parse(lag.get("potential", "0"))
        self.constraints = [self.parse(e) for e in raw.get("constraints", {}).values()]
        choices = raw.get("quasi_velocities", {})
        if not choices and not self.constraints:
            choices = {"identity": {"eta": ["der(%s)" % c for c in self.coords]}}
        if eta_rows is not None:                   # a choice hamel made (its default choice)
            choices = {eta_name or "given": {"eta": eta_rows}}
        self.eta_name = eta_name or next(iter(choices), None)
        if self.eta_name not in choices:
            fail(f"{self.name} has no quasi-velocity choice `{self.eta_name}` "
                 f"(choices: {', '.join(choices)})")
        self.eta = [self.parse(e) for e in choices[self.eta_name]["eta"]]

    def _sin(self, x):
        return self.s[x] if x in self.s else sp.sin(x)

    def _cos(self, x):
        return self.c[x] if x in self.c else sp.cos(x)

    def parse(self, text, trig_symbols=None):
        """Translate `der(q)` -> qd_q, `^` -> `**`; numbers exact; sin/cos(q) -> s_q/c_q."""
        # sympify evaluates Python: only the model grammar's characters get that far (no
        # strings, attributes, lambdas or dunder names), whoever wrote the file.
        if re.search(r"[^\w\s+\-*/^().,]|__|\.\s*[A-Za-z_]", text):
            fail(f"`{text}` is not an expression of the model grammar")
        text = re.sub(r"der\s*\(\s*(\w+)\s*\)", r"qd_\1", text).replace("^", "**")
        ns = dict(BUILTINS)
        if trig_symbols is None:
            trig_symbols = self.trig_symbols
        if trig_symbols:
            ns.update(sin=self._sin, cos=self._cos, tan=lambda x: self._sin(x) / self._cos(x))
        else:
            ns.update(sin=sp.sin, cos=sp.cos, tan=sp.tan)
        ns.update({str(v): v for v in self.q + self.qd + list(self.p.values())})
        for name, call in re.findall(r"(?<![\w.])([A-Za-z_]\w*)\s*(\()?", text):
            if name in ns:
                continue
            if not call:
                fail(f"unknown name `{name}` in `{text}`")
            ns[name] = self.functions.setdefault(name, sp.Function(name))   # free function
        return sp.sympify(text, locals=ns, rational=True)


# ---------------------------------------------------------------------------------------------
# Canonical form and calculus.
class Algebra:
    def __init__(self, model):
        self.trig = [(model.c[q], model.s[q]) for q in model.q]
        self.s, self.c = model.s, model.c

    def canon(self, e):
        if e.is_number:
            return e
        num, den = sp.fraction(sp.together(e))
        try:
            (pn, pd), info = sp.parallel_poly_from_expr([num, den])
        except sp.PolificationFailed:              # both expand to numbers
            return sp.expand(num) / sp.expand(den)
        gens = info["gens"]
        for c, s in self.trig:                     # reduce modulo c_q² + s_q² − 1, c_q first
            if c not in gens:
                continue
            gens = (c,) + tuple(g for g in gens if g not in (c, s)) + (s,)
            ideal = sp.Poly(c**2 + s**2 - 1, *gens)
            pn, pd = (sp.Poly(p, *gens).rem(ideal) for p in (pn, pd))
        if pn.is_zero:
            return sp.S.Zero
        coeff, pn, pd = pn.cancel(pd)              # gcd cancellation, as sp.cancel
        return coeff * pn.as_expr() / pd.as_expr()

    def is_zero(self, e):
        e = self.canon(e)
        # a second pass sees sqrt(X)**2 -> X that SymPy applies when rebuilding the expression
        return e == 0 or self.canon(e) == 0

    def d(self, e, q):
        """∂e/∂q with sin(q), cos(q) carried as s_q, c_q."""
        s, c = self.s[q], self.c[q]
        return self.canon(sp.diff(e, q) + c * sp.diff(e, s) - s * sp.diff(e, c))

    def mat(self, m):
        return m.applyfunc(self.canon)

    def dmat(self, m, q):
        return m.applyfunc(lambda e: self.d(e, q))


class Simplify(Algebra):
    """sp.simplify at every place where Algebra brings an expression to its canonical form."""

    def canon(self, e):
        return e if e.is_number else sp.simplify(e)

    def is_zero(self, e):
        return sp.simplify(e) == 0

    def d(self, e, q):
        return self.canon(sp.diff(e, q))


def sym(m):
    """Symmetric part (M + Mᵀ)/2."""
    return (m + m.T) / 2


# ---------------------------------------------------------------------------------------------
# The derivation (hamel-derive/src/symbolic.rs, step by step).
def derive(model, simplify=False):
    al = Simplify(model) if simplify else Algebra(model)
    q, qd = model.q, model.qd
    ell = len(q)
    if model.mass is not None:
        A = al.mat(sp.Matrix(model.mass))
    else:
        A = al.mat(sp.hessian(model.kinetic, qd))
    alpha = al.mat(sp.Matrix([[sp.diff(c, v) for v in qd] for c in model.constraints])) \
        if model.constraints else sp.zeros(0, ell)
    Z = al.mat(sp.Matrix([[sp.diff(e, v) for v in qd] for e in model.eta]))
    mu, sigma = alpha.rows, Z.rows
    M = Z.col_join(alpha)
    delta = al.canon(M.det(method="berkowitz"))
    if delta == 0:
        fail("det[Z; alpha] is identically zero")
    Minv = M.adjugate(method="berkowitz").applyfunc(lambda e: al.canon(e / delta))
    G, Th = Minv[:, :sigma], Minv[:, sigma:]
    Gt = G.T
    moves = [any(G[k, s] != 0 for s in range(sigma)) for k in range(ell)]

    B = al.mat(A * G)                                  # AΓ
    AG = al.mat(Gt * B)                                # A_Γ = ΓᵀAΓ
    gradU = sp.Matrix([al.d(model.potential, qk) for qk in q])
    forcing = al.mat(Gt * gradU)

    # True Q: sym[ Σ_k (Γᵀ ∂(AΓ)/∂q_k)_ir γ_ks − ½ Σ_j γ_ji (Γᵀ ∂A/∂q_j Γ)_rs ].
    T1 = [sp.zeros(sigma, sigma) for _ in range(sigma)]
    for k in (k for k in range(ell) if moves[k]):
        g = al.mat(Gt * al.dmat(B, q[k]))
        for i in range(sigma):
            T1[i] += sp.Matrix(sigma, sigma, lambda r, s: g[i, r] * G[k, s])
        h = al.mat(Gt * al.mat(al.dmat(A, q[k]) * G))
        for i in range(sigma):
            T1[i] -= G[k, i] / 2 * h
    Q = [al.mat(sym(t)) for t in T1]

    # The paper's Q: sym[ Σ_j b_jr (Γᵀ C_j Γ)_is + Σ_h γ_hs ∂b_ri/∂q_h − ½ Σ_h γ_hi ∂b_rs/∂q_h ].
    dAG = [al.dmat(AG, q[h]) if moves[h] else sp.zeros(sigma, sigma) for h in range(ell)]
    dZ = [al.dmat(Z, qk) for qk in q]
    T2 = [sp.zeros(sigma, sigma) for _ in range(sigma)]
    for j in range(sigma):
        C = sp.Matrix(ell, ell, lambda h, k: dZ[k][j, h] - dZ[h][j, k])
        if C.is_zero_matrix:
            continue
        P = al.mat(Gt * al.mat(C * G))
        for i in range(sigma):
            T2[i] += sp.Matrix(sigma, sigma, lambda r, s: AG[j, r] * P[i, s])
    for h in (h for h in range(ell) if moves[h]):
        for i in range(sigma):
            T2[i] += sp.Matrix(sigma, sigma, lambda r, s:
                               G[h, s] * dAG[h][r, i] - G[h, i] * dAG[h][r, s] / 2)
    Qp = [al.mat(sym(t)) for t in T2]

    # The correction: sym[ Σ_m N_mr (Γᵀ V_m Γ)_is ], N = ΘᵀAΓ.
    N = al.mat(Th.T * B)
    dal = [al.dmat(alpha, qk) for qk in q]
    T3 = [sp.zeros(sigma, sigma) for _ in range(sigma)]
    for m in range(mu):
        V = sp.Matrix(ell, ell, lambda h, k: dal[k][m, h] - dal[h][m, k])
        if V.is_zero_matrix:
            continue
        R = al.mat(Gt * al.mat(V * G))
        for i in range(sigma):
            T3[i] += sp.Matrix(sigma, sigma, lambda r, s: N[m, r] * R[i, s])
    Qc = [al.mat(sym(t)) for t in T3]

    # Exact checks.
    split = all(al.is_zero(Q[i][r, s] - Qp[i][r, s] - Qc[i][r, s])
                for i in range(sigma) for r in range(sigma) for s in range(sigma))
    eta = sp.Matrix(sp.symbols(f"eta1:{sigma + 1}"))
    quad = lambda m: (eta.T * m * eta)[0, 0]
    Geta = G * eta
    rate = sum(eta[i] * quad(Q[i]) for i in range(sigma)) \
        - sum(Geta[k] * quad(dAG[k]) for k in range(ell) if moves[k]) / 2
    energy = al.is_zero(rate)
    return dict(A_Gamma=AG, forcing=forcing, Q=Q, Q_paper=Qp, Q_corr=Qc, eta=eta,
                split_identity=split, energy_conserved=energy)


# ---------------------------------------------------------------------------------------------
# --check: η̇ at states, from the derived Q's, to compare with `hamel eval`.
def check(model, d, state):
    import mpmath
    mpmath.mp.dps = 30
    f = lambda v: sp.Float(v, 30)
    vals = {model.p[k]: f(state.get("params", {}).get(k, v)) for k, v in model.params.items()}
    for qk in model.q:
        v = f(state["q"][qk.name])
        vals.update({qk: v, model.s[qk]: sp.sin(v), model.c[qk]: sp.cos(v)})
    vals.update(zip(d["eta"], [f(v) for v in state["eta"]]))
    defs = {}
    for name, fn in model.functions.items():
        if name not in state.get("functions", {}):
            fail(f"give the free function `{name}` under \"functions\"")
        args = next(a.args for e in model.eta for a in e.atoms(sp.core.function.AppliedUndef)
                    if a.func == fn)
        defs[fn] = sp.Lambda(args, model.parse(state["functions"][name], trig_symbols=False))

    def num(e):
        for fn, lam in defs.items():
            e = e.replace(fn, lam)
        return mpmath.mpf(sp.N(e.doit().xreplace(vals), 30))

    eta = d["eta"]
    ag = mpmath.matrix([[num(e) for e in row] for row in d["A_Gamma"].tolist()])
    forcing = [num(e) for e in d["forcing"]]

    def solve(Q):
        rhs = mpmath.matrix([forcing[i] - num((eta.T * Q[i] * eta)[0, 0]) for i in range(len(Q))])
        return [float(x) for x in mpmath.lu_solve(ag, rhs)]
    return {"eta_dot": solve(d["Q"]), "eta_dot_paper": solve(d["Q_paper"])}


def a_gamma_chars(model, a_gamma):
    """Total length of A_Γ's entries printed by SymPy, sin(q) and cos(q) written out."""
    back = {model.s[q]: sp.sin(q) for q in model.q}
    back.update({model.c[q]: sp.cos(q) for q in model.q})
    return sum(len(str(e.xreplace(back))) for e in a_gamma)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model", help="model file (TOML)")
    ap.add_argument("eta", nargs="?", help="quasi-velocity choice (default: the first)")
    ap.add_argument("--timeout", type=float, help="give up after SECONDS of derivation")
    ap.add_argument("--check", metavar="STATE_JSON", help="print η̇ at the state(s) of this file")
    ap.add_argument("--simplify", action="store_true",
                    help="sp.simplify instead of the polynomial normal form")
    ap.add_argument("--eta-rows", metavar="JSON",
                    help="the quasi-velocities as a JSON list of expressions (for a choice hamel "
                         "made itself, such as the default `velocities` of a model without one)")
    args = ap.parse_args()
    rows = json.loads(args.eta_rows) if args.eta_rows else None
    model = Model(args.model, args.eta, trig_symbols=not args.simplify, eta_rows=rows)

    def on_alarm(signum, frame):
        raise Timeout()
    if args.timeout:
        signal.signal(signal.SIGALRM, on_alarm)
        signal.setitimer(signal.ITIMER_REAL, args.timeout)
    start = time.perf_counter()
    try:
        d = derive(model, args.simplify)
        seconds = time.perf_counter() - start
        signal.setitimer(signal.ITIMER_REAL, 0)
    except Timeout:
        print(json.dumps({"model": model.name, "eta": model.eta_name, "seconds": args.timeout,
                          "split_identity": None, "energy_conserved": None,
                          "a_gamma_chars": None, "status": "timeout"}))
        return
    if args.check:
        with open(args.check) as fh:
            states = json.load(fh)
        out = [check(model, d, s) for s in states] if isinstance(states, list) \
            else check(model, d, states)
        print(json.dumps(out))
        return
    print(json.dumps({"model": model.name, "eta": model.eta_name, "seconds": round(seconds, 6),
                      "split_identity": d["split_identity"],
                      "energy_conserved": d["energy_conserved"],
                      "a_gamma_chars": a_gamma_chars(model, d["A_Gamma"]), "status": "ok"}))


if __name__ == "__main__":
    main()
