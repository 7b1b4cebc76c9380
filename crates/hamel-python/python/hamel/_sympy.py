"""A derivation's objects as SymPy expressions (``Derivation.to_sympy()``).

hamel's canonical text uses the model file's syntax: names (identifiers that hamel has
checked), numbers, ``+ - * / ^``, calls of the known functions, ``etaR`` for the
quasi-velocities and ``etaR_dot`` for their rates. Every name becomes a real SymPy Symbol (so
that ``E``, ``I``, ``S``, ``N`` or ``beta`` are not taken for SymPy's constants), ``^`` is a
power, decimals are exact rationals."""

import re

SHAPES = {
    "a": "matrix", "alpha": "matrix", "z": "matrix", "grad_u": "vector", "forces": "vector",
    "gamma": "matrix", "theta": "matrix", "delta": "scalar", "a_gamma": "matrix",
    "forcing": "vector", "nu": "matrix", "q": "matrices", "q_paper": "matrices",
    "q_correction": "matrices", "kinematics": "vector", "equations": "vector",
    "equations_paper": "vector",
}

_NAME = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")


def _parser():
    import sympy as sp
    from sympy.parsing.sympy_parser import (convert_xor, parse_expr, rationalize,
                                            standard_transformations)

    functions = {"sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "sqrt": sp.sqrt, "exp": sp.exp,
                 "log": sp.log, "asin": sp.asin, "acos": sp.acos, "atan": sp.atan,
                 "atan2": sp.atan2, "sinh": sp.sinh, "cosh": sp.cosh, "tanh": sp.tanh,
                 "abs": sp.Abs, "pi": sp.pi}
    transformations = standard_transformations + (convert_xor, rationalize)
    symbols = {}

    def der(x):
        return sp.Symbol(f"{x.name}_dot", real=True)

    def parse(text):
        local = dict(functions)
        for name in set(_NAME.findall(text)) - set(functions) - {"der"}:
            local[name] = symbols.setdefault(name, sp.Symbol(name, real=True))
        local["der"] = der
        return parse_expr(text, local_dict=local, transformations=transformations)

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
