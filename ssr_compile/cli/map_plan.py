"""``ssr-compile map-plan DIR PLAN``: a plan of a compiled task, in the user's lifted actions."""

from __future__ import annotations

import argparse

from ..json_output import document, dumps
from .registry import register


def _configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("folder", metavar="DIR", help="the folder `ssr-compile compile -o DIR` wrote")
    p.add_argument(
        "plan",
        metavar="PLAN",
        help="a plan of DIR's task: (action arg ...) lines (Fast Downward's sas_plan, "
        "pyperplan's .soln) or unified-planning's printed plan; `;` starts a comment",
    )
    p.add_argument(
        "--no-validate",
        dest="validate",
        action="store_false",
        help="do not check the plan against the original domain and problem",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print the result as JSON (schema: README, ssr_compile/json_output.py)",
    )


def run(args: argparse.Namespace) -> int:
    from ..artifact import Artifact, read_plan, source_task, validate

    artifact = Artifact.load(args.folder)
    plan = artifact.map_steps(read_plan(args.plan), args.plan)
    valid, reason, validator = None, "", None
    if args.validate:
        domain, problem = source_task(artifact)
        valid, reason, validator = validate(domain, problem, plan)
    streams = artifact.stream_instances(plan)
    if args.json:
        print(
            dumps(
                document(
                    "map-plan",
                    plan=[{"action": n, "args": list(a)} for n, a in plan],
                    valid=valid,
                    validator=validator,
                    reason=reason or None,
                    domain=artifact.source.get("domain"),
                    problem=artifact.source.get("problem"),
                    stream_instances=streams,
                )
            )
        )
    else:
        print(f"plan ({len(plan)} steps) in the actions of {artifact.source.get('domain')}:")
        for i, (name, a) in enumerate(plan, 1):
            print(f"  {i:2d}. ({' '.join([name, *a])})")
        if streams:
            print(f"optimistic objects it names ({len(streams)}), made by stream instances:")
            for obj, inst in streams.items():
                print(f"  {obj} <- {inst}")
        if valid is not None:
            against = "the optimistic problem of " if artifact.optimistic else ""
            verdict = "valid" if valid else f"INVALID ({reason})"
            checker = {"unified-planning": "unified-planning's validator"}.get(
                validator, "ssr-compile's plan checker"
            )
            print(f"{verdict} for {against}{artifact.source.get('problem')} (checked by {checker})")
    if valid is False:
        return 1
    return 0


register(
    "map-plan",
    "map a plan of a compiled task (`compile -o DIR`) back to your domain's actions and "
    "validate it against the original domain and problem",
    _configure,
    run,
)
