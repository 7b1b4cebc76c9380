"""``python -m hamel._worker KIND ARGS...``: the process that runs the computer algebra for a
notebook or script (a derivation the store lacks), then exits. The job comes on stdin; the
result goes to the file named last. Its output is this process's own: Symbolica's notice is
printed as Symbolica prints it."""

import sys

from ._hamel import work


def main() -> int:
    if len(sys.argv) < 2:
        print("usage: python -m hamel._worker derive-worker RESULT\n"
              "       python -m hamel._worker search-worker MODEL --eliminate A,B --budget S --max N",
              file=sys.stderr)
        return 2
    try:
        work(sys.argv[1], sys.argv[2:])
    except Exception as e:  # the caller reads the outcome from the result file
        print(f"hamel worker: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
