#!/usr/bin/env python3
"""SymPy's own Whipple bicycle (sympy/physics/mechanics/tests/test_kane3.py, `test_bicycle`),
up to and including `KanesMethod(..., constraint_solver="CRAMER").kanes_equations(...)`: the
baseline of the bicycle's derivation time and size (docs/models/whipple_bicycle.md).

    python3 bench/sympy_bicycle.py [--count]

The test's code is read from the installed SymPy and run as it is written there, stopping after
`kanes_equations`. The linearisation that follows in the test is not run. Prints one JSON line:

    {"sympy": VERSION, "status": "ok", "seconds": wall time of the derivation (imports excluded),
     "ops_m_f": count_ops of the full mass matrix and forcing vector,
     "ops_cse": count_ops after sympy.cse}

the two counts only with --count (they take longer than the derivation).

`hamel bench --sympy` runs it as the baseline of the bicycle's `benchmark` row (SymPy's
derivation of the same bicycle, by Kane's method, in place of bench/sympy_derive.py's
Boltzmann–Hamel derivation).

Exit status: 0; 3 when SymPy, or its test file, is missing.
"""
import inspect
import json
import sys
import textwrap
import time

try:
    import sympy as sp
    from sympy.physics.mechanics.tests import test_kane3
except ImportError as e:
    print(f"sympy_bicycle.py: SymPy or its test_kane3 is not installed: {e}", file=sys.stderr)
    sys.exit(3)


def derivation_source():
    """The body of test_bicycle up to the line that calls kanes_equations, dedented."""
    lines = inspect.getsource(test_kane3.test_bicycle).splitlines()
    body = lines[lines.index(next(l for l in lines if l.startswith("def "))) + 1:]
    end = next(i for i, l in enumerate(body) if "kanes_equations" in l)
    return textwrap.dedent("\n".join(body[: end + 1]))


def main():
    code = compile(derivation_source(), "test_kane3.test_bicycle", "exec")
    scope = dict(vars(test_kane3))
    started = time.perf_counter()
    exec(code, scope)
    seconds = time.perf_counter() - started
    out = {"sympy": sp.__version__, "status": "ok", "seconds": seconds}
    if "--count" in sys.argv[1:]:
        km = scope["KM"]
        exprs = list(km.mass_matrix_full) + list(km.forcing_full)
        out["ops_m_f"] = sum(sp.count_ops(e) for e in exprs)
        replacements, reduced = sp.cse(exprs)
        out["ops_cse"] = sum(sp.count_ops(v) for _, v in replacements) + sum(
            sp.count_ops(e) for e in reduced
        )
    print(json.dumps(out))


if __name__ == "__main__":
    main()
