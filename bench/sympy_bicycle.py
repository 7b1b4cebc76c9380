#!/usr/bin/env python3
"""SymPy's own Whipple bicycle (sympy/physics/mechanics/tests/test_kane3.py, `test_bicycle`),
up to and including `KanesMethod(..., constraint_solver="CRAMER").kanes_equations(...)`: the
baseline of the bicycle's derivation time and size (docs/models/whipple_bicycle.md).

    python3 bench/sympy_bicycle.py [--count | --linearize]

The test's code is read from the installed SymPy and run as it is written there, stopping after
`kanes_equations`; with --linearize, it goes on through the test's linearisation
(`KM.linearize(A_and_B=True, op_point=..., linear_solver="CRAMER")`, the benchmark's values
substituted, A(v) on lean, steer and their rates extracted), and "linearize_seconds" is the
time of that part. Prints one JSON line:

    {"sympy": VERSION, "status": "ok", "seconds": wall time of the derivation (imports excluded;
     with --linearize, of the derivation and the linearisation),
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


def body_lines():
    """The body of test_bicycle, its lines."""
    lines = inspect.getsource(test_kane3.test_bicycle).splitlines()
    return lines[lines.index(next(l for l in lines if l.startswith("def "))) + 1:]


def derivation_source():
    """The body of test_bicycle up to the line that calls kanes_equations, dedented."""
    body = body_lines()
    end = next(i for i, l in enumerate(body) if "kanes_equations" in l)
    return textwrap.dedent("\n".join(body[: end + 1]))


def linearisation_source():
    """The body after kanes_equations, through the extraction of A on lean, steer and rates."""
    body = body_lines()
    start = next(i for i, l in enumerate(body) if "kanes_equations" in l) + 1
    end = next(i for i, l in enumerate(body) if "A_s.extract" in l)
    return textwrap.dedent("\n".join(body[start : end + 1]))


def main():
    code = compile(derivation_source(), "test_kane3.test_bicycle", "exec")
    scope = dict(vars(test_kane3))
    started = time.perf_counter()
    exec(code, scope)
    seconds = time.perf_counter() - started
    out = {"sympy": sp.__version__, "status": "ok", "seconds": seconds}
    if "--linearize" in sys.argv[1:]:
        code = compile(linearisation_source(), "test_kane3.test_bicycle", "exec")
        started = time.perf_counter()
        exec(code, scope)
        out["linearize_seconds"] = time.perf_counter() - started
        out["seconds"] = seconds + out["linearize_seconds"]
        out["derive_seconds"] = seconds
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
