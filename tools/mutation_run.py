"""Mutation testing of the paper's core modules: small deterministic mutants, one at a time.

Not part of the test suite (``python -m pytest`` never collects it); an optional check of
how many small bugs in the compiler, the Focused solver, the belief layer, perception and the
kitchen's streams the fast tests notice.  From the repository root:

    python tools/mutation_run.py --json /tmp/mutation-head.json

See tools/README.md for the options, the before/after comparison and what the numbers mean.

How it works:

1. ``git archive HEAD`` of ``--repo`` (default: this checkout) is unpacked in a temporary
   folder; nothing in the checkout is ever modified.
2. Mutants are made from the Python ``ast`` of each target file: comparison flips
   (``==``/``!=``, ``<``/``<=``, ``in``/``not in`` ...), ``and``/``or``, ``not x`` -> ``x``,
   constants (int ``n`` -> ``n + 1``, float ``x`` -> ``2 x``, ``True``/``False``), arithmetic
   (``+``/``-``, ``*``/``/``), ``min``/``max`` and ``any``/``all`` swapped, ``return x`` ->
   ``return None``, and statements removed (calls, augmented assignments, assignments to an
   attribute or item, ``break``/``continue``/``raise``).  Docstrings, annotations and f-strings
   are left alone.  Each mutant replaces one source span, so line numbers stay put.
3. A mutant is sampled when a hash of its key (logical file, enclosing function, operator,
   original and replacement text, occurrence number) falls below ``--sample``; the key holds
   no line number, so an unchanged function yields the same sampled mutants at any commit.
4. The chosen tests run once with a line tracer (the baseline): each test's covered lines in
   the target files and its time.  A test that fails at baseline is dropped (and listed).
5. Each mutant runs, with ``-x``, only the baseline tests that executed its lines (fastest
   first); lines run only while importing run every test that touched the file.  A mutant no
   test executes is "uncovered" (it survives without any test run).  The tests run in a child
   forked from a process that has already imported the heavy third-party libraries (numpy,
   pybullet, matplotlib, unified-planning ...) but none of the project, so each mutant costs
   about its tests' run time.  One child at a time; a per-mutant timeout.

Score = (killed + timeout) / sampled mutants, per file and overall; uncovered mutants count
as survivors.
"""

from __future__ import annotations

import argparse
import ast
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from dataclasses import asdict, dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

# The modules issue 18 names: the compiler's instantiation, derived predicates and plan
# constraints (compile/costs.py runs under nearly every compile test, too dear here); the Focused solver; the belief package (plot.py aside); the camera's
# visibility; the kitchen's streams.
DEFAULT_FILES = [
    "ssr_compile/compile/derived.py",
    "ssr_compile/compile/instantiate.py",
    "ssr_compile/compile/constraints.py",
    "ssr_compile/solver/focused.py",
    "ssr_compile/belief/particles.py",
    "ssr_compile/belief/observation.py",
    "ssr_compile/belief/visibility.py",
    "ssr_compile/belief/determinize.py",
    "sim/perception.py",
    "streams/kitchen_module.py",
    "streams/kitchen_motion.py",
    "streams/kitchen_belief.py",
]

# Where a target lived before the belief layer became ssr_compile.belief (commit 0caa393): a
# target missing from --repo is read from here, under its current name (so mutants match).
MOVED = {
    "ssr_compile/belief/particles.py": "streams/belief.py",
    "ssr_compile/belief/observation.py": "streams/belief_obs.py",
    "ssr_compile/belief/visibility.py": "streams/visibility.py",
}

# The fast tests of those modules (files missing at a commit are skipped); tests marked slow
# and the closed-loop episode files (test_policy.py, test_kitchen_closed_loop.py) are not run.
DEFAULT_TESTS = [
    "tests/test_belief.py",
    "tests/test_belief_detect.py",
    "tests/test_belief_streams_once.py",
    "tests/test_belief_thresholds.py",
    "tests/test_compile.py",
    "tests/test_compile_passes.py",
    "tests/test_constraints.py",
    "tests/test_costs_once.py",
    "tests/test_derived_semantics.py",
    "tests/test_focused.py",
    "tests/test_focused_state.py",
    "tests/test_instance_cap.py",
    "tests/test_kitchen_domain.py",
    "tests/test_kitchen_state.py",
    "tests/test_kitchen_stream_tests.py",
    "tests/test_paper_claims.py",
    "tests/test_sim_world.py",
    "tests/test_visibility.py",
]

# Imported once in the parent so that each forked child skips them; none imports the project.
HEAVY_IMPORTS = [
    "numpy",
    "pybullet",
    "lark",
    "matplotlib",
    "matplotlib.pyplot",
    "hypothesis",
    "unified_planning",
    "unified_planning.shortcuts",
    "pyperplan",
    "tqdm",
    "PIL",
]

PYTEST_ARGS = ["-q", "-x", "-rfE", "-p", "no:cacheprovider", "-p", "no:randomly", "-m", "not slow"]


# ------------------------------------------------------------------------------ mutants


@dataclass
class Mutant:
    file: str  # path in the repository
    logical: str  # the module's name for matching across commits
    line: int
    end_line: int
    lines: list[int]  # lines whose execution means the mutant's code ran
    start: int  # character span replaced
    end: int
    replacement: str
    op: str
    original: str  # source text of the span (one line, shortened)
    new: str
    function: str  # qualified name of the enclosing def/class, or <module>
    function_hash: str  # hash of the enclosing function's source (unparsed)
    key: str = ""
    status: str = ""
    killer: str = ""
    seconds: float = 0.0
    tests: int = 0


CMP_SWAP = {
    ast.Eq: ast.NotEq,
    ast.NotEq: ast.Eq,
    ast.Lt: ast.LtE,
    ast.LtE: ast.Lt,
    ast.Gt: ast.GtE,
    ast.GtE: ast.Gt,
    ast.In: ast.NotIn,
    ast.NotIn: ast.In,
    ast.Is: ast.IsNot,
    ast.IsNot: ast.Is,
}
BINOP_SWAP = {
    ast.Add: ast.Sub,
    ast.Sub: ast.Add,
    ast.Mult: ast.Div,
    ast.Div: ast.Mult,
    ast.FloorDiv: ast.Div,
    ast.Pow: ast.Mult,
}
CALL_SWAP = {"min": "max", "max": "min", "any": "all", "all": "any"}
QUIET_CALLS = {"print"}  # removing these is never a behaviour change worth a test


def _short(text: str, n: int = 70) -> str:
    text = " ".join(text.split())
    return text if len(text) <= n else text[: n - 3] + "..."


class _Collector(ast.NodeVisitor):
    """Walks one module and records every mutant with its span and enclosing function."""

    def __init__(self, source: str, file: str, logical: str) -> None:
        self.source = source
        self.file = file
        self.logical = logical
        self.line_starts = [0]
        for line in source.splitlines(keepends=True):
            self.line_starts.append(self.line_starts[-1] + len(line))
        self.scope: list[str] = []
        self.scope_hash: list[str] = []
        self.stmt: list[ast.stmt] = []
        self.skip: set[int] = set()  # id() of nodes not to mutate (docstrings, annotations)
        self.mutants: list[Mutant] = []

    # -- helpers
    def offset(self, line: int, col: int) -> int:
        # ast columns are UTF-8 byte offsets
        text = self.source[self.line_starts[line - 1] : self.line_starts[line]]
        return self.line_starts[line - 1] + len(text.encode()[:col].decode())

    def span(self, node: ast.AST) -> tuple[int, int]:
        return (
            self.offset(node.lineno, node.col_offset),
            self.offset(node.end_lineno, node.end_col_offset),
        )

    def add(self, node: ast.AST, replacement: str, op: str, new_text: str | None = None) -> None:
        start, end = self.span(node)
        original = self.source[start:end]
        stmt = self.stmt[-1] if self.stmt else node
        lines = set(range(node.lineno, node.end_lineno + 1)) | {stmt.lineno}
        self.mutants.append(
            Mutant(
                file=self.file,
                logical=self.logical,
                line=node.lineno,
                end_line=node.end_lineno,
                lines=sorted(lines),
                start=start,
                end=end,
                replacement=replacement,
                op=op,
                original=_short(original),
                new=_short(new_text if new_text is not None else replacement),
                function=".".join(self.scope) or "<module>",
                function_hash=self.scope_hash[-1] if self.scope_hash else "",
            )
        )

    def expr(self, node: ast.expr, new: ast.expr, op: str) -> None:
        text = ast.unparse(new)
        self.add(node, f"({text})", op, text)

    # -- scopes
    def _scoped(self, node) -> None:
        for d in node.decorator_list:
            self.skip.update(id(n) for n in ast.walk(d))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            args = node.args
            for a in args.posonlyargs + args.args + args.kwonlyargs + [args.vararg, args.kwarg]:
                if a is not None and a.annotation is not None:
                    self.skip.update(id(n) for n in ast.walk(a.annotation))
            if node.returns is not None:
                self.skip.update(id(n) for n in ast.walk(node.returns))
        self.scope.append(node.name)
        self.scope_hash.append(hashlib.sha1(ast.unparse(node).encode()).hexdigest()[:12])
        self.generic_visit(node)
        self.scope.pop()
        self.scope_hash.pop()

    visit_FunctionDef = visit_AsyncFunctionDef = visit_ClassDef = _scoped

    def visit_Module(self, node: ast.Module) -> None:
        self.scope_hash.append("")
        self.generic_visit(node)

    def generic_visit(self, node: ast.AST) -> None:
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr):
            if isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
                self.skip.update(id(n) for n in ast.walk(body[0]))  # docstring
        if isinstance(node, ast.AnnAssign):
            self.skip.update(id(n) for n in ast.walk(node.annotation))
        if isinstance(node, ast.JoinedStr):
            return
        if isinstance(node, ast.Subscript):  # indices: x[3], x[:, 0] (mostly an IndexError)
            self.skip.update(
                id(n) for n in ast.walk(node.slice) if isinstance(n, (ast.Constant, ast.UnaryOp))
            )
        if isinstance(node, ast.stmt):
            self.stmt.append(node)
            self.statement(node)
        if id(node) not in self.skip:
            self.expression(node)
        for child in ast.iter_child_nodes(node):
            self.visit(child)
        if isinstance(node, ast.stmt):
            self.stmt.pop()

    # -- statement mutants
    def statement(self, node: ast.stmt) -> None:
        if id(node) in self.skip or not self.scope:  # module level: definitions, constants
            return
        remove = False
        if isinstance(node, ast.Expr) and isinstance(node.value, (ast.Call, ast.Await)):
            f = node.value.func if isinstance(node.value, ast.Call) else None
            remove = not (isinstance(f, ast.Name) and f.id in QUIET_CALLS)
        elif isinstance(node, (ast.AugAssign, ast.Break, ast.Continue, ast.Raise)):
            remove = True
        elif isinstance(node, ast.Assign):
            remove = all(isinstance(t, (ast.Attribute, ast.Subscript)) for t in node.targets)
        if remove:
            self.add(node, "pass", "remove statement", "pass")
        if isinstance(node, ast.Return) and node.value is not None:
            v = node.value
            if not (isinstance(v, ast.Constant) and v.value is None):
                self.add(node, "return None", "return None", "return None")

    # -- expression mutants
    def expression(self, node: ast.AST) -> None:
        if isinstance(node, ast.Compare):
            for i, op in enumerate(node.ops):
                swap = CMP_SWAP.get(type(op))
                if swap is None:
                    continue
                ops = list(node.ops)
                ops[i] = swap()
                new = ast.Compare(left=node.left, ops=ops, comparators=node.comparators)
                self.expr(node, new, "comparison")
        elif isinstance(node, ast.BoolOp):
            other = ast.Or() if isinstance(node.op, ast.And) else ast.And()
            self.expr(node, ast.BoolOp(op=other, values=node.values), "and/or")
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            self.expr(node, node.operand, "drop not")
        elif isinstance(node, ast.BinOp):
            swap = BINOP_SWAP.get(type(node.op))
            if swap is not None:
                self.expr(node, ast.BinOp(left=node.left, op=swap(), right=node.right), "arith")
        elif isinstance(node, ast.Constant) and type(node.value) in (bool, int, float):
            v = node.value
            if isinstance(v, bool):
                new = not v
            elif isinstance(v, int):
                new = v + 1
            else:
                new = v * 2 if v else 1.0
            self.expr(node, ast.Constant(new), "constant")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            other = CALL_SWAP.get(node.func.id)
            if other is not None:
                start, _ = self.span(node.func)
                _, end = self.span(node.func)
                stmt = self.stmt[-1] if self.stmt else node
                self.mutants.append(
                    Mutant(
                        file=self.file,
                        logical=self.logical,
                        line=node.lineno,
                        end_line=node.end_lineno,
                        lines=sorted(set(range(node.lineno, node.end_lineno + 1)) | {stmt.lineno}),
                        start=start,
                        end=end,
                        replacement=other,
                        op="min/max any/all",
                        original=_short(ast.unparse(node)),
                        new=_short(other + ast.unparse(node)[len(node.func.id) :]),
                        function=".".join(self.scope) or "<module>",
                        function_hash=self.scope_hash[-1] if self.scope_hash else "",
                    )
                )


def make_mutants(root: Path, files: list[tuple[str, str]]) -> list[Mutant]:
    """Every mutant of the given (path, logical name) files, with its sampling key."""
    out: list[Mutant] = []
    for path, logical in files:
        source = (root / path).read_text()
        col = _Collector(source, path, logical)
        col.visit(ast.parse(source))
        seen: dict[tuple, int] = defaultdict(int)
        for m in col.mutants:
            mutated = source[: m.start] + m.replacement + source[m.end :]
            try:
                compile(mutated, path, "exec")
            except SyntaxError:
                continue
            base = (m.logical, m.function, m.op, m.original, m.new)
            m.key = "|".join(map(str, base)) + f"|{seen[base]}"
            seen[base] += 1
            out.append(m)
    return out


def describe(m: Mutant) -> str:
    return f"{m.file}:{m.line} {m.op}: {m.original} -> {m.new}"


def sampled(m: Mutant, rate: float) -> bool:
    h = int(hashlib.sha1(m.key.encode()).hexdigest()[:8], 16) / 0xFFFFFFFF
    return h < rate


# ------------------------------------------------------------------------------ runner


def preimport() -> None:
    os.environ.setdefault("MPLBACKEND", "Agg")
    for name in HEAVY_IMPORTS:
        try:
            __import__(name)
        except Exception:  # noqa: BLE001 - optional speed-up only
            pass


class _Tracer:
    """Per-test line coverage of the target files (sys.settrace; Python 3.10+)."""

    def __init__(self, files: set[str]) -> None:
        self.files = files
        self.current = "<import>"
        self.hits: dict[str, set] = defaultdict(set)
        self.seconds: dict[str, float] = {}
        self.failed: set[str] = set()

    def trace(self, frame, event, arg):
        if frame.f_code.co_filename in self.files:
            return self.local
        return None

    def local(self, frame, event, arg):
        if event == "line":
            self.hits[self.current].add((frame.f_code.co_filename, frame.f_lineno))
        return self.local

    # pytest hooks (this object is passed as a plugin)
    def pytest_runtest_logstart(self, nodeid, location):
        self.current = nodeid
        self._t = time.perf_counter()

    def pytest_runtest_logfinish(self, nodeid, location):
        self.seconds[nodeid] = time.perf_counter() - self._t
        self.current = "<import>"

    def pytest_runtest_logreport(self, report):
        if report.failed:
            self.failed.add(report.nodeid)


def _child(workdir: Path, args: list[str], log: Path, tracer: _Tracer | None = None) -> None:
    """In the forked child: run pytest on args in workdir and exit with its code."""
    try:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        os.setpgid(0, 0)
        fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.chdir(workdir)
        sys.path.insert(0, str(workdir))
        sys.dont_write_bytecode = True
        import threading

        import pytest

        plugins = []
        if tracer is not None:
            plugins.append(tracer)
            threading.settrace(tracer.trace)
            sys.settrace(tracer.trace)
        rc = int(pytest.main(args, plugins=plugins))
        sys.settrace(None)
        if tracer is not None:
            outside = sorted(
                f"{name}: {mod.__file__}"
                for name, mod in list(sys.modules.items())
                if name.split(".")[0] in ("ssr_compile", "sim", "streams")
                and getattr(mod, "__file__", None)
                and not str(mod.__file__).startswith(str(workdir))
            )
            data = {
                "hits": {k: sorted(v) for k, v in tracer.hits.items()},
                "seconds": tracer.seconds,
                "failed": sorted(tracer.failed),
                "outside": outside,
            }
            (workdir / ".mutation-baseline.json").write_text(json.dumps(data))
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(rc)
    except BaseException:  # noqa: BLE001
        import traceback

        traceback.print_exc()
        sys.stderr.flush()
        os._exit(99)


def become_subreaper() -> None:
    """Orphans of a test run (processes that left the child's group) become ours to end."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER
    except Exception:  # noqa: BLE001 - not Linux: leftovers are only killed by group
        pass


def end_leftovers() -> None:
    """Kill and reap every process still our child (only test runs' leftovers are)."""
    me = str(os.getpid())
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[1] == me:
            pid = int(stat.parent.name)
            try:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
            except (ProcessLookupError, ChildProcessError, PermissionError):
                pass


def run_forked(workdir, args, log, timeout, tracer=None) -> tuple[str, float, float]:
    """(outcome, wall seconds, cpu seconds) of one pytest run in a forked child."""
    t0 = time.perf_counter()
    pid = os.fork()
    if pid == 0:
        _child(workdir, args, log, tracer)
    outcome = None
    cpu = 0.0
    while outcome is None:
        got, status, usage = os.wait4(pid, os.WNOHANG)
        if got:
            cpu = usage.ru_utime + usage.ru_stime
            if os.WIFSIGNALED(status):
                outcome = "crashed"
            else:
                rc = os.WEXITSTATUS(status)
                outcome = {0: "passed", 1: "failed", 2: "interrupted", 3: "internal"}.get(
                    rc, f"rc{rc}"
                )
        elif time.perf_counter() - t0 > timeout:
            try:
                os.killpg(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            _, status, usage = os.wait4(pid, 0)
            cpu = usage.ru_utime + usage.ru_stime
            outcome = "timeout"
        else:
            time.sleep(0.02)
    try:  # leftovers of the run (planner servers, helpers)
        os.killpg(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    end_leftovers()
    return outcome, time.perf_counter() - t0, cpu


def first_failure(log: Path) -> str:
    text = log.read_text(errors="replace")
    m = re.search(r"^(?:FAILED|ERROR) (\S+)", text, re.M)
    if m:
        return m.group(1)
    m = re.search(r"^E\s+(\w+Error.*)$", text, re.M)
    return _short(m.group(1), 60) if m else ""


# ------------------------------------------------------------------------------ report


def summarize(mutants: list[Mutant], title: str = "") -> tuple[str, dict]:
    rows = defaultdict(lambda: defaultdict(int))
    for m in mutants:
        rows[m.logical][m.status] += 1
        rows["overall"][m.status] += 1
    lines = [title] if title else []
    lines.append(
        f"{'module':40} {'killed':>6} {'timeout':>7} {'survived':>8} {'uncovered':>9} "
        f"{'total':>5} {'score':>6}"
    )
    table = {}
    for name in sorted(k for k in rows if k != "overall") + ["overall"]:
        r = rows[name]
        total = sum(r.values())
        caught = r["killed"] + r["timeout"]
        score = caught / total if total else 0.0
        table[name] = {**r, "total": total, "score": round(score, 4)}
        lines.append(
            f"{name:40} {r['killed']:6} {r['timeout']:7} {r['survived']:8} {r['uncovered']:9} "
            f"{total:5} {score:6.1%}"
        )
    return "\n".join(lines), table


def compare(before_path: str, after_path: str) -> None:
    """Scores of two runs on the mutants both made from identical functions."""
    before = {m["key"]: m for m in json.loads(Path(before_path).read_text())["mutants"]}
    after = {m["key"]: m for m in json.loads(Path(after_path).read_text())["mutants"]}
    same = [
        k for k in before if k in after and before[k]["function_hash"] == after[k]["function_hash"]
    ]
    print(f"mutants in both runs from textually identical functions: {len(same)}")
    for label, run in (("before", before), ("after", after)):
        ms = [Mutant(**run[k]) for k in same]
        print(summarize(ms, f"\n{label} ({before_path if label == 'before' else after_path})")[0])
    gained = [
        k
        for k in same
        if before[k]["status"] in ("survived", "uncovered")
        and after[k]["status"] in ("killed", "timeout")
    ]
    lost = [
        k
        for k in same
        if after[k]["status"] in ("survived", "uncovered")
        and before[k]["status"] in ("killed", "timeout")
    ]
    print(f"\nnow caught, survived before: {len(gained)}; survived now, caught before: {len(lost)}")
    for label, keys in (("now caught", gained), ("lost", lost)):
        for k in keys:
            m = after[k]
            print(f"  {label}: {describe(Mutant(**m))}  [{m['killer']}]")


# ------------------------------------------------------------------------------ main


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repo", default=str(REPO), help="checkout whose HEAD is tested")
    ap.add_argument(
        "--files",
        nargs="+",
        default=DEFAULT_FILES,
        help="target files, PATH or PATH=LOGICAL (LOGICAL names the module across commits)",
    )
    ap.add_argument("--tests", nargs="+", default=DEFAULT_TESTS, help="test files to run")
    ap.add_argument("--sample", type=float, default=0.2, help="fraction of mutants kept")
    ap.add_argument("--timeout-factor", type=float, default=2.0)
    ap.add_argument("--min-timeout", type=float, default=15.0)
    ap.add_argument(
        "--max-test-seconds",
        type=float,
        default=10.0,
        help="tests slower than this at baseline are not run per mutant",
    )
    ap.add_argument(
        "--test-budget",
        type=float,
        default=10.0,
        help="per mutant, run the fastest covering tests up to this many seconds of "
        "(traced) baseline time; 0: every covering test",
    )
    ap.add_argument("--limit", type=int, default=0, help="run at most N mutants (0: all)")
    ap.add_argument("--list", action="store_true", help="list the sampled mutants and stop")
    ap.add_argument(
        "--estimate",
        action="store_true",
        help="after the baseline, print the test time per file if every mutant "
        "survived (an upper bound) and stop",
    )
    ap.add_argument("--json", help="write every mutant's outcome here")
    ap.add_argument("--compare", nargs=2, metavar=("BEFORE.json", "AFTER.json"))
    ap.add_argument(
        "--only",
        metavar="TEXT",
        action="append",
        help="run only the sampled mutants whose line 'FILE:LINE op: old -> new' "
        "contains TEXT (repeatable); e.g. to rerun survivors with --test-budget 0",
    )
    args = ap.parse_args()
    if args.compare:
        compare(*args.compare)
        return 0

    repo = Path(args.repo).resolve()
    files = [tuple(f.split("=", 1)) if "=" in f else (f, f) for f in args.files]
    work = Path(tempfile.mkdtemp(prefix="ssr-mutation-"))
    try:
        archive = subprocess.run(
            ["git", "archive", "HEAD"], cwd=repo, capture_output=True, check=True
        )
        subprocess.run(["tar", "-x", "-C", str(work)], input=archive.stdout, check=True)
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=repo, capture_output=True, text=True
        ).stdout.strip()
        files = [(p if (work / p).is_file() or p not in MOVED else MOVED[p], lg) for p, lg in files]
        missing = [p for p, _ in files if not (work / p).is_file()]
        if missing:
            print("not in this commit:", " ".join(missing))
        files = [(p, lg) for p, lg in files if (work / p).is_file()]
        tests = [t for t in args.tests if (work / t).is_file()]
        everything = make_mutants(work, files)
        mutants = [m for m in everything if sampled(m, args.sample)]
        if args.only:
            mutants = [m for m in mutants if any(t in describe(m) for t in args.only)]
        if args.limit:
            mutants = mutants[: args.limit]
        print(
            f"{repo} at {commit}: {len(everything)} mutants in {len(files)} files, "
            f"{len(mutants)} sampled (--sample {args.sample})"
        )
        print("tests:", " ".join(tests))
        if args.list:
            for m in mutants:
                print(f"  {m.file}:{m.line} [{m.function}] {m.op}: {m.original} -> {m.new}")
            return 0

        os.environ["PYTHONDONTWRITEBYTECODE"] = "1"
        os.environ["PYTHONPATH"] = str(work) + os.pathsep + os.environ.get("PYTHONPATH", "")
        os.environ["MPLBACKEND"] = "Agg"
        preimport()
        become_subreaper()
        signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
        log = work / ".mutation-log.txt"

        # baseline with coverage
        abs_files = {str(work / p): p for p, _ in files}
        baseline_args = [a for a in PYTEST_ARGS if a != "-x"] + tests
        outcome, wall, cpu = run_forked(work, baseline_args, log, 3600, _Tracer(set(abs_files)))
        base = json.loads((work / ".mutation-baseline.json").read_text())
        print(
            f"baseline: {outcome} in {wall:.0f} s wall, {cpu:.0f} s cpu "
            f"({len(base['seconds'])} tests, traced)"
        )
        if base["outside"]:
            print("WARNING: project modules imported from outside the copy:", base["outside"])
        dropped = set(base["failed"]) | {
            t for t, s in base["seconds"].items() if s > args.max_test_seconds
        }
        for t in sorted(dropped):
            why = "fails at baseline" if t in base["failed"] else "too slow"
            print(f"  not used: {t} ({why})")
        covers: dict[tuple[str, int], set[str]] = defaultdict(set)
        file_tests: dict[str, set[str]] = defaultdict(set)
        import_lines: set[tuple[str, int]] = set()
        for test, hits in base["hits"].items():
            for f, line in hits:
                rel = abs_files[f]
                if test == "<import>":
                    import_lines.add((rel, line))
                elif test not in dropped:
                    covers[(rel, line)].add(test)
                    file_tests[rel].add(test)
        seconds = base["seconds"]

        def tests_for(m: Mutant) -> list[str]:
            chosen: set[str] = set()
            for line in m.lines:
                chosen |= covers.get((m.file, line), set())
                if (m.file, line) in import_lines:
                    chosen |= file_tests[m.file]
            ordered = sorted(chosen, key=lambda t: (seconds.get(t, 0.0), t))
            if args.test_budget:
                kept, spent = [], 0.0
                for t in ordered:
                    if kept and spent + seconds.get(t, 0.0) > args.test_budget:
                        break
                    kept.append(t)
                    spent += seconds.get(t, 0.0)
                ordered = kept
            return ordered

        if args.estimate:
            per_file: dict[str, float] = defaultdict(float)
            for m in mutants:
                per_file[m.file] += sum(seconds.get(t, 0.0) for t in tests_for(m))
            for f, s in sorted(per_file.items()):
                print(f"  {f:40} {s:8.0f} s (traced) if every mutant survived")
            print(f"  {'all':40} {sum(per_file.values()):8.0f} s")
            return 0

        t_start = time.perf_counter()
        cpu_total = 0.0
        for i, m in enumerate(mutants, 1):
            ordered = tests_for(m)
            m.tests = len(ordered)
            if not ordered:
                m.status = "uncovered"
            else:
                path = work / m.file
                original = path.read_bytes()
                text = original.decode()
                path.write_text(text[: m.start] + m.replacement + text[m.end :])
                expected = sum(seconds.get(t, 0.0) for t in ordered)
                limit = max(args.min_timeout, args.timeout_factor * expected + 10)
                try:
                    outcome, wall, cpu = run_forked(work, PYTEST_ARGS + ordered, log, limit)
                finally:
                    path.write_bytes(original)
                cpu_total += cpu
                m.seconds = round(wall, 2)
                if outcome == "passed":
                    m.status = "survived"
                elif outcome == "timeout":
                    m.status = "timeout"
                elif outcome in ("failed", "interrupted", "internal", "crashed"):
                    m.status = "killed"
                    m.killer = first_failure(log)
                else:
                    m.status = "error"
                    m.killer = outcome + " " + first_failure(log)
            print(
                f"[{i}/{len(mutants)}] {m.status:9} {describe(m)}"
                + (f"  [{m.killer}]" if m.killer else ""),
                flush=True,
            )
        elapsed = time.perf_counter() - t_start
        text, table = summarize(mutants, f"\nrepo {repo} at {commit}")
        print(text)
        print(f"mutants: {elapsed:.0f} s wall, {cpu_total:.0f} s cpu in test children")
        print("\nsurvivors (covered by tests that still pass):")
        for m in mutants:
            if m.status == "survived":
                print(f"  {m.file}:{m.line} [{m.function}] {m.op}: {m.original} -> {m.new}")
        print("uncovered (no chosen test runs the line):")
        for m in mutants:
            if m.status == "uncovered":
                print(f"  {m.file}:{m.line} [{m.function}] {m.op}: {m.original} -> {m.new}")
        if args.json:
            Path(args.json).write_text(
                json.dumps(
                    {
                        "repo": str(repo),
                        "commit": commit,
                        "tests": tests,
                        "sample": args.sample,
                        "dropped_tests": sorted(dropped),
                        "table": table,
                        "mutants": [asdict(m) for m in mutants],
                    },
                    indent=1,
                )
            )
        return 0
    finally:
        end_leftovers()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
