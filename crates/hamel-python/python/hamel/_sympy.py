"""A derivation's objects as SymPy expressions (``Derivation.to_sympy()``).

hamel's canonical text uses the model file's syntax: names (identifiers that hamel has
checked), numbers, ``+ - * / ^``, calls of the known functions, ``etaR`` for the
quasi-velocities and ``etaR_dot`` for their rates, ``der(q)`` for a velocity (the Symbol
``q_dot``). Every name becomes a real SymPy Symbol (so that ``E``, ``I``, ``S``, ``N``,
``beta`` or ``lambda`` are not taken for SymPy's constants or Python's words), ``^`` is a
power, decimals are exact rationals. The text is read by a small parser of that grammar, not
by ``sympy.parse_expr`` (which hands Python's compiler nesting too deep for a bicycle)."""

import re

SHAPES = {
    "a": "matrix", "alpha": "matrix", "z": "matrix", "grad_u": "vector", "forces": "vector",
    "gamma": "matrix", "theta": "matrix", "delta": "scalar", "a_gamma": "matrix",
    "forcing": "vector", "nu": "matrix", "q": "matrices", "q_paper": "matrices",
    "q_correction": "matrices", "kinematics": "vector", "equations": "vector",
    "equations_paper": "vector",
}



_TOKEN = re.compile(r"\s*(?:(?P<number>[0-9]+(?:\.[0-9]*)?(?:[eE][+-]?[0-9]+)?|\.[0-9]+(?:[eE][+-]?[0-9]+)?)"
                    r"|(?P<name>[A-Za-z_][A-Za-z_0-9]*)|(?P<op>[-+*/^(),]))")


def _tokens(text):
    out, at = [], 0
    text = text.rstrip()
    while at < len(text):
        m = _TOKEN.match(text, at)
        if not m:
            raise ValueError(f"cannot read {text[at:at + 20]!r} in hamel's text")
        out.append((m.lastgroup, m.group(m.lastgroup)))
        at = m.end()
    return out


def _parser():
    """A reader of hamel's canonical text into SymPy: sums and products are read in loops
    (a bicycle's entries have hundreds of terms, more than Python's own parser nests), names
    become real Symbols whatever they are (`lambda`, `E`, `I`, `beta`)."""
    import sympy as sp

    functions = {"sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "sqrt": sp.sqrt, "exp": sp.exp,
                 "log": sp.log, "asin": sp.asin, "acos": sp.acos, "atan": sp.atan,
                 "atan2": sp.atan2, "sinh": sp.sinh, "cosh": sp.cosh, "tanh": sp.tanh,
                 "abs": sp.Abs}
    symbols = {}

    def symbol(name):
        return symbols.setdefault(name, sp.Symbol(name, real=True))

    def parse(text):
        tokens = _tokens(text)
        at = 0

        def peek():
            return tokens[at] if at < len(tokens) else (None, None)

        def take(value=None):
            nonlocal at
            kind, got = peek()
            if kind is None or (value is not None and got != value):
                raise ValueError(f"expected {value or 'more'} in {text[:60]!r}")
            at += 1
            return kind, got

        def expr():
            terms = [term()]
            while peek()[1] in ("+", "-"):
                _, sign = take()
                terms.append(term() if sign == "+" else -term())
            return terms[0] if len(terms) == 1 else sp.Add(*terms)

        def term():
            factors = [unary()]
            while peek()[1] in ("*", "/"):
                _, op = take()
                factors.append(unary() if op == "*" else sp.Pow(unary(), -1))
            return factors[0] if len(factors) == 1 else sp.Mul(*factors)

        def unary():
            if peek()[1] in ("-", "+"):
                _, sign = take()
                return unary() if sign == "+" else -unary()
            base = atom()
            if peek()[1] == "^":
                take()
                return sp.Pow(base, unary())
            return base

        def atom():
            kind, got = take()
            if kind == "number":
                return sp.Rational(got)
            if got == "(":
                inner = expr()
                take(")")
                return inner
            if kind != "name":
                raise ValueError(f"unexpected {got!r} in {text[:60]!r}")
            if peek()[1] != "(":
                return sp.pi if got == "pi" else symbol(got)
            take("(")
            args = [expr()]
            while peek()[1] == ",":
                take()
                args.append(expr())
            take(")")
            if got == "der":
                return symbol(f"{args[0].name}_dot")
            if got not in functions:
                raise ValueError(f"unknown function {got!r} in hamel's text")
            return functions[got](*args)

        value = expr()
        if at != len(tokens):
            raise ValueError(f"unexpected {tokens[at][1]!r} in {text[:60]!r}")
        return value

    return parse


def to_sympy(derivation):
    """The derivation's objects (those it holds: closed form or structured) as SymPy
    Matrices (a list of them for the Q⁽ⁱ⁾) and expressions, by name."""
    import sympy as sp

    parse = _parser()
    data = derivation.to_dict()
    out = {}
    for key, shape in SHAPES.items():
        value = data.get(key)
        if value is None:
            continue
        if shape == "scalar":
            out[key] = parse(value)
        elif shape == "vector":
            out[key] = sp.Matrix([parse(e) for e in value])
        elif shape == "matrix":
            out[key] = sp.Matrix([[parse(e) for e in row] for row in value]) if value else sp.zeros(0, 0)
        else:
            out[key] = [sp.Matrix([[parse(e) for e in row] for row in m]) for m in value]
    return out
