"""Exact polynomial arithmetic on rationals, for the Routh-Hurwitz analysis.

A polynomial is a list of :class:`fractions.Fraction` coefficients, highest
power first: ``[1, 2, 3]`` is ``x^2 + 2 x + 3``.  Every float of the plant is
an exact binary rational, so working in ``Fraction`` makes the characteristic
polynomial, its Hurwitz determinants and the sign tests exact: the engaged
plant's coefficients span some 30 orders of magnitude (a 110 kHz mesh next to
a 1 rad/s loop), where floating-point Hurwitz determinants would lose every
digit to cancellation.
"""
from __future__ import annotations

from fractions import Fraction
from typing import Sequence

Poly = list  # list[Fraction], highest power first


def trim(p: Sequence) -> Poly:
    """Drop leading zero coefficients (the zero polynomial is ``[0]``)."""
    p = [Fraction(c) for c in p]
    i = 0
    while i < len(p) - 1 and p[i] == 0:
        i += 1
    return p[i:] or [Fraction(0)]


def degree(p: Poly) -> int:
    """Degree; -1 for the zero polynomial."""
    p = trim(p)
    return -1 if p == [0] else len(p) - 1


def evaluate(p: Poly, x: Fraction) -> Fraction:
    """``p(x)`` by Horner's rule, exactly."""
    acc = Fraction(0)
    for c in p:
        acc = acc * x + c
    return acc


def derivative(p: Poly) -> Poly:
    n = len(p) - 1
    return trim([c * (n - i) for i, c in enumerate(p[:-1])]) if n > 0 else [Fraction(0)]


def remainder(a: Poly, b: Poly) -> Poly:
    """Remainder of ``a / b`` (``b`` not zero)."""
    a, b = trim(a), trim(b)
    if degree(b) < 0:
        raise ZeroDivisionError("polynomial division by zero")
    a = list(a)
    while degree(a) >= degree(b) and degree(a) >= 0:
        q = a[0] / b[0]
        for i in range(len(b)):
            a[i] -= q * b[i]
        a = trim(a[1:]) if len(a) > 1 else [Fraction(0)]
    return trim(a)


def interpolate(xs: Sequence[Fraction], ys: Sequence[Fraction]) -> Poly:
    """The polynomial of degree < len(xs) through the points ``(xs[i], ys[i])`` (Lagrange)."""
    n = len(xs)
    out = [Fraction(0)] * n
    for i in range(n):
        basis = [Fraction(1)]                          # prod_{j != i} (x - xj)/(xi - xj)
        denom = Fraction(1)
        for j in range(n):
            if j != i:
                basis = [c for c in basis] + [Fraction(0)]
                for k in range(len(basis) - 1, 0, -1):
                    basis[k] -= xs[j] * basis[k - 1]
                denom *= xs[i] - xs[j]
        scale = ys[i] / denom
        for k in range(n):
            out[k] += scale * basis[k]
    return trim(out)


def determinant(m: Sequence[Sequence[Fraction]]) -> Fraction:
    """Exact determinant by fraction-valued Gaussian elimination."""
    a = [list(map(Fraction, row)) for row in m]
    n = len(a)
    det = Fraction(1)
    for col in range(n):
        piv = next((r for r in range(col, n) if a[r][col] != 0), None)
        if piv is None:
            return Fraction(0)
        if piv != col:
            a[col], a[piv] = a[piv], a[col]
            det = -det
        det *= a[col][col]
        for r in range(col + 1, n):
            f = a[r][col] / a[col][col]
            if f:
                for c in range(col, n):
                    a[r][c] -= f * a[col][c]
    return det


def charpoly(a: Sequence[Sequence[Fraction]]) -> Poly:
    """``det(s I - A)``, monic, exactly (Faddeev-LeVerrier recursion).

    ``M_0 = 0, c_n = 1; M_k = A M_{k-1} + c_{n-k+1} I, c_{n-k} = -tr(A M_k)/k``.
    """
    a = [list(map(Fraction, row)) for row in a]
    n = len(a)
    coeffs = [Fraction(1)]
    m = [[Fraction(0)] * n for _ in range(n)]
    for k in range(1, n + 1):
        am = [[sum(a[i][l] * m[l][j] for l in range(n)) for j in range(n)] for i in range(n)]
        m = [[am[i][j] + (coeffs[-1] if i == j else 0) for j in range(n)] for i in range(n)]
        am = [[sum(a[i][l] * m[l][j] for l in range(n)) for j in range(n)] for i in range(n)]
        coeffs.append(-sum(am[i][i] for i in range(n)) / k)
    return coeffs


# ------------------------------------------------------------- real roots

def sturm_sequence(p: Poly) -> list[Poly]:
    """``p, p', -rem(p, p'), ...`` (Sturm's theorem counts distinct real roots)."""
    seq = [trim(p), derivative(p)]
    while degree(seq[-1]) > 0:
        r = remainder(seq[-2], seq[-1])
        if degree(r) < 0:
            break
        seq.append([-c for c in r])
    return seq


def _variations(seq: list[Poly], x: Fraction) -> int:
    signs = [s for s in (evaluate(p, x) for p in seq) if s != 0]
    return sum(1 for u, v in zip(signs, signs[1:]) if (u > 0) != (v > 0))


def positive_roots(p: Poly, rel_tol: float = 1e-13) -> list[float]:
    """The distinct real roots ``x > 0`` of ``p``, ascending, to relative accuracy ``rel_tol``.

    Isolated exactly with Sturm sequences on ``(0, B]`` (``B``: Cauchy's bound
    ``1 + max |a_i / a_0|``), then bisected; roots at zero are divided out first.
    """
    p = trim(p)
    if degree(p) <= 0:
        return []
    while p[-1] == 0:  # x = 0 roots
        p = p[:-1]
        if degree(p) <= 0:
            return []
    seq = sturm_sequence(p)
    bound = 1 + max(abs(c / p[0]) for c in p[1:])
    out: list[float] = []
    stack = [(Fraction(0), bound, _variations(seq, Fraction(0)), _variations(seq, bound))]
    while stack:
        a, b, va, vb = stack.pop()
        count = va - vb
        if count <= 0:
            continue
        if count == 1 and (b - a) <= Fraction(rel_tol) * b:
            out.append(float((a + b) / 2))
            continue
        mid = (a + b) / 2
        nudge = (b - a) / 1_000_003
        while evaluate(p, mid) == 0:  # keep the end points off the roots (Sturm's theorem)
            mid += nudge
        vm = _variations(seq, mid)
        stack.append((mid, b, vm, vb))
        stack.append((a, mid, va, vm))
    return sorted(out)
