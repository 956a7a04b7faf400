"""How large Fast Downward's negated axioms would be, read from a translated task.

The search binary's heuristics need, for each derived variable whose default (false) value a
precondition, the goal or another axiom reads, rules that achieve that value: the negation of
the variable's rules, a conjunction of disjunctions multiplied out into a disjunction of
conjunctions (``tasks/negated_axioms_task`` in Fast Downward's source).  When each rule has one
condition on an object's multi-valued variable (``atposeb(o2, pb2)``: one value of ``o2``'s
pose), the result has one rule per combination of the other values of every such variable.
On a cluttered kitchen (six boxes) that was 2.9 million unary operators, 45 s before the first
state was evaluated.

:func:`negated_rules` estimates that size without building it: per derived variable, rules
with one condition merged per variable (their excluded values), each other rule a factor of its
conditions' alternatives, the product over the factors; summed over the variables needed
negatively.  The ``fd`` backend translates again with the derived predicates' existentials split
(:mod:`ssr_compile.compile.split_axioms`) when the estimate passes
:data:`~ssr_compile.planners.fd.NEGATED_RULES`.
"""

from __future__ import annotations

import math
from collections import defaultdict


def negated_rules(sas_task, cap: float = 1e12) -> float:
    """The estimated number of negated axiom rules the heuristics of ``sas_task`` (a Fast
    Downward ``SASTask``) would build, at most ``cap``."""
    ranges = sas_task.variables.ranges
    layers = sas_task.variables.axiom_layers
    init = sas_task.init.values
    derived = [v for v, layer in enumerate(layers) if layer >= 0]
    if not derived or not sas_task.axioms:
        return 0.0
    default = {v: init[v] for v in derived}
    rules = defaultdict(list)
    for ax in sas_task.axioms:
        rules[ax.effect[0]].append(ax.condition)
    read_false: set[int] = set()

    def note(pairs) -> None:
        for var, val in pairs:
            if var in default and val == default[var]:
                read_false.add(var)

    for op in sas_task.operators:
        note(op.prevail)
        note((var, pre) for var, pre, _post, _cond in op.pre_post if pre >= 0)
        for _var, _pre, _post, cond in op.pre_post:
            note(cond)
    note(sas_task.goal.pairs)
    for var_rules in rules.values():
        for conditions in var_rules:
            note(conditions)
    # a variable needed false needs the variables its rules read true false as well
    todo = list(read_false)
    while todo:
        for conditions in rules.get(todo.pop(), ()):
            for var, val in conditions:
                if var in default and val != default[var] and var not in read_false:
                    read_false.add(var)
                    todo.append(var)
    total = 0.0
    for var in read_false:
        excluded: dict[int, set[int]] = defaultdict(set)
        log_size = 0.0
        for conditions in rules.get(var, ()):
            if len(conditions) == 1:
                v, val = conditions[0]
                excluded[v].add(val)
                continue
            alternatives = sum(ranges[v] - 1 for v, _ in conditions)
            if alternatives == 0:
                log_size = -math.inf
                break
            log_size += math.log(alternatives)
        for v, values in excluded.items():
            left = ranges[v] - len(values)
            if left <= 0:
                log_size = -math.inf
                break
            log_size += math.log(left)
        if log_size > math.log(cap):
            return cap
        total += math.exp(log_size) if log_size > -math.inf else 0.0
        if total >= cap:
            return cap
    return total
