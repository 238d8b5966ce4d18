#!/usr/bin/env python
"""Mutation testing of uqdrive's core modules: a small, self-contained AST mutator.

Each mutant is one small change to one module (an operator flipped, a constant changed, a
return value dropped, a condition negated, min/max swapped, ...). The module's tests (the test
files that import it) run against every mutant; a mutant is *killed* when they fail (or time
out) and *survives* when they pass. The score is killed / total per module; survivors are
listed with file:line and the mutation, and those judged equivalent (no observable change) in
:data:`EQUIVALENT` are counted apart, with the reason.

Everything runs on a copy of the repository in a temporary directory (``--workdir``): the
working tree is never touched. Not part of CI: ``make mutation`` or

    .venv/bin/python tools/mutate.py --module gp --sample 40 --seed 1
    .venv/bin/python tools/mutate.py --module identify --list          # the mutants, no run

Options: ``--module`` (repeatable; default: all of MODULES), ``--sample N --seed S`` (a
reproducible random sample of N mutants per module), ``--timeout`` (seconds per mutant;
default 3x the unmutated run + 30 s), ``--tests`` (override the test files), ``--match`` (only
mutants whose "line:col description segment" contains a text, e.g. to re-check survivors),
``--json`` (write the results), ``--keep`` (keep the copy).

Test runs use one BLAS thread (the machine is shared; the baseline runs the same way), stop at
the first failure (-x), and fix Hypothesis' seed, so a mutant's verdict is reproducible.
"""

from __future__ import annotations

import argparse
import ast
import copy
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: Core modules and where they live under src/uqdrive (if a layout step moves one, it is found
#: by its file name instead).
MODULES = {"gp": "wheelslip/gp.py", "galerkin": "numerics/galerkin.py", "identify": "inference/identify.py", "slqr": "control/slqr.py",
           "statistics": "vehicle/statistics.py", "scorecard": "studies/scorecard.py", "fit": "inference/discrepancy/fit.py",
           "effectset": "inference/discrepancy/effectset.py", "band": "inference/discrepancy/band.py",
           "selection": "inference/discrepancy/selection.py"}

#: Test files never run for a mutant (the end-to-end Snakemake DAG).
EXCLUDED_TESTS = ("test_workflow.py",)

#: Survivors judged equivalent (no observable change of any output), per module: dicts with
#: ``line`` (a fragment of the original source line), ``mutation`` (the description printed),
#: optionally ``mutated`` (a fragment of the mutated line, when one line has several alike) and
#: ``reason``. Matched by text, not by line number, so they survive edits elsewhere.
_CLIP = ("|z| = |u| / sqrt(ab) <= sqrt((a - 1)(b - 1) / (ab)) < 1 (Cauchy-Schwarz), with a margin 1 - |z| > 1e-5 for data of "
         "order 1 anywhere in the box |log g| <= 9: the clip is never active")
_TOL = "a stopping tolerance or iteration cap doubled: the optimum moves far less than any stated accuracy"
EQUIVALENT: dict[str, list[dict[str, str]]] = {
    "gp": [
        *({"line": "z = np.clip(z, -1 + 1e-15, 1 - 1e-15)", "mutation": m, "reason": _CLIP}
          for m in ("constant 1e-15 -> 2e-15", "constant 1 -> 2", "`+` -> `-`", "`-` -> `+`")),
        *({"line": "np.arcsin(np.clip(z, -1.0, 1.0))", "mutation": "constant 1.0 -> 2.0", "reason": _CLIP},),
        {"line": "res.fun < best.fun", "mutation": "`<` -> `<=`", "reason": "differs on exact ties of the NLL only (equal optima)"},
        *({"line": "self.rng.uniform(-3, 3, D + 3)", "mutation": "constant 3 -> 4", "mutated": m,
           "reason": "the box the random restarts are drawn from, [-4, 3] or [-3, 4] instead of [-3, 3]: a tuning choice (the "
                     "starts stay distinct, spread over both signs and inside the search box, as the tests require)"}
          for m in ("uniform(-(4), 3,", "uniform(-3, (4),")),
        {"line": "self._posterior(k_star[r], k_ss[r : r + 1], f[1], f[2])", "mutation": "constant 1 -> 2",
         "reason": "k_ss[r : r + 2] holds one more prior variance, broadcast to a second output entry that `a[0]` never reads"},
        {"line": "self._jitter = 1e-10", "mutation": "constant 1e-10 -> 2e-10",
         "reason": "diagonal regularisation of K; 1e-10 more changes outputs by ~1e-10 relative, below every stated accuracy"},
    ],
    "galerkin": [
        {"line": "PolynomialChaos(parametric + linear, order, quadrature_points=1)", "mutation": "constant 1 -> 2",
         "reason": "the projector's chaos serves its indices, order and Sobol indices; its own quadrature is never used"},
        {"line": "evaluate(np.array([1.0]), 1)[0, 1]", "mutation": "constant 1 -> 2", "mutated": "np.array([1.0]), (2))[0, 1]",
         "reason": "evaluating up to degree 2 instead of 1 leaves column 1 (the degree-1 polynomial) unchanged"},
        {"line": "self.G_par.reshape(-1, self.G_par.shape[-1])", "mutation": "constant 1 -> 2", "mutated": "reshape(-(2), self",
         "reason": "numpy reads any negative size as the one to infer: reshape(-2, Q) == reshape(-1, Q)"},
        {"line": "d = v.shape[-1]", "mutation": "constant 1 -> 2", "reason": "A's values are square (d x d): shape[-2] == shape[-1]"},
        {"line": "optimize=True", "mutation": "constant True -> False", "reason": "einsum's contraction order only; same values"},
        {"line": "for b in range(self.n_linear + 1)", "mutation": "constant 1 -> 2", "mutated": "range(self.n_linear + (2))",
         "reason": "one more block index, n_linear + 1, which no term belongs to: an empty block"},
        {"line": "return self.linear_input_matrix(values).sum(axis=-1)", "mutation": "drop unary `-`",
         "reason": "for the documented values (Q, d, n_linear) the matrix is (d P, n_linear): axis 1 is axis -1"},
        {"line": "return X.reshape(X.shape[:-1] + (-1, self.n_terms))", "mutation": "constant 1 -> 2", "mutated": "+ (-(2), self.n_terms)",
         "reason": "numpy reads any negative size as the one to infer"},
        {"line": "@functools.lru_cache(maxsize=16)", "mutation": "constant 16 -> 17", "reason": "cache size only"},
    ],
    "identify": [
        {"line": '"ftol": 1e-15, "gtol": 1e-10', "mutation": "constant 1e-15 -> 2e-15", "reason": _TOL},
        {"line": '"ftol": 1e-15, "gtol": 1e-10', "mutation": "constant 1e-10 -> 2e-10", "reason": _TOL},
        {"line": 'method="trf", ftol=1e-12, xtol=1e-12, gtol=1e-12', "mutation": "constant 1e-12 -> 2e-12", "reason": _TOL},
        {"line": "max_iter: int = 300", "mutation": "constant 300 -> 301", "reason": _TOL},
        {"line": "abs(again.fun - best.fun) <= 1e-9 * abs(best.fun)", "mutation": "constant 1e-09 -> 2e-09", "reason": _TOL},
        {"line": "np.maximum(r.variance, 1e-300)", "mutation": "constant 1e-300 -> 2e-300",
         "reason": "floor of a variance before its square root: 1e-150 vs 1.4e-150 m, never reached by a physical model"},
        {"line": "self._J0 = max(first[0], 1e-300)", "mutation": "constant 1e-300 -> 2e-300", "reason": "floor of the cost scale, only for a zero initial cost"},
        {"line": "np.where(np.abs(theta0) > 1e-8, np.abs(theta0), 1.0)", "mutation": "constant 1e-08 -> 2e-08",
         "reason": "the threshold below which a start value gets scale 1: rescaling the search only"},
        {"line": "np.where(np.abs(theta0) > 1e-8, np.abs(theta0), 1.0)", "mutation": "constant 1.0 -> 2.0",
         "reason": "the scale of parameters that start at zero: rescaling the search only"},
        {"line": "return np.full(n, np.sqrt(est._penalty / n))", "mutation": "`/` -> `*`",
         "reason": "a larger penalty residual for non-physical trial points: the step is rejected either way"},
        {"line": "if best is None or res.fun < best.fun:", "mutation": "`<` -> `<=`", "reason": "differs on exact ties of the cost only"},
        {"line": "if again.success and again.fun <= best.fun:", "mutation": "`<=` -> `<`",
         "reason": "on an exact tie the restart is accepted by the next branch (change < 1e-9): converged either way"},
        {"line": "if self.starts <= 0:", "mutation": "`<=` -> `<`", "reason": "starts = 0 gives 24 x 0 = no candidates either way"},
        {"line": 'if "z" not in cache or not np.array_equal(cache["z"], z):', "mutation": "drop unary `not`", "mutated": 'or (np.array_equal',
         "reason": "least_squares asks for the Jacobian only at the point it evaluated last, so the cache always matches; the "
                   "mutant recomputes it there (cost only)"},
        {"line": "out = self._objective(np.asarray(theta, float), gradient=False)", "mutation": "constant False -> True",
         "reason": "cost_function returns out[0], the cost; the mutant computes the gradient too and drops it"},
        {"line": "best.fun < self._penalty)", "mutation": "`<` -> `<=`",
         "reason": "the start must be physical (else ValueError) and costs 1 in scaled units; the local optimisers never end above "
                   "their start, so best.fun <= 1 < 1e6 and equality with the penalty cannot occur"},
        {"line": "n = 24 * self.starts", "mutation": "constant 24 -> 25",
         "reason": "size of the random candidate pool of the global stage: a tuning choice, no specified output"},
        {"line": 'RuntimeWarning, stacklevel=2', "mutation": "constant 2 -> 3",
         "reason": "the frame the warning names; 3 would in fact be right (the warning is raised in _fit, under fit): reported, not a test gap"},
        {"line": "def moments(self, theta, gradient: bool = False): ...", "mutation": "constant False -> True",
         "reason": "the default of a Protocol stub, never executed"},
    ],
    "slqr": [
        {"line": '"gtol": 1e-9, "maxiter": 500', "mutation": "constant 1e-09 -> 2e-09", "reason": _TOL},
        {"line": '"gtol": 1e-9, "maxiter": 500', "mutation": "constant 500 -> 501", "reason": _TOL},
        {"line": "np.sum(u[:, 1:] ** 2, axis=-1)", "mutation": "drop unary `-`", "mutated": "u[:, 1:] ** 2, axis=(1))",
         "reason": "u is (time, terms): axis 1 is axis -1"},
        {"line": "self.X0 = pr.initial_state(x0_mean) + pr.linear_initial_state(x0_lin)", "mutation": "`+` -> `-`",
         "reason": "the initial-condition germs are U(-1, 1), symmetric and entering nothing else: m - h xi has the distribution "
                   "of m + h xi, so every moment and the cost are unchanged"},
        {"line": "np.zeros((4,) + self.E.shape)", "mutation": "constant 4 -> 5",
         "reason": "E does not depend on K: its derivative directions are zeros, and a fifth zero direction is never read"},
    ],
    "statistics": [],
    "scorecard": [
        {"line": "+ 1e-12 if np.isfinite(miss) else 0.0", "mutation": "constant 0.0 -> 1.0",
         "reason": "the slack of a row whose miss is infinite (reproduced NaN): inf > 0 and inf > 1 agree, as do inf < -0 and inf < -1"},
        {"line": "(r.status == \"pass\" and miss > slack)", "mutation": "`>` -> `>=`",
         "reason": "differs only when the miss equals the 6-digit slack to the last bit: an exact tie of two computed doubles"},
        {"line": "(r.status == \"deviates\" and miss < -slack)", "mutation": "`<` -> `<=`",
         "reason": "differs only when the miss equals minus the 6-digit slack to the last bit: an exact tie of two computed doubles"},
        {"line": "\"holds\": free.size > 0 and misses <= set(WIND_BOUNDS)", "mutation": "constant 0 -> 1",
         "reason": "the unit-free flags are one per parameter, six or none (bayes_study): a size of exactly 1 does not occur"},
        {"line": "holds=extrapolates and hits / max(sets, 1) > 0.95", "mutation": "`>` -> `>=`",
         "reason": "holds matters only for a row outside its tolerance; coverage exactly 0.95 is the nominal value, always inside"},
        {"line": "holds=extrapolates and hits / max(sets, 1) > 0.95", "mutation": "constant 1 -> 2",
         "reason": "differs only for sets = 1, where coverage 1 passes (within 0.427 of 0.95) and coverage 0 gives 0 either way"},
    ],
    "fit": [
        *({"line": "THETA_SCALE = (1.0, 0.2, 1.5, 0.2, 400.0, 400.0)", "mutation": m, "mutated": frag,
           "reason": "a typical magnitude (trf's x_scale and the floor of the difference step 1e-4 max(|p|, typical)) of mu's mean, "
                     "l_f's mean or l_f's std changed by a factor <= 2: a tuning choice; the fits reach their optima to the stated tolerances"}
          for m, frag in (("constant 1.0 -> 2.0", "((2.0), 0.2"), ("constant 1.5 -> 1.0", "0.2, (1.0), 0.2"), ("constant 0.2 -> 0.4", "1.5, (0.4)"))),
        *({"line": "x0 = np.clip(x0, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))", "mutation": m,
           "reason": "how far inside its bounds a start on (or clipped to) a bound begins, 1e-9 of the range: 2e-9 of it, or "
                     "1e-9 / range (trf itself then moves it at least 1e-10 max(1, |bound|) inside); for the ranges of THETA_BOUNDS "
                     "and the effects' bounds (0.1 to 6000) the start moves by < 1e-7 of the range"}
          for m in ("`*` -> `/`", "constant 1e-09 -> 2e-09")),
        {"line": "np.abs(x[self.simulator.spin_row]) > self.spin_threshold, axis=-1)", "mutation": "drop unary `-`",
         "reason": "x[spin_row] is (realisations, times): axis 1 is axis -1"},
        {"line": "h[~free] = 0.0", "mutation": "constant 0.0 -> 1.0",
         "reason": "the steps of known parameters are never read: the neighbours and the quotients take h[free] only"},
    ],
    "band": [
        {"line": "reshape(cells.shape[0], -1).max(axis=1)", "mutation": "constant 1 -> 2", "mutated": "reshape(cells.shape[0], -(2))",
         "reason": "numpy reads any negative size as the one to infer"},
        {"line": "per_call = max(1, 4000 // max(n, 1))", "mutation": "constant 1 -> 2", "mutated": "max(n, (2))",
         "reason": "differs only for n = 1 realisation, whose std (ddof 1) is undefined: no band of n = 1 is ever made"},
        {"line": "per_call = max(1, 4000 // max(n, 1))", "mutation": "constant 4000 -> 4001",
         "reason": "4001 is prime: 4001 // n == 4000 // n for 2 <= n <= 4000, and beyond both give one replicate per simulation"},
        {"line": "xb = xb.reshape(x.shape[0], reps, n, -1)", "mutation": "constant 1 -> 2", "mutated": "reps, n, -(2))",
         "reason": "numpy reads any negative size as the one to infer"},
        {"line": "np.abs(xb[sim.spin_row]) > spin", "mutation": "`>` -> `>=`",
         "reason": "differs only when a simulated |beta| equals the spin threshold to the last bit: an exact tie of a continuous value"},
    ],
    "selection": [
        *({"line": line, "mutation": "`+` -> `-`", "reason": "the key of a bootstrap's random stream: another key draws another, equally valid null band"}
          for line in ("after_band, which = comparison.own_band(fc, key=step + 1)",
                       "pair = pair_step(comparison, fitter, cur, cur_band, names, values, fits, screening, stalled, (after_band, which), prev_gap, key=step + 1)")),
        {"line": "excess_rms(fc.z_, band) <= 0.5 * prev_gap", "mutation": "`<=` -> `<`",
         "reason": "differs on an exact tie of two continuous gaps only"},
    ],
}

IGNORE_COPY = shutil.ignore_patterns(".git", ".venv", ".snakemake", "results", ".hypothesis", ".ruff_cache", ".pytest_cache", "__pycache__", "*.pyc",
                                     "*.egg-info", "build")


# -- mutants ---------------------------------------------------------------------------------
@dataclass
class Mutant:
    module: str
    path: str  # relative to the repository
    line: int
    col: int
    description: str
    source_line: str
    segment: str  # the original text of the mutated node
    mutated_line: str  # the line as the mutant reads it
    start: int  # byte offsets of the replaced segment in the original source
    end: int
    replacement: str
    status: str = "pending"  # killed | survived | timeout | equivalent | error
    seconds: float = 0.0
    reason: str = ""

    @property
    def where(self) -> str:
        return f"{self.path}:{self.line}:{self.col}"


_BINOP_SWAP = {ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult, ast.FloorDiv: ast.Div, ast.Pow: ast.Mult, ast.Mod: ast.FloorDiv,
               ast.BitAnd: ast.BitOr, ast.BitOr: ast.BitAnd}
_CMP_SWAPS = {ast.Lt: (ast.LtE, ast.Gt), ast.LtE: (ast.Lt, ast.GtE), ast.Gt: (ast.GtE, ast.Lt), ast.GtE: (ast.Gt, ast.LtE), ast.Eq: (ast.NotEq,),
              ast.NotEq: (ast.Eq,), ast.Is: (ast.IsNot,), ast.IsNot: (ast.Is,), ast.In: (ast.NotIn,), ast.NotIn: (ast.In,)}
_SYMBOL = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.FloorDiv: "//", ast.Pow: "**", ast.Mod: "%", ast.BitAnd: "&", ast.BitOr: "|",
           ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!=", ast.Is: "is", ast.IsNot: "is not", ast.In: "in",
           ast.NotIn: "not in", ast.And: "and", ast.Or: "or"}
_CALL_SWAP = {"min": "max", "max": "min", "minimum": "maximum", "maximum": "minimum", "argmin": "argmax", "argmax": "argmin", "any": "all", "all": "any",
              "nanmin": "nanmax", "nanmax": "nanmin"}


def _new_constant(value):
    """The mutated value of a numeric constant: 0 -> 1, 1 -> 2, other ints n -> n + 1; floats
    with |c| > 1 -> 1.0 (e.g. a box (-9, 9) capped at 1) and |c| < 1 -> 2 c."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        if value == 0.0:
            return 1.0
        if value == 1.0:
            return 2.0
        return 1.0 if abs(value) > 1.0 else 2.0 * value
    return None


def _call_name(func):
    if isinstance(func, ast.Name):
        return func.id
    if isinstance(func, ast.Attribute):
        return func.attr
    return None


class _Collector(ast.NodeVisitor):
    """Walks a module and records (node, new_node_or_text, description) mutation points."""

    def __init__(self):
        self.points = []  # (node, replacement text, description)
        self._function = []

    # subtrees never mutated: docstrings/strings, annotations, f-strings, raise, __all__
    def visit_JoinedStr(self, node):
        return

    def visit_Raise(self, node):
        return

    def visit_Assign(self, node):
        if any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            return
        self.visit(node.value)

    def visit_AnnAssign(self, node):
        if node.value is not None:
            self.visit(node.value)

    def visit_arg(self, node):
        return  # annotations

    def _visit_function(self, node):
        self._function.append(node.name)
        for d in node.decorator_list:
            self.visit(d)
        self.visit(node.args)  # defaults (args themselves are skipped)
        for stmt in node.body:
            self.visit(stmt)
        self._function.pop()

    visit_FunctionDef = visit_AsyncFunctionDef = _visit_function

    def visit_Expr(self, node):
        if isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            return  # docstring
        self.generic_visit(node)

    def _expr(self, node, new, description):
        self.points.append((node, "(" + ast.unparse(new) + ")", description))

    def visit_BinOp(self, node):
        swap = _BINOP_SWAP.get(type(node.op))
        if swap is not None:
            new = copy.deepcopy(node)
            new.op = swap()
            self._expr(node, new, f"`{_SYMBOL[type(node.op)]}` -> `{_SYMBOL[swap]}`")
        self.generic_visit(node)

    def visit_AugAssign(self, node):
        swap = _BINOP_SWAP.get(type(node.op))
        if swap is not None:
            new = copy.deepcopy(node)
            new.op = swap()
            self.points.append((node, ast.unparse(new), f"`{_SYMBOL[type(node.op)]}=` -> `{_SYMBOL[swap]}=`"))
        self.visit(node.value)

    def visit_Compare(self, node):
        for i, op in enumerate(node.ops):
            for swap in _CMP_SWAPS.get(type(op), ()):
                new = copy.deepcopy(node)
                new.ops[i] = swap()
                self._expr(node, new, f"`{_SYMBOL[type(op)]}` -> `{_SYMBOL[swap]}`")
        self.generic_visit(node)

    def visit_BoolOp(self, node):
        new = copy.deepcopy(node)
        new.op = ast.Or() if isinstance(node.op, ast.And) else ast.And()
        self._expr(node, new, f"`{_SYMBOL[type(node.op)]}` -> `{_SYMBOL[type(new.op)]}`")
        self.generic_visit(node)

    def visit_UnaryOp(self, node):
        if isinstance(node.op, (ast.USub, ast.Not)):
            self._expr(node, node.operand, f"drop unary `{'-' if isinstance(node.op, ast.USub) else 'not'}`")
        self.generic_visit(node)

    def visit_Constant(self, node):
        value = _new_constant(node.value)
        if value is not None:
            self._expr(node, ast.Constant(value), f"constant {node.value!r} -> {value!r}")

    def visit_Call(self, node):
        name = _call_name(node.func)
        if name in _CALL_SWAP:
            new = copy.deepcopy(node)
            if isinstance(new.func, ast.Name):
                new.func.id = _CALL_SWAP[name]
            else:
                new.func.attr = _CALL_SWAP[name]
            self._expr(node, new, f"`{name}` -> `{_CALL_SWAP[name]}`")
        elif name == "abs" and len(node.args) == 1 and not node.keywords:
            self._expr(node, node.args[0], "drop `abs`")
        self.generic_visit(node)

    def visit_Return(self, node):
        if node.value is not None and not (isinstance(node.value, ast.Constant) and node.value.value is None):
            self.points.append((node.value, "(None)", "return value -> None"))
            self.visit(node.value)

    def _negate(self, test):
        self.points.append((test, None, "negate condition"))

    def visit_If(self, node):
        self._negate(node.test)
        self.generic_visit(node)

    visit_While = visit_IfExp = visit_If

    def visit_comprehension(self, node):
        for cond in node.ifs:
            self._negate(cond)
        self.generic_visit(node)


def _line_offsets(data: bytes):
    offsets, pos = [0], 0
    for line in data.splitlines(keepends=True):
        pos += len(line)
        offsets.append(pos)
    return offsets


def find_module(name: str, root: Path = REPO) -> Path:
    package = root / "src" / "uqdrive"
    if (package / MODULES[name]).is_file():
        return package / MODULES[name]
    hits = sorted(p for p in package.rglob(f"{name}.py") if p.parent.name != "cli")
    if len(hits) != 1:
        raise SystemExit(f"module '{name}': expected one src/uqdrive/**/{name}.py, found {[str(h) for h in hits]}")
    return hits[0]


def mutants_of(name: str, root: Path = REPO) -> list[Mutant]:
    """Every mutant of module ``name``, in source order, deduplicated by the resulting AST."""
    path = find_module(name, root)
    data = path.read_bytes()
    text = data.decode()
    tree = ast.parse(text)
    original = ast.dump(tree)
    offsets = _line_offsets(data)
    lines = text.splitlines()
    collector = _Collector()
    collector.visit(tree)
    seen, out = {original}, []
    for node, replacement, description in collector.points:
        start = offsets[node.lineno - 1] + node.col_offset
        end = offsets[node.end_lineno - 1] + node.end_col_offset
        segment = data[start:end].decode()
        if replacement is None:  # negated condition
            replacement = f"(not ({segment}))"
        mutated = (data[:start] + replacement.encode() + data[end:]).decode()
        try:
            dump = ast.dump(ast.parse(mutated))
        except SyntaxError:
            continue
        if dump in seen:
            continue
        seen.add(dump)
        out.append(Mutant(name, str(path.relative_to(root)), node.lineno, node.col_offset, description, lines[node.lineno - 1].strip(),
                          " ".join(segment.split()), mutated.splitlines()[node.lineno - 1].strip(), start, end, replacement))
    out.sort(key=lambda m: (m.start, m.description))
    return out


def apply(m: Mutant, root: Path) -> str:
    """Write mutant ``m`` into the copy at ``root``; returns the original text to restore."""
    path = root / m.path
    data = path.read_bytes()
    path.write_bytes(data[: m.start] + m.replacement.encode() + data[m.end :])
    return data


def equivalent_reason(m: Mutant) -> str:
    for e in EQUIVALENT.get(m.module, []):
        if e["line"] in m.source_line and e["mutation"] == m.description and e.get("mutated", "") in m.mutated_line:
            return e["reason"]
    return ""


def _short(text: str, n: int = 60) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


# -- tests -----------------------------------------------------------------------------------
def importing_tests(module_path: Path, root: Path) -> list[str]:
    """Test files (relative paths) that import the module directly; its own test file first."""
    dotted = ".".join(module_path.relative_to(root / "src").with_suffix("").parts)  # uqdrive.a.b
    parent, leaf = dotted.rsplit(".", 1)
    found = []
    for f in sorted((root / "tests").glob("test_*.py")):
        if f.name in EXCLUDED_TESTS:
            continue
        for node in ast.walk(ast.parse(f.read_text())):
            hit = False
            if isinstance(node, ast.Import):
                hit = any(a.name == dotted or a.name.startswith(dotted + ".") for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module:
                hit = node.module == dotted or node.module.startswith(dotted + ".") or (node.module == parent and any(a.name == leaf for a in node.names))
            if hit:
                found.append(str(f.relative_to(root)))
                break
    own = f"tests/test_{leaf}.py"
    return sorted(found, key=lambda p: (p != own, p))


def run_tests(root: Path, tests, timeout: float | None) -> tuple[str, float, str]:
    """Run pytest on ``tests`` in the copy; (status, seconds, tail of the output)."""
    env = dict(os.environ)
    env.update(PYTHONPATH=str(root / "src"), PYTHONDONTWRITEBYTECODE="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    cmd = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-x", "-q", "--no-header", "-o", "addopts=", "--hypothesis-seed=0", *tests]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=root, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the process group of the pytest we started
        out, _ = proc.communicate()
        return "timeout", time.perf_counter() - t0, out[-2000:]
    seconds = time.perf_counter() - t0
    if proc.returncode == 0:
        return "survived", seconds, out[-2000:]
    if proc.returncode in (1, 2):  # a test failed, or collection failed (the mutant breaks an import)
        return "killed", seconds, out[-2000:]
    return "error", seconds, out[-2000:]  # 3-5: internal error, usage error, no tests


def make_copy(workdir: str | None) -> Path:
    base = Path(workdir) if workdir else Path(tempfile.mkdtemp(prefix="uqdrive-mutation-"))
    root = base / "repo"
    if root.exists():
        shutil.rmtree(root)
    shutil.copytree(REPO, root, ignore=IGNORE_COPY)
    return root


def score_line(name, ms):
    killed = sum(m.status in ("killed", "timeout") for m in ms)
    equiv = sum(m.status == "equivalent" for m in ms)
    total = len(ms)
    denom = total - equiv
    pct = 100.0 * killed / denom if denom else float("nan")
    return killed, total, equiv, f"{name:<11s} killed {killed:3d} / {total:3d} ({100.0 * killed / max(total, 1):5.1f} %); equivalent {equiv:2d}; " \
                                   f"score over non-equivalent {killed}/{denom} = {pct:5.1f} %"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--module", action="append", choices=MODULES, help="module to mutate (repeatable; default all)")
    ap.add_argument("--sample", type=int, default=0, help="random sample of N mutants per module (0: all)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the sample")
    ap.add_argument("--timeout", type=float, default=None, help="seconds per mutant (default 3x the unmutated run + 30)")
    ap.add_argument("--tests", nargs="+", help="test files to run instead of those importing the module")
    ap.add_argument("--workdir", help="directory for the copy of the repository (default: a new temporary directory)")
    ap.add_argument("--keep", action="store_true", help="keep the copy")
    ap.add_argument("--match", action="append", help="keep only mutants whose 'line:col description segment' contains this text (repeatable)")
    ap.add_argument("--list", action="store_true", help="list the (sampled) mutants and exit")
    ap.add_argument("--json", help="write every mutant's result to this file")
    args = ap.parse_args(argv)
    modules = args.module or list(MODULES)
    # Mutants are enumerated on the copy (byte offsets stay valid while others edit the tree).
    root = REPO if args.list else make_copy(args.workdir)

    plan = {}
    for name in modules:
        ms = mutants_of(name, root)
        if args.match:
            ms = [m for m in ms if any(t in f"{m.line}:{m.col} {m.description} {m.segment}" for t in args.match)]
        n_all = len(ms)
        if args.sample and args.sample < len(ms):
            ms = sorted(random.Random(f"{args.seed}:{name}").sample(ms, args.sample), key=lambda m: (m.start, m.description))
        plan[name] = ms
        print(f"{name}: {len(ms)} of {n_all} mutants ({find_module(name, root).relative_to(root)})", flush=True)
    if args.list:
        for ms in plan.values():
            for m in ms:
                print(f"  {m.where}: {m.description:28s} in `{_short(m.segment)}`" + ("  [judged equivalent]" if equivalent_reason(m) else ""))
        return 0

    print(f"copy of the repository: {root}", flush=True)
    results = {}
    try:
        for name, ms in plan.items():
            tests = args.tests or importing_tests(find_module(name, root), root)
            print(f"\n== {name}: {len(ms)} mutants; tests: {' '.join(tests)}", flush=True)
            status, base, out = run_tests(root, tests, None)
            if status != "survived":
                print(f"the unmutated tests fail ({status}); skipping {name}\n{out}", flush=True)
                continue
            timeout = args.timeout or 3.0 * base + 30.0
            print(f"   unmutated run {base:.1f} s; timeout {timeout:.0f} s per mutant", flush=True)
            for i, m in enumerate(ms, 1):
                original = apply(m, root)
                try:
                    m.status, m.seconds, out = run_tests(root, tests, timeout)
                finally:
                    (root / m.path).write_bytes(original)
                if m.status == "survived":
                    m.reason = equivalent_reason(m)
                    if m.reason:
                        m.status = "equivalent"
                if m.status == "error":
                    m.reason = out.strip().splitlines()[-1] if out.strip() else "pytest error"
                print(f"   [{i:3d}/{len(ms)}] {m.status:10s} {m.seconds:6.1f} s  {m.where}: {m.description} in `{_short(m.segment)}`", flush=True)
            results[name] = ms
    finally:
        if not args.keep:
            shutil.rmtree(root.parent if not args.workdir else root, ignore_errors=True)

    print("\n== mutation scores (killed = tests fail or time out)")
    tk = tt = te = 0
    for name, ms in results.items():
        k, t, e, line = score_line(name, ms)
        tk, tt, te = tk + k, tt + t, te + e
        print(line)
    if results:
        print(f"{'overall':<11s} killed {tk:3d} / {tt:3d} ({100.0 * tk / max(tt, 1):5.1f} %); non-equivalent {tk}/{tt - te} = "
              f"{100.0 * tk / max(tt - te, 1):5.1f} %")
    for name, ms in results.items():
        rest = [m for m in ms if m.status in ("survived", "equivalent", "error")]
        if rest:
            print(f"\n{name}: survivors")
            for m in rest:
                tag = {"survived": "SURVIVED", "equivalent": "equivalent", "error": "ERROR"}[m.status]
                print(f"  {tag:10s} {m.where}: {m.description} in `{_short(m.segment)}`" + (f"\n             ({m.reason})" if m.reason else ""))
    if args.json:
        Path(args.json).write_text(json.dumps({n: [asdict(m) for m in ms] for n, ms in results.items()}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
