"""Unrolled 3 x 3 algebra on nested lists of scalars, with Python zeros and ones folded at
trace time (a stack's dashpot matrix is sparse), and the two solves of the step's
block-tridiagonal system ``(M + dt/2 C) a = F``."""

from __future__ import annotations

LDL_BATCH_MAX_BLOCKS = 3
"""Batches of assemblies of up to this many blocks solve their step as a single history does,
by :func:`solve_ldl`; larger ones by block elimination (:func:`solve_tridiagonal`), which ran
faster from four blocks up (docs/assemblies.md, "Performance")."""


def is_zero(x) -> bool:
    return isinstance(x, float) and x == 0.0


def mul(a, b):
    """``a * b`` with Python zeros and ones folded (XLA keeps ``x * 0.0`` for NaN semantics)."""
    if is_zero(a) or is_zero(b):
        return 0.0
    if isinstance(a, float) and a == 1.0:
        return b
    if isinstance(b, float) and b == 1.0:
        return a
    return a * b


def plus(*terms):
    """Sum with Python zeros dropped."""
    out = 0.0
    for t in terms:
        if not is_zero(t):
            out = t if is_zero(out) else out + t
    return out


def inv3(a):
    """Inverse of a 3 x 3 matrix given as nested lists of scalars (adjugate / determinant)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a

    def det2(p, q, r, s_):
        return plus(mul(p, q), -mul(r, s_) if not is_zero(mul(r, s_)) else 0.0)

    c00 = det2(a11, a22, a12, a21)
    c01 = det2(a12, a20, a10, a22)
    c02 = det2(a10, a21, a11, a20)
    det = plus(mul(a00, c00), mul(a01, c01), mul(a02, c02))
    r = 1.0 / det
    return [
        [mul(c00, r), mul(det2(a02, a21, a01, a22), r), mul(det2(a01, a12, a02, a11), r)],
        [mul(c01, r), mul(det2(a00, a22, a02, a20), r), mul(det2(a02, a10, a00, a12), r)],
        [mul(c02, r), mul(det2(a01, a20, a00, a21), r), mul(det2(a00, a11, a01, a10), r)],
    ]


def mv(a, v):
    return [plus(*(mul(a[i][j], v[j]) for j in range(3))) for i in range(3)]


def mm(a, b):
    return [[plus(*(mul(a[i][j], b[j][k]) for j in range(3))) for k in range(3)] for i in range(3)]


def transpose(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def solve_tridiagonal(diag, lower, rhs):
    """Solve the symmetric block-tridiagonal system with diagonal blocks ``diag[k]``,
    ``A[k, k-1] = lower[k]`` (``lower[0]`` unused) and right-hand sides ``rhs[k]`` by block
    elimination (3 x 3 blocks). Used by batches of more than ``LDL_BATCH_MAX_BLOCKS`` blocks;
    the others use :func:`solve_ldl`."""
    n = len(diag)
    dp, gp, inv = [diag[0]], [rhs[0]], [inv3(diag[0])]
    for k in range(1, n):
        lk = lower[k]
        li = mm(lk, inv[k - 1])
        lt = transpose(lk)
        corr = mm(li, lt)
        dk = [[plus(diag[k][i][j], mul(-1.0, corr[i][j])) for j in range(3)] for i in range(3)]
        g = mv(li, gp[k - 1])
        dp.append(dk)
        gp.append([plus(rhs[k][i], mul(-1.0, g[i])) for i in range(3)])
        inv.append(inv3(dk))
    out = [None] * n
    out[n - 1] = mv(inv[n - 1], gp[n - 1])
    for k in range(n - 2, -1, -1):
        u = mv(transpose(lower[k + 1]), out[k + 1])
        out[k] = mv(inv[k], [plus(gp[k][i], mul(-1.0, u[i])) for i in range(3)])
    return out


def solve_ldl(diag, lower, rhs):
    """:func:`solve_tridiagonal`'s system as a single history and small batches solve it
    (symmetric positive definite, ``M + dt/2 C``: no pivoting; the lower triangles of ``diag``
    are read): a scalar ``L D L^T`` of its band, then the two triangular solves.

    Each multiplier is a division by its pivot, and XLA:CPU does not copy a division into
    its consumers: each factor is computed once, where the adjugate inverses' shared products
    were copied into each output (docs/assemblies.md, "Performance"). In a batch the divisions
    are vector operations of their own, and from four blocks up the block elimination ran
    faster.
    """
    n = len(diag)
    size = 3 * n
    a = {}  # the lower triangle of the band, (row, column) -> entry
    for k in range(n):
        for i in range(3):
            for j in range(i + 1):
                a[3 * k + i, 3 * k + j] = diag[k][i][j]
            if k > 0:
                for j in range(3):
                    a[3 * k + i, 3 * (k - 1) + j] = lower[k][i][j]
    last = [min(size, 3 * (r // 3 + 2)) for r in range(size)]  # the band's rows below a column
    d, low = [], {}
    for j in range(size):
        d.append(a[j, j])
        rows = range(j + 1, last[j])
        col = {i: a[i, j] for i in rows if not is_zero(a[i, j])}
        for i, v in col.items():
            low[i, j] = v / d[j]
        for i in col:  # the trailing update (its entries stay in the band)
            for k in range(j + 1, i + 1):
                if k in col:
                    a[i, k] = plus(a[i, k], -mul(low[i, j], col[k]))
    b = [v for k in range(n) for v in rhs[k]]
    y = []
    for i in range(size):
        y.append(plus(b[i], *(-mul(low[i, j], y[j]) for j in range(i) if (i, j) in low)))
    z = [yi / di for yi, di in zip(y, d)]
    x = [0.0] * size
    for i in range(size - 1, -1, -1):
        x[i] = plus(z[i], *(-mul(low[k, i], x[k]) for k in range(i + 1, size) if (k, i) in low))
    return [x[3 * k : 3 * k + 3] for k in range(n)]


def scale(a, m):
    """``a * m`` of a 3 x 3 matrix ``m``."""
    return [[mul(a, m[i][j]) for j in range(3)] for i in range(3)]


def add(a, b):
    """``a + b`` of two 3 x 3 matrices."""
    return [[plus(a[i][j], b[i][j]) for j in range(3)] for i in range(3)]
