"""The step's Newton matrix from the Jacobian's zero pattern: probed once, coloured, factored block by block.

Simplified Newton (``step_n``) factors ``A = I - (h/2) D xi`` with ``D xi``, the
Jacobian of the continuous field, by differences: dense, n + 1 field
evaluations and O(n^3) a refresh.  Where ``D xi`` is mostly zero (the damped
pendula: a 2 x 2 block per pendulum and the entropy's row) a run can do
better with what the user's functions imply and the user never wrote down:

* **the pattern, probed once** (``probe``): n + 1 evaluations of ``xi`` at a
  point moved off the state by a deterministic pseudo-random amount
  (``PROBE_MOVE`` of each coordinate's size: a coordinate at 0, or a
  derivative vanishing at the state, does not hide an entry), each column
  differenced with a step ``PROBE_STEP`` of its coordinate's size (an entry
  whose first difference rounds away still moves at second order).  An entry
  is structural where the difference is not exactly zero;
* **dense rows dropped**: a row with more than ``max(DENSE_ROW_MIN, n /
  DENSE_ROW_FRACTION)`` entries (the entropy's row ``ds/dt = gamma |p|^2``)
  would make every column its own colour; at most ``MAX_DROPPED`` of them are
  left out of the matrix (its row taken as the identity's), which simplified
  Newton tolerates: with ``A = [[B, 0], [c^T, 1]]`` approximated by ``[[B, 0],
  [0, 1]]`` the error of the dropped coordinate trails the others' by one
  iteration (``I - A~^-1 A`` is nilpotent);
* **colours** (Curtis, Powell and Reid, IMA J. Appl. Math. 13 (1974) 117):
  columns that share no kept row are differenced together, one evaluation of
  ``xi`` per colour, greedily in the coordinates' order;
* **blocks**: the connected components of the kept pattern (union-find), each
  factored densely with partial pivoting (``vecn.lu_factor``); a refresh costs
  ``colours + 1`` evaluations and ``sum_b 2 b^3 / 3`` flops, a solve ``sum_b
  2 b^2``.

A pattern is used only where it pays (``SPARSE_SHARE``: the largest block and the
colours at most a quarter of n); the probe then
answers False and the step keeps its dense Jacobian.  An entry the probe missed
makes the matrix an approximation, never the step inexact: the iteration's
contraction is measured, and the step's acceptance (``step_n``) is the same
whatever matrix the iteration used.

The structure is kept in the workspace's dense region (``step_n``): the
``struct`` array (the LU factors' n^2 floats: counts, the colours, the blocks,
the packed sources of the entries and the packed Jacobian) and the ``fac`` array (the dense
Jacobian's n^2 floats: the packed factors and their pivots).  Reference:
docs/engine_rn.md, "Solving the step".
"""

import numpy as np

from .field_n import difference_step, field_into
from .jit import inner
from .layout import SQRT_EPS
from .vecn import lu_factor, lu_solve, norm_inf

#: the probe's point moves off the state by up to this fraction of each coordinate's size (``1 + |x_i|``)
PROBE_MOVE = 2.0**-12

#: the probe's difference step, as a fraction of each coordinate's size at that point
PROBE_STEP = 2.0**-10

#: a row with more entries than ``max(DENSE_ROW_MIN, n / DENSE_ROW_FRACTION)`` is dense
DENSE_ROW_MIN = 8
DENSE_ROW_FRACTION = 8

#: at most this many dense rows are dropped; a pattern with more is not used
MAX_DROPPED = 4

#: an evaluation of the continuous field xi, in evaluations of the discrete field (which adds the discrete
#: gradients, H and S and the projections: 0.23 on the pendula at n = 257, docs/engine_rn_speed.md), for the
#: solver choice's prices of a block refresh and solve
XI_SHARE = 0.5

#: a pattern is used only where its largest block and its colours are at most n / this
SPARSE_SHARE = 4

# -- the struct array: counts, the index arrays (integers in its floats), the packed sources and Jacobian ---------
S_BLOCKS, S_COLOURS, S_PACKED, S_DROPPED, S_CUBES, S_SQUARES, S_LARGEST = 0, 1, 2, 3, 4, 5, 6
S_BORDERED = 7  # the dropped rows solved exactly (below), their coordinates from S_ROWS on, xi there from S_XI
S_ROWS = 8
S_XI = S_ROWS + MAX_DROPPED
S_R = S_XI + MAX_DROPPED  # the solve's right-hand side on them
S_HEAD = S_R + MAX_DROPPED


@inner
def _colour(struct, n):
    """The colour of each column (integers in the struct's floats, as all its index arrays)."""
    return struct[S_HEAD : S_HEAD + n].view(np.int64)


@inner
def _order(struct, n):
    """The coordinates block by block: block k is ``order[start[k]:start[k + 1]]``."""
    return struct[S_HEAD + n : S_HEAD + 2 * n].view(np.int64)


@inner
def _start(struct, n):
    return struct[S_HEAD + 2 * n : S_HEAD + 3 * n + 1].view(np.int64)


@inner
def _offset(struct, n):
    """Where block k's (b, b) matrix starts in the packed arrays."""
    return struct[S_HEAD + 3 * n + 1 : S_HEAD + 4 * n + 2].view(np.int64)


@inner
def _dropped(struct, n):
    return struct[S_HEAD + 4 * n + 2 : S_HEAD + 5 * n + 2]


@inner
def _packed(struct, n, which):
    """The packed sources (``which`` 0, integers: ``_source``) or Jacobian (1): block k's (b, b) matrix in the
    block's order."""
    base = S_HEAD + 5 * n + 2
    q = int(struct[S_PACKED])
    return struct[base + which * q : base + (which + 1) * q]


@inner
def _source(struct, n):
    return _packed(struct, n, 0).view(np.int64)


@inner
def fits(n):
    """Whether the struct of a pattern worth using fits in n^2 floats (blocks of at most n / ``SPARSE_SHARE``)."""
    kept = n * max(DENSE_ROW_MIN, n // DENSE_ROW_FRACTION)  # the kept rows' entries, listed by the probe
    return S_HEAD + 5 * n + 2 + 2 * n * (n // SPARSE_SHARE) + n + 1 + kept <= n * n


@inner
def _root(parent, i):
    while parent[i] != i:
        parent[i] = parent[int(parent[i])]
        i = int(parent[i])
    return i


@inner
def probe(model, eps, hamiltonian, x, struct, csc, moved, f0, column, mark):
    """Probe ``D xi``'s zero pattern near ``x`` and, where it pays, build the struct (module docstring); returns
    True where the step should use it.  ``csc`` (n^2 floats of scratch) holds the pattern by columns; ``moved``,
    ``f0``, ``column`` and ``mark`` are scratch vectors of length n.  n + 1 evaluations of xi, then O(n + the
    entries) work."""
    n = x.shape[0]
    for i in range(n):  # a deterministic pseudo-random move (the golden-ratio sequence), in [0.5, 1] of the bound
        r = 0.5 + 0.5 * ((i + 1) * 0.6180339887498949 % 1.0)
        moved[i] = x[i] + PROBE_MOVE * r * (1.0 + abs(x[i]))
    field_into(f0, model, eps, hamiltonian, moved)
    for i in range(n):
        if not np.isfinite(f0[i]):
            return False
    # the pattern by columns: column j's rows are csc[csc[j]:csc[j + 1]]
    entries = n + 1
    for j in range(n):
        csc[j] = entries
        keep = moved[j]
        moved[j] = keep + PROBE_STEP * (1.0 + abs(keep))
        field_into(column, model, eps, hamiltonian, moved)
        moved[j] = keep
        for i in range(n):
            if not np.isfinite(column[i]):
                return False
            if column[i] != f0[i]:
                csc[entries] = i
                entries += 1
    csc[n] = entries
    # dense rows
    dropped, counts = _dropped(struct, n), f0
    limit = max(DENSE_ROW_MIN, n // DENSE_ROW_FRACTION)
    counts[:] = 0.0
    for at in range(n + 1, entries):
        counts[int(csc[at])] += 1.0
    n_dropped = 0
    for i in range(n):
        dropped[i] = 1.0 if counts[i] > limit else 0.0
        n_dropped += counts[i] > limit
    if n_dropped > MAX_DROPPED:
        return False
    # the kept rows' columns, listed by rows at the struct's end (``fits``: past the packed arrays): row i's at
    # struct[struct[rows_at + i]:struct[rows_at + i + 1]], filled below
    kept = 0.0
    for i in range(n):
        kept += counts[i] if dropped[i] == 0.0 else 0.0
    rows_at = n * n - (n + 1) - int(kept)
    listed = float(rows_at + n + 1)
    for i in range(n):
        struct[rows_at + i] = listed
        listed += counts[i] if dropped[i] == 0.0 else 0.0
    struct[rows_at + n] = listed
    # blocks: the connected components of the kept entries
    parent = mark
    for i in range(n):
        parent[i] = i
    for j in range(n):
        for at in range(int(csc[j]), int(csc[j + 1])):
            i = int(csc[at])
            if dropped[i] == 0.0:
                a, b = _root(parent, i), _root(parent, j)
                if a != b:
                    parent[max(a, b)] = min(a, b)
    order, start, offset, colour = _order(struct, n), _start(struct, n), _offset(struct, n), _colour(struct, n)
    block_of, position = f0, moved  # scratch from here on
    for i in range(n):  # the block of each coordinate (its root's), numbered in order of first appearance
        colour[i] = -1  # scratch here: the number of the block whose root is i
    blocks = 0
    for i in range(n):
        root = _root(parent, i)
        if colour[root] < 0:
            colour[root] = blocks
            blocks += 1
        block_of[i] = colour[root]
    for k in range(blocks + 1):
        start[k] = 0
    for i in range(n):
        start[int(block_of[i]) + 1] += 1
    largest, cubes, squares = 0.0, 0.0, 0.0
    for k in range(blocks):
        b = float(start[k + 1])
        largest = max(largest, b)
        cubes += b * b * b
        offset[k + 1] = int(squares + b * b)
        squares += b * b
        start[k + 1] += start[k]
    offset[0] = 0
    if largest * SPARSE_SHARE > n:
        return False
    fill = column  # the next free place in each block's run of ``order``
    for k in range(blocks):
        fill[k] = start[k]
    for i in range(n):
        k = int(block_of[i])
        order[int(fill[k])] = i
        position[i] = fill[k] - start[k]
        fill[k] += 1.0
    struct[S_BLOCKS], struct[S_PACKED], struct[S_DROPPED] = blocks, squares, n_dropped
    struct[S_CUBES], struct[S_SQUARES], struct[S_LARGEST] = cubes, squares, largest
    # colours: greedy, a column takes the first colour no column sharing a kept row with it has
    for j in range(n):  # each kept entry (i, j) into row i's list, in the order of the columns
        for at in range(int(csc[j]), int(csc[j + 1])):
            i = int(csc[at])
            if dropped[i] == 0.0:
                struct[int(struct[rows_at + i])] = j
                struct[rows_at + i] += 1.0
    for i in range(n - 1, 0, -1):  # the starts back in place
        struct[rows_at + i] = struct[rows_at + i - 1]
    struct[rows_at] = rows_at + n + 1.0
    for j in range(n):
        colour[j] = -1
    colours = 0
    for j in range(n):
        for c in range(colours + 1):
            mark[c] = 0.0
        for at in range(int(csc[j]), int(csc[j + 1])):
            i = int(csc[at])
            if dropped[i] == 0.0:
                for listed_at in range(int(struct[rows_at + i]), int(struct[rows_at + i + 1])):
                    k = int(struct[listed_at])
                    if colour[k] >= 0:
                        mark[colour[k]] = 1.0
        c = 0
        while mark[c] != 0.0:
            c += 1
        colour[j] = c
        colours = max(colours, c + 1)
    struct[S_COLOURS] = colours
    # where each entry of the packed blocks comes from: row i of colour(j)'s evaluation (``refresh``), -1 off the
    # pattern; block by block, row i and column j in the block's order
    source = _source(struct, n)
    source[:] = -1
    for j in range(n):
        for at in range(int(csc[j]), int(csc[j + 1])):
            i = int(csc[at])
            if dropped[i] == 0.0:
                k = int(block_of[i])
                b = start[k + 1] - start[k]
                source[offset[k] + int(position[i]) * b + int(position[j])] = colour[j] * n + i
    # the bordered rows: dropped rows i whose coordinate no kept row reads and xi_i does not read either (the
    # entropy's: ds/dt = gamma |p|^2).  A is then block triangular with i last, and the solve finds
    # delta_i = r_i + (h/2) D xi_i . delta from the others' delta by one directional difference
    bordered = 0
    for i in range(n):
        if dropped[i] != 0.0:
            read = False  # column i: any entry in a kept row, or xi_i reading x_i
            for at in range(int(csc[i]), int(csc[i + 1])):
                k = int(csc[at])
                read = read or dropped[k] == 0.0 or k == i
            if not read:
                struct[S_ROWS + bordered] = i
                bordered += 1
    struct[S_BORDERED] = bordered
    return colours * SPARSE_SHARE <= n


@inner
def refresh(model, eps, hamiltonian, x, struct, columns, f0, shifted):
    """``D xi(x)`` on the pattern by differences, one evaluation of xi per colour, into the packed Jacobian;
    ``f0 = xi(x)``.  ``columns`` holds the colours' evaluations (at least colours x n floats: the factors' space,
    which ``factor`` then fills); ``shifted`` is a scratch vector."""
    n = x.shape[0]
    field_into(f0, model, eps, hamiltonian, x)
    delta = difference_step(x)
    colour, order, start, offset = _colour(struct, n), _order(struct, n), _start(struct, n), _offset(struct, n)
    source, jac = _source(struct, n), _packed(struct, n, 1)
    for c in range(int(struct[S_COLOURS])):
        for i in range(n):
            shifted[i] = x[i] + delta if colour[i] == c else x[i]
        field_into(columns[c * n : (c + 1) * n], model, eps, hamiltonian, shifted)
    for k in range(int(struct[S_BLOCKS])):
        first, b, base = start[k], start[k + 1] - start[k], offset[k]
        for a in range(b):
            fi = f0[order[first + a]]
            for at in range(base + a * b, base + (a + 1) * b):
                jac[at] = (columns[source[at]] - fi) / delta if source[at] >= 0 else 0.0
    return f0


@inner
def factor(struct, fac, n, h):
    """``A = I - h/2 D xi`` block by block from the packed Jacobian, factored in place into ``fac`` (the packed
    factors, then the pivots); False where a block is singular."""
    start, offset, jac = _start(struct, n), _offset(struct, n), _packed(struct, n, 1)
    q = int(struct[S_PACKED])
    pivots = fac[q : q + n]
    ok = True
    for k in range(int(struct[S_BLOCKS])):
        first, b, base = int(start[k]), int(start[k + 1] - start[k]), int(offset[k])
        for at in range(base, base + b * b):
            fac[at] = -0.5 * h * jac[at]
        for a in range(b):
            fac[base + a * b + a] += 1.0
        if b == 1:  # the inverse itself
            fac[base] = 1.0 / fac[base]
            ok = ok and np.isfinite(fac[base])
        elif b == 2:  # the inverse itself: [[d, -b], [-c, a]] / (ad - bc)
            a11, a12, a21, a22 = fac[base], fac[base + 1], fac[base + 2], fac[base + 3]
            det = a11 * a22 - a12 * a21
            fac[base], fac[base + 1], fac[base + 2], fac[base + 3] = a22 / det, -a12 / det, -a21 / det, a11 / det
            ok = ok and det != 0.0 and np.isfinite(det)
        else:
            ok = lu_factor(fac, base, b, pivots, first) and ok
    return ok


@inner
def keep_base(struct, x, f0, base):
    """At a refresh: the point of the Jacobian into ``base`` and xi there on the bordered rows (``solve``)."""
    for i in range(x.shape[0]):
        base[i] = x[i]
    for r in range(int(struct[S_BORDERED])):
        struct[S_XI + r] = f0[int(struct[S_ROWS + r])]


@inner
def solve(model, eps, hamiltonian, h, struct, fac, n, rhs, gather, base, moved):
    """``rhs = A^-1 rhs`` (in place) block by block with ``factor``'s factors, then the bordered rows: ``delta_i =
    r_i + (h/2) D xi_i(base) . delta``, the directional derivative by one difference of xi along the others'
    delta.  ``gather`` and ``moved`` are scratch vectors, ``base`` the Jacobian's point (``keep_base``).
    Returns the evaluations of xi (0 or 1)."""
    order, start, offset = _order(struct, n), _start(struct, n), _offset(struct, n)
    q = int(struct[S_PACKED])
    pivots = fac[q : q + n]
    for k in range(int(struct[S_BLOCKS])):
        first, b, at = int(start[k]), int(start[k + 1] - start[k]), int(offset[k])
        if b == 1:
            i = int(order[first])
            rhs[i] *= fac[at]
            continue
        if b == 2:
            i, j = int(order[first]), int(order[first + 1])
            r1, r2 = rhs[i], rhs[j]
            rhs[i] = fac[at] * r1 + fac[at + 1] * r2
            rhs[j] = fac[at + 2] * r1 + fac[at + 3] * r2
            continue
        for a in range(b):
            gather[a] = rhs[int(order[first + a])]
        lu_solve(fac, at, b, pivots, first, gather)
        for a in range(b):
            rhs[int(order[first + a])] = gather[a]
    bordered = int(struct[S_BORDERED])
    if bordered == 0:
        return 0
    for r in range(bordered):
        struct[S_R + r] = rhs[int(struct[S_ROWS + r])]  # r_i: the block solve left the bordered rows as they were
        rhs[int(struct[S_ROWS + r])] = 0.0
    size = norm_inf(rhs)
    tau = SQRT_EPS * (1.0 + norm_inf(base)) / size if size > 0.0 else 0.0
    if size > 0.0:
        for i in range(n):
            moved[i] = base[i] + tau * rhs[i]
        field_into(gather, model, eps, hamiltonian, moved)
    for r in range(bordered):
        i = int(struct[S_ROWS + r])
        slope = (gather[i] - struct[S_XI + r]) / tau if size > 0.0 else 0.0
        rhs[i] = struct[S_R + r] + 0.5 * h * slope
    return 1 if size > 0.0 else 0


@inner
def refresh_evaluations(struct):
    """The evaluations of xi a refresh takes: one per colour and one at the state."""
    return int(struct[S_COLOURS]) + 1


@inner
def refresh_cost(struct, field):
    """A refresh in evaluations of the discrete field (``field``: its modelled flops): ``refresh_evaluations`` of
    xi at ``XI_SHARE`` of one each, and the blocks' factorisation, ``sum_b 2 b^3 / 3`` flops."""
    return XI_SHARE * refresh_evaluations(struct) + 2.0 * struct[S_CUBES] / (3.0 * field)


@inner
def solve_weight(struct, field):
    """A Newton iteration in evaluations of the discrete field: one, the blocks' solve ``sum_b 2 b^2`` flops and,
    with bordered rows, one xi at ``XI_SHARE``."""
    return 1.0 + (XI_SHARE if struct[S_BORDERED] > 0.0 else 0.0) + 2.0 * struct[S_SQUARES] / field
