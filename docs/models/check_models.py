#!/usr/bin/env python3
"""Re-derive the seed models from first principles and compare them with models/*.toml.

For every model the kinetic energy is rebuilt from the positions of the centres of mass
(velocities by differentiation) and from the angular velocities of the bodies, which are
obtained from their rotation matrices (skew part of R' R^T); U is rebuilt from the heights;
the constraints are rebuilt from the physical no-slip / rolling conditions. The script then
checks against the TOML file:

* T (or the mass matrix) is a homogeneous quadratic form and equals the derived one;
* U equals the derived one;
* each constraint is linear homogeneous in the velocities, alpha has full rank mu, and its
  row space equals the row space of the physical conditions;
* T is positive definite at the default parameters for random admissible configurations;
* each eta list has l - mu linear homogeneous entries and det[Z; alpha] is not identically 0;
* extra facts used in docs/models/*.md (conjugate momenta, the Chaplygin sleigh equations,
  the knife equations, the claims about the paper's formulas).

Needs only Python >= 3.11 and SymPy. Run:  python3 docs/models/check_models.py [-v]
"""

import random
import re
import sys
import tomllib
from pathlib import Path

import mpmath
import sympy as sp
from sympy.core.function import AppliedUndef
from sympy.parsing.sympy_parser import parse_expr, rationalize, standard_transformations

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
VERBOSE = "-v" in sys.argv
BUILTINS = {"sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "sqrt": sp.sqrt, "exp": sp.exp, "log": sp.log}
RNG = random.Random(20151111)
mpmath.mp.dps = 50
FAILURES = []


def check(cond, what):
    print(("  ok    " if cond else "  FAIL  ") + what)
    if not cond:
        FAILURES.append(what)


# ----------------------------------------------------------------------------------------------
# reading a model file
# ----------------------------------------------------------------------------------------------
class Model:
    def __init__(self, name):
        self.data = tomllib.loads((MODELS / f"{name}.toml").read_text())
        d = self.data
        assert d["name"] == name
        self.names = list(d["coordinates"])
        self.q = [sp.Symbol(n, real=True) for n in self.names]
        self.dq = [sp.Symbol("d_" + n, real=True) for n in self.names]
        self.params = {k: sp.Symbol(k, positive=True) for k in d.get("parameters", {})}
        self.defaults = {self.params[k]: sp.nsimplify(v, rational=True) for k, v in d.get("parameters", {}).items()}
        clash = set(self.params) & (set(self.names) | set(BUILTINS) | {"der"})
        assert not clash, clash
        self.P = self.params  # short alias
        lag = d["lagrangian"]
        if "kinetic" in lag:
            self.T = self.parse(lag["kinetic"])
            self.A = sp.hessian(self.T, self.dq)
        else:
            self.A = sp.Matrix([[self.parse(e) for e in row] for row in lag["mass_matrix"]])
            v = sp.Matrix(self.dq)
            self.T = sp.expand((v.T * self.A * v)[0] / 2)
        self.U = self.parse(lag.get("potential", "0"))
        self.cons = {k: self.parse(v) for k, v in d.get("constraints", {}).items()}
        self.alpha = sp.Matrix([[sp.diff(c, v) for v in self.dq] for c in self.cons.values()]) \
            if self.cons else sp.zeros(0, len(self.q))
        self.etas = {k: [self.parse(e, free_ok=True) for e in v["eta"]]
                     for k, v in d.get("quasi_velocities", {}).items()}

    def parse(self, text, free_ok=False):
        s = re.sub(r"der\(\s*([A-Za-z_][A-Za-z0-9_]*)\s*\)", r"d_\1", text).replace("^", "**")
        local = dict(BUILTINS)
        local.update({n: s_ for n, s_ in zip(self.names, self.q)})
        local.update({"d_" + n: s_ for n, s_ in zip(self.names, self.dq)})
        local.update(self.params)
        for f in set(re.findall(r"([A-Za-z_][A-Za-z0-9_]*)\s*\(", s)) - set(BUILTINS):
            assert free_ok, f"free function {f} outside eta: {text}"
            local[f] = sp.Function(f, real=True)
        e = parse_expr(s, local_dict=local, transformations=standard_transformations + (rationalize,))
        known = set(self.q) | set(self.dq) | set(self.params.values())
        assert e.free_symbols <= known, f"unknown names {e.free_symbols - known} in {text}"
        for f in e.atoms(AppliedUndef):
            assert all(a in self.q for a in f.args), f"free function {f} must take coordinates"
        return e

    def on_velocities(self, expr):
        """coefficient row of an expression that must be linear homogeneous in the velocities"""
        row = [sp.diff(expr, v) for v in self.dq]
        rest = sp.expand(expr - sum(c * v for c, v in zip(row, self.dq)))
        ok = rest == 0 and all(not (c.free_symbols & set(self.dq)) for c in row)
        return row, ok

    def random_point(self, funcs=()):
        """random admissible configuration (angles in (-1.2, 1.2)), default parameters, random
        values for the free functions"""
        pt = {q: sp.Rational(RNG.randint(-1200, 1200), 1000) for q in self.q}
        pt.update(self.defaults)
        fv = {f: sp.Rational(RNG.randint(300, 1700), 1000) * RNG.choice([-1, 1]) for f in funcs}
        return pt, fv


def nmat(M, pt, fv=None):
    if fv:
        M = M.subs(fv)
    return mpmath.matrix([[mpmath.mpf(sp.N(M[i, j].subs(pt), 50)) for j in range(M.cols)] for i in range(M.rows)])


def is_zero(expr, model=None):
    """symbolic zero test, with a numeric fallback at random points when simplify gives up"""
    e = sp.expand(expr)
    if e == 0:
        return True
    e = sp.simplify(sp.expand_trig(e))
    if e == 0:
        return True
    if model is None:
        return False
    for _ in range(6):
        pt, fv = model.random_point(e.atoms(AppliedUndef))
        pt.update({p: sp.Rational(RNG.randint(100, 3000), 1000) for p in model.params.values()})
        pt.update({v: sp.Rational(RNG.randint(-2000, 2000), 1000) for v in model.dq})
        pt.update({v: sp.Rational(RNG.randint(-2000, 2000), 1000) for v in e.free_symbols if v not in pt})
        if abs(sp.N(e.subs(fv).subs(pt), 40)) > 1e-30:
            return False
    return True


def matrices_equal(M1, M2, model):
    return all(is_zero(M1[i, j] - M2[i, j], model=model) for i in range(M1.rows) for j in range(M1.cols))


def gram_det(rows, pt):
    M = nmat(sp.Matrix(rows), pt)
    return mpmath.det(M * M.T)


# ----------------------------------------------------------------------------------------------
# kinematics from first principles
# ----------------------------------------------------------------------------------------------
def Rz(t):
    return sp.Matrix([[sp.cos(t), -sp.sin(t), 0], [sp.sin(t), sp.cos(t), 0], [0, 0, 1]])


def Rx(t):
    return sp.Matrix([[1, 0, 0], [0, sp.cos(t), -sp.sin(t)], [0, sp.sin(t), sp.cos(t)]])


def Ry(t):
    return sp.Matrix([[sp.cos(t), 0, sp.sin(t)], [0, 1, 0], [-sp.sin(t), 0, sp.cos(t)]])


def vel(r, m):
    """velocity of a point with position r(q)"""
    return r.jacobian(m.q) * sp.Matrix(m.dq)


def omega(Rm, m):
    """angular velocity (space frame) of a body with orientation Rm(q): skew part of R' R^T"""
    Rdot = sum((Rm.diff(q) * v for q, v in zip(m.q, m.dq)), sp.zeros(3, 3))
    W = (Rdot * Rm.T).applyfunc(lambda e: sp.trigsimp(sp.expand(e)))
    assert all(sp.simplify(W[i, j] + W[j, i]) == 0 for i in range(3) for j in range(3))
    return sp.Matrix([W[2, 1], W[0, 2], W[1, 0]])


def body_T(m, mass, r_G, Rm=None, I_body=None):
    """kinetic energy of a rigid body: centre of mass at r_G, orientation Rm, inertia I_body
    (about G, in body axes)"""
    vG = vel(r_G, m)
    T = mass * vG.dot(vG) / 2
    if Rm is not None:
        w = omega(Rm, m)
        wb = Rm.T * w
        T += (wb.T * I_body * wb)[0] / 2
    return sp.expand(T)


def rod_inertia(mass, length):
    """homogeneous thin rod along its body x-axis, about its centre"""
    return sp.diag(0, mass * length ** 2 / 12, mass * length ** 2 / 12)


def disk_inertia(mass, radius):
    """homogeneous disk with its axis along body y, about its centre"""
    return sp.diag(mass * radius ** 2 / 4, mass * radius ** 2 / 2, mass * radius ** 2 / 4)


def U_gravity(masses_heights, g):
    """potential of gravity -g k: force = +grad U, U = -g sum m z"""
    return -g * sum(mm * z for mm, z in masses_heights)


def compare_with_file(m, T_der, U_der, phys_rows):
    A_der = sp.hessian(T_der, m.dq)
    check(matrices_equal(m.A, A_der, m), "mass matrix A of the file = A derived from positions and angular velocities")
    lam = sp.Symbol("lam")
    check(sp.expand(m.T.subs({v: lam * v for v in m.dq}, simultaneous=True) - lam ** 2 * m.T) == 0,
          "T is homogeneous quadratic in the velocities")
    check(all(sp.simplify(m.A[i, j] - m.A[j, i]) == 0 for i in range(m.A.rows) for j in range(m.A.cols)),
          "A symmetric")
    check(not (m.A.free_symbols & set(m.dq)), "A free of velocities")
    check(is_zero(m.U - U_der, model=m), "U of the file = U derived from the heights")
    check(not (m.U.free_symbols & set(m.dq)), "U free of velocities")
    mu = len(m.cons)
    for name, c in m.cons.items():
        _, ok = m.on_velocities(c)
        check(ok, f"constraint {name} linear homogeneous in the velocities")
    # rank, row space and positive definiteness at random configurations
    full, inspan, pd = True, True, True
    for _ in range(4):
        pt, _ = m.random_point()
        if mu:
            g0 = gram_det(m.alpha.tolist(), pt)
            full = full and g0 > 1e-20
            for r in phys_rows:
                gd = gram_det(m.alpha.tolist() + [r], pt)
                inspan = inspan and abs(gd) < mpmath.mpf(10) ** -35 * (1 + abs(g0))
        try:
            mpmath.cholesky(nmat(m.A, pt))
        except (ZeroDivisionError, ValueError):
            pd = False
    if mu:
        check(full, f"alpha has full rank mu = {mu} at random configurations")
        check(inspan, "every physical no-slip/rolling condition lies in the row space of alpha")
    check(pd, "A positive definite at the default parameters, random admissible configurations")
    if mu:
        # physical conditions span the same space (rank of phys rows = mu)
        pt, _ = m.random_point()
        rows = phys_rows
        M = nmat(sp.Matrix(rows), pt)
        sv = mpmath.svd_r(M, compute_uv=False)
        rank = sum(1 for s in sv if s > 1e-30)
        check(rank == mu, f"physical conditions have rank {rank} = mu")
    # quasi-velocities
    l = len(m.q)
    for cname, etas in m.etas.items():
        check(len(etas) == l - mu, f"choice {cname}: {len(etas)} = l - mu = {l - mu} entries")
        Z = []
        for e in etas:
            row, ok = m.on_velocities(e)
            check(ok, f"choice {cname}: eta linear homogeneous in velocities")
            Z.append(row)
        M = sp.Matrix(Z + m.alpha.tolist())
        funcs = M.atoms(AppliedUndef)
        vals = []
        for _ in range(3):
            pt, fv = m.random_point(funcs)
            vals.append(abs(mpmath.det(nmat(M, pt, fv))))
        check(max(vals) > 1e-20, f"choice {cname}: det[Z; alpha] not identically zero")
        if VERBOSE:
            print(f"        det[Z; alpha] ({cname}) =", sp.factor(sp.trigsimp(sp.simplify(M.det()))))


# ----------------------------------------------------------------------------------------------
# Boltzmann-Hamel helpers (for the extra checks)
# ----------------------------------------------------------------------------------------------
def gamma_and_AG(m, choice):
    Z = sp.Matrix([m.on_velocities(e)[0] for e in m.etas[choice]])
    s = Z.rows
    M = sp.Matrix.vstack(Z, m.alpha)
    G = sp.simplify(M.inv()[:, :s])
    AG = (G.T * m.A * G).applyfunc(lambda e: sp.factor(sp.trigsimp(sp.simplify(e))))
    return Z, G, AG


def reduced_equations(m, choice):
    """solve Gamma^T (d/dt dL/dq' - dL/dq) = 0 with q' = Gamma eta for eta'"""
    Z, G, AG = gamma_and_AG(m, choice)
    s = Z.rows
    eta = sp.Matrix(sp.symbols(f"eta1:{s + 1}"))
    etad = sp.Matrix(sp.symbols(f"etad1:{s + 1}"))
    qd = G * eta
    qdd = G * etad + sum((G.diff(q) * eta * qd[k] for k, q in enumerate(m.q)), sp.zeros(len(m.q), 1))
    n = len(m.q)
    E = sp.Matrix(m.A * qdd)
    for i in range(n):
        E[i] += sum((sp.diff(m.A[i, j], m.q[k]) - sp.diff(m.A[j, k], m.q[i]) / 2) * qd[j] * qd[k]
                    for j in range(n) for k in range(n)) - sp.diff(m.U, m.q[i])
    eqs = G.T * E
    sol = sp.solve(list(eqs), list(etad), dict=True)[0]
    return {k: sp.simplify(v) for k, v in sol.items()}, eta, etad


# ----------------------------------------------------------------------------------------------
# the models
# ----------------------------------------------------------------------------------------------
ez = sp.Matrix([0, 0, 1])


def knife(name="knife"):
    m = Model(name)
    x, y, th = m.q
    mass, l = m.P["m"], m.P["l"]
    # in the plane: (x, y, 0); for the vertical knife the plane is vertical with y up
    T = body_T(m, mass, sp.Matrix([x, y, 0]), Rz(th), rod_inertia(mass, l))
    vP = vel(sp.Matrix([x, y, 0]), m)
    e = sp.Matrix([sp.cos(th), sp.sin(th), 0])
    lateral = vP.cross(e)[2]                   # v_P x e = 0
    U = 0 if name == "knife" else -mass * m.P["g"] * y
    compare_with_file(m, T, U, [m.on_velocities(lateral)[0]])
    sol, eta, etad = reduced_equations(m, "paper")
    if name == "knife":
        check(sol[etad[0]] == 0 and sol[etad[1]] == 0, "knife, paper choice: eta1' = eta2' = 0")
        _, _, AG = gamma_and_AG(m, "paper")
        check(AG == sp.diag(mass, mass * l ** 2 / 12), "knife, paper choice: A_Gamma = diag(m, m l^2/12)")
    else:
        g = m.P["g"]
        check(sp.simplify(sol[etad[0]] + g * sp.sin(th)) == 0 and sol[etad[1]] == 0,
              "vertical knife: eta1' = -g sin(theta), eta2' = 0 (y eliminated, theta not)")


def chaplygin_sleigh():
    m = Model("chaplygin_sleigh")
    x, y, th = m.q
    mass, I, a = m.P["m"], m.P["I"], m.P["a"]
    C = sp.Matrix([x, y, 0])
    e = sp.Matrix([sp.cos(th), sp.sin(th), 0])
    T = body_T(m, mass, C + a * e, Rz(th), sp.diag(0, 0, I))
    lateral = vel(C, m).cross(e)[2]
    compare_with_file(m, T, 0, [m.on_velocities(lateral)[0]])
    sol, eta, etad = reduced_equations(m, "paper_style")
    v, w = eta
    check(sp.simplify(sol[etad[0]] - a * w ** 2) == 0, "sleigh: v' = a omega^2  (m v' = m a omega^2)")
    check(sp.simplify(sol[etad[1]] + mass * a * v * w / (I + mass * a ** 2)) == 0,
          "sleigh: (I + m a^2) omega' = -m a v omega")


def snakeboard():
    m = Model("snakeboard")
    x, y, th, ps, ph = m.q
    mass, J, Jr, Jw, r = (m.P[k] for k in ("m", "J", "J_r", "J_w", "r"))
    P = sp.Matrix([x, y, 0])
    e = sp.Matrix([sp.cos(th), sp.sin(th), 0])
    # J is the board's with the wheel sets' own 2 J_w; the rotor and the wheel sets are massless
    # bodies turning about vertical axes (their masses are in m, at P).
    T = (body_T(m, mass, P, Rz(th), sp.diag(0, 0, J - 2 * Jw))
         + body_T(m, 0, P, Rz(th + ps), sp.diag(0, 0, Jr))
         + body_T(m, 0, P + r * e, Rz(th + ph), sp.diag(0, 0, Jw))
         + body_T(m, 0, P - r * e, Rz(th - ph), sp.diag(0, 0, Jw)))
    rows = []
    for sign, steer in ((1, ph), (-1, -ph)):
        heading = sp.Matrix([sp.cos(th + steer), sp.sin(th + steer), 0])
        rows.append(m.on_velocities(vel(P + sign * r * e, m).cross(heading)[2])[0])
    compare_with_file(m, T, 0, rows)


def bar_blade():
    m = Model("bar_blade")
    x, y, th, ph = m.q
    m_r, l_r, m_f, l_f = (m.P[k] for k in ("m_r", "l_r", "m_f", "l_f"))
    Pr = sp.Matrix([x, y, 0])
    e_th = sp.Matrix([sp.cos(th), sp.sin(th), 0])
    e_b = sp.Matrix([sp.cos(th + ph), sp.sin(th + ph), 0])
    Pf = Pr + l_r * e_th
    T = body_T(m, m_r, Pr + l_r / 2 * e_th, Rz(th), rod_inertia(m_r, l_r)) \
        + body_T(m, m_f, Pf, Rz(th + ph), rod_inertia(m_f, l_f))
    c1 = vel(Pr, m).cross(e_th)[2]           # (36) first
    c2 = vel(Pf, m).cross(e_b)[2]            # (36) second
    compare_with_file(m, T, 0, [m.on_velocities(c)[0] for c in (c1, c2)])
    # claims in docs/models/bar_blade.md
    I_f = m_f * l_f ** 2 / 12
    lam1 = (m_f + m_r / 2) * l_r
    lam2 = m_r * l_r ** 2 / 3 + m_f * l_r ** 2 + I_f
    A_claim = sp.Matrix([[m_r + m_f, 0, -lam1 * sp.sin(th), 0], [0, m_r + m_f, lam1 * sp.cos(th), 0],
                         [-lam1 * sp.sin(th), lam1 * sp.cos(th), lam2, I_f], [0, 0, I_f, I_f]])
    check(matrices_equal(m.A, A_claim, m), "bar_blade: A has lambda1 = (m_f + m_r/2) l_r, lambda2 = m_r l_r^2/3 + m_f l_r^2 + I_f")
    _, _, AG = gamma_and_AG(m, "paper_z13")
    z13 = sp.Function("z13", real=True)(ph)
    den = l_r * sp.cos(ph) + z13 * sp.sin(ph)
    mt = m_r + m_f
    check(is_zero(AG[0, 0] - (mt * l_r ** 2 * sp.cos(ph) ** 2 + lam2 * sp.sin(ph) ** 2) / den ** 2, model=m),
          "bar_blade: b11 = (m_tot l_r^2 cos^2 phi + lambda2 sin^2 phi)/(l_r cos phi + z13 sin phi)^2")
    check(is_zero(AG[0, 1] - I_f * sp.sin(ph) / den, model=m) and is_zero(AG[1, 1] - I_f, model=m),
          "bar_blade: b12 = I_f sin(phi)/(l_r cos phi + z13 sin phi) != 0, b22 = I_f (A_Gamma not diagonal)")
    if VERBOSE:
        print("        A_Gamma (paper_z13) =", AG)


def bar_wheels():
    m = Model("bar_wheels")
    x, y, th, p1, ph = m.q
    m_w, R, a, l_r, m_f, l_f = (m.P[k] for k in ("m_w", "R", "a", "l_r", "m_f", "l_f"))
    p2 = p1 - 2 * a * th / R                 # holonomic relation R (psi2 - psi1) + 2 a theta = 0
    Pr = sp.Matrix([x, y, 0])
    e_th = sp.Matrix([sp.cos(th), sp.sin(th), 0])
    e = sp.Matrix([sp.sin(th), -sp.cos(th), 0])   # axle direction, P2 - P1 = 2 a e
    e_b = sp.Matrix([sp.cos(th + ph), sp.sin(th + ph), 0])
    B = Pr + R * ez
    P1, P2 = B - a * e, B + a * e
    Pf = Pr + l_r * e_th
    # wheel i: body y along -e (Rz(theta) maps -y to e), spin psi_i about e: R = Rz(theta) Ry(-psi_i)
    RW1, RW2 = Rz(th) * Ry(-p1), Rz(th) * Ry(-p2)
    w1 = omega(RW1, m)
    check(all(sp.simplify(w1[i] - (m.dq[2] * ez + m.dq[3] * e)[i]) == 0 for i in range(3)),
          "bar_wheels: angular velocity of wheel 1 = theta' k + psi1' e (as in the paper)")
    T = body_T(m, m_w, P1, RW1, disk_inertia(m_w, R)) + body_T(m, m_w, P2, RW2, disk_inertia(m_w, R)) \
        + body_T(m, m_f, Pf, Rz(th + ph), rod_inertia(m_f, l_f))
    rows = []
    for P, RW in ((P1, RW1), (P2, RW2)):     # contact point velocity v_P + omega x (-R k) = 0
        vc = vel(P, m) + omega(RW, m).cross(-R * ez)
        rows += [m.on_velocities(sp.expand(vc[i]))[0] for i in range(2)]
    rows.append(m.on_velocities(vel(Pf, m).cross(e_b)[2])[0])
    compare_with_file(m, T, 0, rows)
    I_f = m_f * l_f ** 2 / 12
    Ibar = m_f * l_r ** 2 + m_w * (4 * a ** 2 + R ** 2 / 2) + I_f
    s, c = sp.sin(th), sp.cos(th)
    A_claim = sp.Matrix([[2 * m_w + m_f, 0, -m_f * l_r * s, 0, 0], [0, 2 * m_w + m_f, m_f * l_r * c, 0, 0],
                         [-m_f * l_r * s, m_f * l_r * c, Ibar, -m_w * a * R, I_f],
                         [0, 0, -m_w * a * R, m_w * R ** 2, 0], [0, 0, I_f, 0, I_f]])
    check(matrices_equal(m.A, A_claim, m), "bar_wheels: A = paper's A with a13 = -m_f l_r sin(theta), a23 = m_f l_r cos(theta)")
    # paper's delta_R and b11 (section 3.3) with general z11..z14 (functions of all q)
    zs = [sp.Function(f"z1{j}", real=True)(*m.q) for j in range(1, 5)]
    Z1 = sp.Matrix([zs])
    al1 = m.alpha[:, :4]
    dR = sp.Matrix.vstack(Z1, al1).det()
    z11, z12, z13, z14 = zs
    dR_paper = l_r * (-R * z11 * c - R * z12 * s + z14) * sp.cos(ph) - (R * z13 + a * z14) * sp.sin(ph)
    check(is_zero(dR - dR_paper, model=m), "bar_wheels: paper's delta_R (section 3.3) is correct")
    _, _, AG = gamma_and_AG(m, "paper")
    b11 = ((3 * m_w + m_f) * l_r ** 2 * sp.cos(ph) ** 2 + (Ibar - m_w * a ** 2) * sp.sin(ph) ** 2) / (l_r * sp.cos(ph)) ** 2
    check(is_zero(AG[0, 0] - b11, model=m), "bar_wheels: paper's b11 = [(3m_w+m_f)R^2 l_r^2 cos^2 + (Ibar - m_w a^2) R^2 sin^2]/delta_R^2")
    check(not is_zero(AG[0, 1], model=m), "bar_wheels: b12 != 0, i.e. (H2) fails for sin(phi) != 0")
    if VERBOSE:
        print("        A_Gamma (paper) =", AG)


def disk_kinematics(m, xC, yC, ph, ps, th, R):
    C = sp.Matrix([xC, yC, 0])
    F = Rz(ph) * Rx(-th)                 # frame (e1, b, u): roll about -e1
    u = F * ez                           # from C to the disk centre
    Rd = F * Ry(ps)                      # disk: spin psi about its axis b = F y
    return C, u, Rd


def rolling_disk():
    m = Model("rolling_disk")
    xC, yC, ph, ps, th = m.q
    R, m_d, g = m.P["R"], m.P["m_d"], m.P["g"]
    C, u, Rd = disk_kinematics(m, xC, yC, ph, ps, th, R)
    P0 = C + R * u
    T = body_T(m, m_d, P0, Rd, disk_inertia(m_d, R))
    U = U_gravity([(m_d, P0[2])], g)
    vc = vel(P0, m) + omega(Rd, m).cross(C - P0)   # material point of the disk at C
    rows = [m.on_velocities(sp.expand(sp.trigsimp(vc[i])))[0] for i in range(3)]
    compare_with_file(m, T, U, rows)
    check(all(is_zero(m.etas["momenta"][i] - sp.diff(m.T, m.dq[j]), model=m) for i, j in ((0, 2), (1, 3))),
          "rolling_disk: momenta choice = (dT/dphi', dT/dpsi')")
    sol, eta, etad = reduced_equations(m, "velocities")
    w, s_, t = eta                           # phi', psi', theta'
    expect = [2 * s_ * t / sp.cos(th), t * (sp.Rational(5, 3) * w * sp.cos(th) + 2 * s_ * sp.tan(th)),
              w ** 2 * sp.sin(th) * sp.cos(th) - sp.Rational(6, 5) * w * s_ * sp.cos(th) + 4 * g * sp.sin(th) / (5 * R)]
    check(all(is_zero(sol[etad[i]] - expect[i], model=m) for i in range(3)),
          "rolling_disk: phi'' = 2 psi' theta'/cos, psi'' = theta'(5/3 phi' cos + 2 psi' tan), "
          "theta'' = phi'^2 sin cos - 6/5 phi' psi' cos + 4 g sin/(5 R)")
    # linearised about upright rolling psi' = W: theta'' = (4 g/(5 R) - 12 W^2/5) theta,
    # stable iff W^2 > g/(3 R), the classical criterion for a thin homogeneous disk
    W, eps = sp.symbols("W epsilon", positive=True)
    lin = sp.diff(expect[2].subs({th: eps * th, t: eps * t, w: 2 * W * eps * th, s_: W}, simultaneous=True), eps).subs(eps, 0)
    check(sp.simplify(lin - (4 * g / (5 * R) - sp.Rational(12, 5) * W ** 2) * th) == 0,
          "rolling_disk: upright rolling stable iff psi'^2 > g/(3 R) (classical result)")


def unicycle_rider():
    m = Model("unicycle_rider")
    xC, yC, ph, ps, th, th1 = m.q
    R, m_d, m_f, m_r, rho1, rho2, rho, g = (m.P[k] for k in ("R", "m_d", "m_f", "m_r", "rho1", "rho2", "rho", "g"))
    C, u, Rd = disk_kinematics(m, xC, yC, ph, ps, th, R)
    e2 = Rz(ph) * sp.Matrix([0, 1, 0])
    P0 = C + R * u
    Pf = C + rho1 * u
    O1 = C + (rho1 + rho2) * u
    Pr = O1 + rho * (sp.sin(th1) * e2 - sp.cos(th1) * ez)
    # the rider swings in the plane orthogonal to the disk through C and P0: normal e1
    e1 = Rz(ph) * sp.Matrix([1, 0, 0])
    check(sp.simplify((Pr - C).dot(e1)) == 0 and sp.simplify(u.dot(e1)) == 0,
          "unicycle: P_r in the plane through C, P0 orthogonal to the disk (normal e1)")
    b = Rd * sp.Matrix([0, 1, 0])
    check(sp.simplify(b.dot(e1)) == 0 and sp.simplify(b.dot(u)) == 0, "unicycle: b is the disk axis")
    T = body_T(m, m_d, P0, Rd, disk_inertia(m_d, R)) + body_T(m, m_f, Pf) + body_T(m, m_r, Pr)
    U = U_gravity([(m_d, P0[2]), (m_f, Pf[2]), (m_r, Pr[2])], g)
    vc = vel(P0, m) + omega(Rd, m).cross(C - P0)
    rows = [m.on_velocities(sp.expand(sp.trigsimp(vc[i])))[0] for i in range(3)]
    compare_with_file(m, T, U, rows)
    check(all(is_zero(m.etas["momenta"][i] - sp.diff(m.T, m.dq[j]), model=m) for i, j in ((0, 2), (1, 3))),
          "unicycle: momenta choice = (dT/dphi', dT/dpsi')")
    # the paper's matrix with the corrections listed in docs/models/unicycle_rider.md
    I_d = m_d * R ** 2 / 2
    k1 = m_d * R + m_f * rho1 + m_r * (rho1 + rho2)
    k2 = m_f * rho1 ** 2 + m_r * (rho1 + rho2) ** 2 + m_d * R ** 2
    k3 = m_r * rho * (rho1 + rho2)
    F1 = k1 * sp.sin(th) + m_r * rho * sp.sin(th1)
    F2 = (I_d / 2 + m_d * R ** 2 + m_f * rho1 ** 2 + m_r * (rho1 + rho2) ** 2) * sp.sin(th) ** 2 \
        + m_r * rho ** 2 * sp.sin(th1) ** 2 + 2 * m_r * rho * (rho1 + rho2) * sp.sin(th) * sp.sin(th1)
    s, c = sp.sin(ph), sp.cos(ph)
    mt = m_d + m_f + m_r
    U_ = [[mt, 0, -F1 * c, 0, -k1 * sp.cos(th) * s, -m_r * rho * sp.cos(th1) * s],
          [0, mt, -F1 * s, 0, k1 * sp.cos(th) * c, m_r * rho * sp.cos(th1) * c],
          [0, 0, F2 + I_d / 2, -I_d * sp.sin(th), 0, 0],
          [0, 0, 0, I_d, 0, 0],
          [0, 0, 0, 0, k2 + I_d / 2, k3 * sp.cos(th + th1)],
          [0, 0, 0, 0, 0, m_r * rho ** 2]]
    A_claim = sp.Matrix(6, 6, lambda i, j: U_[min(i, j)][max(i, j)])
    check(matrices_equal(m.A, A_claim, m),
          "unicycle: A = paper's A with a33 = F2 + I_d/2, rho for l, kappa2 with rho1 and m_d R^2")
    check(is_zero(m.U - (-k1 * g * sp.cos(th) + m_r * g * rho * sp.cos(th1)), model=m),
          "unicycle: U = -kappa1 g cos(theta) + m_r g rho cos(theta1)")
    # (38) and Gamma_1 of the family, with F2 -> F2 + I_d/2
    w1, w2, z13, z14, z23, z24 = (sp.Function(n, real=True)(th, th1) for n in ("w1", "w2", "z13", "z14", "z23", "z24"))
    Zm = sp.Matrix([m.on_velocities(e)[0] for e in m.etas["family"]])
    M = sp.Matrix.vstack(Zm, m.alpha)
    G = M.inv()[:, :4].applyfunc(sp.simplify)
    d13, d23 = z24 + R * w2, z14 + R * w1
    DR = z13 * d13 - z23 * d23
    check(is_zero(M.det() - DR, model=m), "unicycle family: delta = z13 z24 - z23 z14 + R (z13 w2 - z23 w1)")
    G1_claim = sp.Matrix([[-R * z23 * c, R * z13 * c], [-R * z23 * s, R * z13 * s], [d13, -d23], [-z23, z13]]) / DR
    check(matrices_equal(G[:4, :2], G1_claim, m) and G[:4, 2:] == sp.zeros(4, 2),
          "unicycle family: Gamma_1 = [[-R z23 c, R z13 c], [-R z23 s, R z13 s], [z24 + R w2, -(z14 + R w1)], [-z23, z13]]/delta, Gamma_2 = 0")
    AG = G.T * m.A * G
    a33 = F2 + I_d / 2
    k = R * F1 + I_d * sp.sin(th)
    b11 = ((mt * R ** 2 + I_d) * z23 ** 2 + 2 * k * z23 * d13 + a33 * d13 ** 2) / DR ** 2
    b12 = -((mt * R ** 2 + I_d) * z13 * z23 + k * (z13 * d13 + z23 * d23) + a33 * d13 * d23) / DR ** 2
    b22 = ((mt * R ** 2 + I_d) * z13 ** 2 + 2 * k * z13 * d23 + a33 * d23 ** 2) / DR ** 2
    check(is_zero(AG[0, 0] - b11, model=m) and is_zero(AG[1, 1] - b22, model=m),
          "unicycle family: (38) b11, b22 hold with F2 replaced by F2 + I_d/2")
    check(is_zero(AG[0, 1] - b12, model=m), "unicycle family: (38) b12 holds with an overall minus sign")
    check(all(is_zero(AG[i, j], model=m) for i in range(2) for j in range(2, 4)),
          "unicycle family: A_Gamma block diagonal ((H2) holds)")


def remark22():
    m = Model("remark22")
    q1, q2, q3 = m.q
    a11, a22, a33 = 1 + q2 ** 2 + q3 ** 2, 1 + q1 ** 2 + q3 ** 2, 1 + q1 ** 2 + q2 ** 2
    T = sp.expand((a11 * m.dq[0] ** 2 + a22 * m.dq[1] ** 2 + a33 * m.dq[2] ** 2) / 2)
    compare_with_file(m, T, 0, [[0, 0, 1 + q1 ** 2]])
    Z, G, AG = gamma_and_AG(m, "paper")
    check(AG == sp.eye(2), "remark22: A_Gamma = I_2")
    check(G == sp.Matrix([[1 / sp.sqrt(a11), 0], [0, 1 / sp.sqrt(a22)], [0, 0]]), "remark22: Gamma as in the paper")
    for r in range(2):
        J = Z[r, :].jacobian(m.q)            # (J_q Z_(r))_{jk} = d z_rj / d q_k
        Mr = (G.T * (J - J.T) * G).applyfunc(sp.simplify)
        if r == 0:
            claim = sp.diff(a11, q2) / (2 * a11 * sp.sqrt(a22))
            check(sp.simplify(Mr[0, 1] - claim) == 0 and sp.simplify(Mr[1, 0] + claim) == 0,
                  "remark22: Gamma^T (J Z_(1) - J Z_(1)^T) Gamma entry = (da11/dq2)/(2 a11 sqrt(a22)) (paper: (da11/dq2)/sqrt(a11 a22))")
        else:
            claim = -sp.diff(a22, q1) / (2 * a22 * sp.sqrt(a11))
            check(sp.simplify(Mr[0, 1] - claim) == 0, "remark22: for Z_(2) the entry is -(da22/dq1)/(2 a22 sqrt(a11))")
        if VERBOSE:
            print(f"        Gamma^T (J Z_({r + 1}) - transpose) Gamma =", Mr)
    sol, eta, etad = reduced_equations(m, "paper")
    c1 = sp.diff(a11, q2) / (2 * a11 * sp.sqrt(a22))
    c2 = -sp.diff(a22, q1) / (2 * a22 * sp.sqrt(a11))
    k = c1 * eta[0] + c2 * eta[1]
    check(is_zero(sol[etad[0]] + eta[1] * k, model=m) and is_zero(sol[etad[1]] - eta[0] * k, model=m),
          "remark22: eta1' = -eta2 (c1 eta1 + c2 eta2), eta2' = eta1 (c1 eta1 + c2 eta2)")


def main():
    for fn, name in ((knife, "knife"), (lambda: knife("vertical_knife"), "vertical_knife"),
                     (bar_blade, "bar_blade"), (bar_wheels, "bar_wheels"),
                     (unicycle_rider, "unicycle_rider"), (rolling_disk, "rolling_disk"),
                     (remark22, "remark22"), (chaplygin_sleigh, "chaplygin_sleigh"),
                     (snakeboard, "snakeboard")):
        print(f"== {name}")
        fn()
    files = sorted(p.stem for p in MODELS.glob("*.toml"))
    print("models checked:", ", ".join(files))
    if FAILURES:
        print(f"{len(FAILURES)} FAILED")
        sys.exit(1)
    print("all checks passed")


if __name__ == "__main__":
    main()
