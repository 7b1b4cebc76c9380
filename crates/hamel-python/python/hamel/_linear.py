"""A linearisation, sweep or map from hamel's JSON as Python objects: lists of numbers become
numpy arrays, eigenvalues complex arrays (their JSON is [re, im] pairs)."""

import json

import numpy as np


def _numbers(value):
    return isinstance(value, list) and value and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)


def _array(value, key):
    if key == "eigenvalues" and isinstance(value, list) and all(_numbers(p) and len(p) == 2 for p in value):
        return np.array([complex(re, im) for re, im in value])
    if _numbers(value):
        return np.array(value, dtype=float)
    if isinstance(value, list) and value and all(_numbers(row) for row in value):
        if len({len(row) for row in value}) == 1:
            return np.array(value, dtype=float)
    return None


def _walk(value, key=None):
    array = _array(value, key)
    if array is not None:
        return array
    if isinstance(value, dict):
        return {k: _walk(v, k) for k, v in value.items()}
    if isinstance(value, list):
        return [_walk(v, key) for v in value]
    return value


def convert(text):
    """hamel's JSON of a linearisation, sweep or map, with arrays."""
    return _walk(json.loads(text))
