"""Plant known bugs one at a time in a copy of the repository and see which tests catch them.

    python tools/plant_bugs.py tests/test_paper_claims.py tests/test_focused.py

Copies the committed tree (git archive HEAD) to a temporary folder, applies each mutant
below, runs the given tests there, and prints CAUGHT (with the first failing test) or
SURVIVED.  Not part of the test suite; a check that the tests would catch a wrong paper.
"""

import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MUTANTS = {
    "kitchen: test-vis always true": (
        "streams/kitchen_belief.py",
        "            return self._visible_despite(obs, self.world.objects[o2], pb2)\n",
        "            return True\n",
    ),
    "kitchen: test-cfree inverted": (
        "streams/kitchen_belief.py",
        "        return float(pb2.weights[same & (d < r)].sum()) <= EPS\n",
        "        return float(pb2.weights[same & (d < r)].sum()) > EPS\n",
    ),
    "derived: only the first axiom inlined": (
        "ssr_compile/compile/derived.py",
        "        for ax in axioms:\n",
        "        for ax in axioms[:1]:\n",
    ),
    "derived: bound variables not renamed apart": (
        "ssr_compile/compile/derived.py",
        'renaming = {v: S.Var(f"{v}-d{n}") for v in variable_names(ax.body)}',
        "renaming = {}",
    ),
    "derived: goal not expanded": (
        "ssr_compile/compile/derived.py",
        "        problem = replace(problem, goal=map_atoms(problem.goal, expand))\n",
        "        pass\n",
    ),
    "costs: a decrease of total-cost counted as cost": (
        "ssr_compile/compile/costs.py",
        '            and e.op == "increase"\n',
        "",
    ),
    "visibility_mask threshold 0.5 -> 0.8": (
        "ssr_compile/belief/observation.py",
        '    min_visible_fraction: float = 0.5,\n) -> np.ndarray:\n    """Which particles',
        '    min_visible_fraction: float = 0.8,\n) -> np.ndarray:\n    """Which particles',
    ),
    "camera is_visible threshold 0.5 -> 0.9": (
        "sim/perception.py",
        "VISIBLE_FRACTION = 0.5\n",
        "VISIBLE_FRACTION = 0.9\n",
    ),
    "camera is_visible >= -> >": (
        "sim/perception.py",
        "visible_fraction(world, name) >= VISIBLE_FRACTION",
        "visible_fraction(world, name) > VISIBLE_FRACTION",
    ),
    "reinvigoration: distance compared with k, not k^2": (
        "ssr_compile/belief/particles.py",
        "float(d2.min()) > reinvig_mahalanobis**2",
        "float(d2.min()) > reinvig_mahalanobis",
    ),
    "deferral: producers of must-evaluate not added": (
        "ssr_compile/solver/deferral.py",
        "    stack = list(must)\n",
        "    stack = []\n",
    ),
    "deferral: certified-fact check dropped": (
        "ssr_compile/solver/deferral.py",
        "            or any(f in first_facts for f in r.certified)\n",
        "",
    ),
    "preimage: add and delete order swapped": (
        "ssr_compile/solver/preimage.py",
        "        state = (state - dels) | adds\n",
        "        state = (state | adds) - dels\n",
    ),
    "stream_plan: domain-fact producers not traversed": (
        "ssr_compile/solver/preimage.py",
        "        for fact in res.domain:\n            for producer in inst.facts.get(fact, ())[:1]:\n                need(producer)\n        needed.append(res)",
        "        needed.append(res)",
    ),
    "instantiate: alternative producers not recorded": (
        "ssr_compile/compile/instantiate.py",
        "                    out.facts.setdefault(atom, []).append(res)\n",
        "                    out.facts.setdefault(atom, [res])\n",
    ),
}
tests = sys.argv[1:] or [
    "tests/test_paper_claims.py",
    "tests/test_belief_thresholds.py",
    "tests/test_derived_semantics.py",
    "tests/test_costs_once.py",
    "tests/test_kitchen_stream_tests.py",
]
ROOT = Path(tempfile.mkdtemp(prefix="ssr-plant-"))
archive = subprocess.run(["git", "archive", "HEAD"], cwd=REPO, capture_output=True, check=True)
subprocess.run(["tar", "-x", "-C", str(ROOT)], input=archive.stdout, check=True)
for name, (f, old, new) in MUTANTS.items():
    p = ROOT / f
    orig = p.read_text()
    if old not in orig:
        print(f"{name}: PATTERN NOT FOUND")
        continue
    p.write_text(orig.replace(old, new, 1))
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-x",
            "-p",
            "no:warnings",
            "-p",
            "no:cacheprovider",
            *tests,
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    p.write_text(orig)
    failed = [line for line in r.stdout.splitlines() if line.startswith("FAILED")]
    print(f"{name}: {'CAUGHT by ' + failed[0] if r.returncode else 'SURVIVED'}")
