"""The sweep's report, rebuilt from ``DIR/episodes.jsonl`` alone: ``DIR/table.md`` (Table I's
layout, ours next to the paper's, and per-cell details) and ``DIR/table1.png``."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable, Iterable
from pathlib import Path

from ..errors import SSRError
from .journal import EPISODES_FILE, FINISHED, SkippedLine, describe_skipped, latest, read_records
from .paper import PAPER_EPISODES, PAPER_TABLE1
from .spec import task_title
from .statistics import cells, groups

TABLE_FILE = "table.md"
PLOT_FILE = "table1.png"
# The lines of a Markdown page between which ``ssr-compile report --into PAGE`` writes the
# table (:func:`publish_table`): the page's own text around them is kept.
BEGIN_MARK = "<!-- table-of-record -->"
END_MARK = "<!-- /table-of-record -->"


def fmt_time(t: float) -> str:
    return f"{t:.0f}" if t >= 100 else f"{t:.1f}" if t >= 1 else f"{t:.2f}"


def render_table(
    records: Iterable[dict], command: str | None = None, notes: Iterable[str] = ()
) -> str:
    """Markdown in Table I's layout: a row per task (ours, then the paper's), per variant the
    success % [95% Wilson interval] and the mean planning time of the successful trials
    [95% bootstrap interval]."""
    records = list(records)
    tasks, variants, table = cells(records)
    head = (
        "| Task | | "
        + " | ".join(f"{v.capitalize()} % | {v.capitalize()} t (s)" for v in variants)
        + " |"
    )
    rule = "|---|---|" + "---:|---:|" * len(variants)
    lines = [
        "# Table I: success rate and mean total planning time of successful trials",
        "",
        "Ours: success % [95% Wilson interval] and mean planning time in seconds of the "
        "successful episodes [95% bootstrap interval of the mean, seeded]; n episodes per "
        f"cell. Paper: Table I of Garrett et al. (ICRA 2020), {PAPER_EPISODES} problems per "
        "task, 10 minutes of planning per episode.",
        "",
        head,
        rule,
    ]
    for t in tasks:
        row = [f"**{task_title(t)}**", "ours"]
        for v in variants:
            c = table.get((t, v))
            if c is None:
                row += ["–", "–"]
                continue
            lo, hi = c.rate_ci
            row.append(f"{100 * c.rate:.0f} [{100 * lo:.0f}, {100 * hi:.0f}] (n={c.n})")
            if c.mean_time is None:
                row.append("–")
            else:
                a, b = c.time_ci
                row.append(f"{fmt_time(c.mean_time)} [{fmt_time(a)}, {fmt_time(b)}]")
        lines.append("| " + " | ".join(row) + " |")
        if t in PAPER_TABLE1:
            prow = ["", "paper"]
            for v in variants:
                p = PAPER_TABLE1[t].get(v)
                prow += [f"{p[0]:g}", f"{p[1]:g}"] if p else ["–", "–"]
            lines.append("| " + " | ".join(prow) + " |")
    recs = list(latest(records).values())
    lines += ["", *render_details(recs)]
    lost = [r for r in recs if r.get("status") not in (FINISHED, None)]
    lines += ["", f"{len(recs)} episodes, {sum(bool(r.get('success')) for r in recs)} successes."]
    if lost:
        kinds: dict[str, int] = {}
        for r in lost:
            kinds[r["status"]] = kinds.get(r["status"], 0) + 1
        lines.append(
            "Counted as failures, the episodes the harness lost: "
            + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items()))
            + " (their reasons are in episodes.jsonl)."
        )
    settings = {json.dumps(r.get("settings"), sort_keys=True) for r in recs if r.get("settings")}
    if len(settings) == 1:
        s = json.loads(settings.pop())
        lines.append(
            f"Settings: planning budget {s['budget']:g} s per episode, at most "
            f"{s['max_cycles']} cycles, constrained attempts {s['constrained_time']:g} s, "
            f"unconstrained {s['unconstrained_time']:g} s, planner {s['planner']}."
        )
    commits = sorted(
        {(r.get("commit") or "?")[:12] + ("+dirty" if r.get("dirty") else "") for r in recs}
    )
    versions = sorted({str(r.get("version")) for r in recs})
    lines.append(f"Toolkit {', '.join(versions)}, commit {', '.join(commits)}.")
    lines += list(notes)
    if command:
        lines += ["", "Command:", "", "```bash", command, "```"]
    return "\n".join(lines) + "\n"


def median(values: list[float]) -> float | None:
    if not values:
        return None
    v = sorted(values)
    n = len(v)
    return v[n // 2] if n % 2 else (v[n // 2 - 1] + v[n // 2]) / 2


def seed_list(seeds: Iterable[int]) -> str:
    """``0-4,7``: sorted seeds with runs folded."""
    out: list[str] = []
    run: list[int] = []
    for s in sorted(set(seeds)):
        if run and s == run[-1] + 1:
            run.append(s)
            continue
        if run:
            out.append(f"{run[0]}-{run[-1]}" if len(run) > 1 else str(run[0]))
        run = [s]
    if run:
        out.append(f"{run[0]}-{run[-1]}" if len(run) > 1 else str(run[0]))
    return ",".join(out) or "–"


def render_details(recs: list[dict]) -> list[str]:
    """Per task × variant, what Table I does not show: the seeds run and those that failed,
    the median planning time of the successes, the mean cycles, the constrained attempts
    (Algorithm 2) that held and those that fell back to an unconstrained replan (totals over
    the cell's episodes), and the commits the episodes ran at."""
    tasks, variants, _ = cells(recs)
    lines = [
        "Per cell: seeds run, seeds that failed, median planning time of the successes (s), "
        "mean cycles per episode, constrained attempts that held / fell back (all episodes), "
        "commit.",
        "",
        "| Task | Variant | Seeds | Failed | Median t (s) | Cycles | Held / fell back | Commit |",
        "|---|---|---|---|---:|---:|---:|---|",
    ]
    for t, v, group, _ok, times in groups(recs, tasks, variants):
        med = median(times)
        cycles = [float(r["cycles"]) for r in group if r.get("cycles") is not None]
        held = sum(int(r.get("constrained_held") or 0) for r in group)
        fell = sum(int(r.get("fallbacks") or 0) for r in group)
        commits = sorted({(r.get("commit") or "?")[:7] for r in group})
        lines.append(
            "| "
            + " | ".join(
                [
                    task_title(t),
                    v,
                    seed_list(int(r["seed"]) for r in group),
                    seed_list(int(r["seed"]) for r in group if not r.get("success")),
                    "–" if med is None else fmt_time(med),
                    f"{sum(cycles) / len(cycles):.1f}" if cycles else "–",
                    f"{held} / {fell}",
                    ", ".join(commits),
                ]
            )
            + " |"
        )
    return lines


def render_plot(records: Iterable[dict], path: str | Path) -> None:
    """Success % and mean planning time per task and variant, ours (with 95% intervals) next
    to the paper's (hatched)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    tasks, variants, table = cells(records)
    fig, axes = plt.subplots(1, 2, figsize=(max(7, 2.6 * len(tasks) + 3), 4.2))
    colors = plt.get_cmap("tab10")
    width = 0.8 / max(len(variants), 1)
    x = np.arange(len(tasks))
    for panel, ax in enumerate(axes):
        for j, v in enumerate(variants):
            ours, err, paper = [], [[], []], []
            for t in tasks:
                c = table.get((t, v))
                if panel == 0:
                    val = 100 * c.rate if c else np.nan
                    ci = (100 * c.rate_ci[0], 100 * c.rate_ci[1]) if c else (np.nan, np.nan)
                    p = PAPER_TABLE1.get(t, {}).get(v)
                    paper.append(p[0] if p else np.nan)
                else:
                    val = c.mean_time if c and c.mean_time is not None else np.nan
                    ci = c.time_ci if c and c.time_ci else (np.nan, np.nan)
                    p = PAPER_TABLE1.get(t, {}).get(v)
                    paper.append(p[1] if p else np.nan)
                ours.append(val)
                err[0].append(max(val - ci[0], 0) if np.isfinite(val) else 0)
                err[1].append(max(ci[1] - val, 0) if np.isfinite(val) else 0)
            pos = x - 0.4 + width * (j + 0.5)
            half = width / 2
            has_paper = any(np.isfinite(paper))
            ax.bar(
                pos - (half / 2 if has_paper else 0),
                ours,
                half if has_paper else width * 0.9,
                yerr=err,
                capsize=2,
                color=colors(j),
                label=f"{v} (ours)",
            )
            if has_paper:
                ax.bar(
                    pos + half / 2,
                    paper,
                    half,
                    color=colors(j),
                    alpha=0.35,
                    hatch="//",
                    edgecolor=colors(j),
                    label=f"{v} (paper)",
                )
        ax.set_xticks(x)
        ax.set_xticklabels([task_title(t) for t in tasks])
        if panel == 0:
            ax.set_ylabel("success (%)")
            ax.set_ylim(0, 105)
            ax.set_title("Success rate, 95% Wilson interval")
        else:
            ax.set_ylabel("mean planning time of successes (s)")
            ax.set_title("Planning time, 95% bootstrap interval")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(
        handles, labels, loc="lower center", ncol=min(len(labels), 4), fontsize=8, frameon=False
    )
    fig.tight_layout(rect=(0, 0.08 + 0.04 * (len(labels) > 4), 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_report(
    out_dir: str | Path,
    command: str | None = None,
    sources: list[str | Path] | None = None,
    say: Callable[[str], None] | None = None,
    into: list[str | Path] | None = None,
) -> tuple[Path, Path, str]:
    """Rebuild ``table.md`` and ``table1.png`` from ``episodes.jsonl`` alone.  With
    ``sources`` (sweep folders), their episodes merged -- the last folder's record of a task,
    variant and seed wins -- are written to ``out_dir/episodes.jsonl`` first, so that the
    merged folder is a report of its own; the commands recorded in the sources' tables are
    kept in the new one.  Lines of an episodes.jsonl that are not records are skipped, said
    (``say``, default: standard error) and noted in the table.  ``into``: Markdown pages to
    publish the table in as well (:func:`publish_table`), the plot written beside the first;
    all files are written as a unit, or none."""
    from ..files import Content, write_files_atomically

    out = Path(out_dir)
    say = say or (lambda msg: print(msg, file=sys.stderr, flush=True))
    skipped: list[tuple[Path, list[SkippedLine]]] = []
    files: dict[Path, Content] = {}
    if sources:
        records, commands = [], []
        for src in map(Path, sources):
            if src.resolve() == out.resolve() and len(sources) > 1:
                raise SSRError(
                    "is one of the sweeps to merge: name a new folder with -o "
                    "(its episodes.jsonl would be overwritten)",
                    file=str(out),
                )
            records += _records_of(src, skipped)
            old = src / TABLE_FILE
            found = _command_of(old.read_text(encoding="utf-8")) if old.is_file() else None
            if found and found not in commands:
                commands.append(found)
        merged = list(latest(records).values())
        if command is not None:
            commands.append(command)
        command = "\n".join(commands) or None
        files[out / EPISODES_FILE] = "".join(json.dumps(r, sort_keys=True) + "\n" for r in merged)
        records = merged
    else:
        records = _records_of(out, skipped)
    for path, lines in skipped:
        say(describe_skipped(path, lines, "not in the table"))
    if command is None:
        old = out / TABLE_FILE
        command = _command_of(old.read_text(encoding="utf-8")) if old.is_file() else None
    notes = [
        f"Not in the table: {len(lines)} unreadable line(s) of {path} (lines "
        + ", ".join(str(x.line) for x in lines)
        + "; `ssr-compile report` says why)."
        for path, lines in skipped
    ]
    text = render_table(records, command, notes)
    files[out / TABLE_FILE] = text
    files[out / PLOT_FILE] = lambda tmp: render_plot(records, tmp)
    if into:
        pages = [Path(x) for x in into]
        plot = pages[0].parent / PLOT_FILE
        for page in pages:
            files[page] = publish_table(page, text, plot)
        files[plot] = lambda tmp: render_plot(records, tmp)
    write_files_atomically(files)  # the merged episodes, the table and its plot: as a unit
    return out / TABLE_FILE, out / PLOT_FILE, text


def publish_table(page: str | Path, table: str, plot: str | Path) -> str:
    """``page`` (Markdown) with the lines between :data:`BEGIN_MARK` and :data:`END_MARK`
    replaced by ``table`` (its title line dropped: the page has its own headings) and a link
    to ``plot``; the page's other lines are kept.  A page without exactly one pair of marks,
    in that order, is bad input (nothing is written)."""
    page = Path(page)
    try:
        text = page.read_text(encoding="utf-8")
    except OSError as e:
        raise SSRError(
            f"cannot read the page to publish into: {e.strerror}", file=str(page)
        ) from None
    lines = text.split("\n")
    begins = [i for i, x in enumerate(lines) if x.strip() == BEGIN_MARK]
    ends = [i for i, x in enumerate(lines) if x.strip() == END_MARK]
    if len(begins) != 1 or len(ends) != 1 or ends[0] < begins[0]:
        where = begins[1] if len(begins) > 1 else ends[1] if len(ends) > 1 else None
        found = (
            f"{len(begins)} line(s) {BEGIN_MARK} and {len(ends)} line(s) {END_MARK}"
            if len(begins) != 1 or len(ends) != 1
            else f"{END_MARK} before {BEGIN_MARK}"
        )
        raise SSRError(
            f"found {found}; expected one line {BEGIN_MARK} and, below it, one line {END_MARK}, "
            "between which the table is written",
            file=str(page),
            line=None if where is None else where + 1,
        )
    body = table.rstrip("\n").split("\n")
    if body and body[0].startswith("# "):
        body = body[1:]
        while body and not body[0].strip():
            body = body[1:]
    link = os.path.relpath(Path(plot).resolve(), page.resolve().parent).replace(os.sep, "/")
    section = [
        "<!-- written by `ssr-compile report --into`: edit outside these marks -->",
        "",
        *body,
        "",
        f"![Table I, ours beside the paper's]({link})",
        "",
    ]
    return "\n".join(lines[: begins[0] + 1] + section + lines[ends[0] :])


def check_report_outputs(out_dir: str | Path, option: str = "-o", journal: bool = False) -> None:
    """Before the work: the report's files (and, with ``journal``, a merge's episodes.jsonl)
    can be written into ``out_dir``."""
    from ..files import check_output

    names = ([EPISODES_FILE] if journal else []) + [TABLE_FILE, PLOT_FILE]
    for name in names:
        check_output(Path(out_dir) / name, option)


def _records_of(folder: Path, skipped: list[tuple[Path, list[SkippedLine]]]) -> list[dict]:
    """The records of ``folder``'s episodes.jsonl; the lines skipped are added to ``skipped``."""
    path = folder / EPISODES_FILE
    if not path.is_file():
        raise SSRError(
            f"no {EPISODES_FILE} in this folder (run `ssr-compile experiment -o {folder}` first)",
            file=str(folder),
        )
    records, bad = read_records(path)
    if not records:
        if bad:
            raise SSRError(
                "holds no episode records:\n" + describe_skipped(path, bad, "all of them"),
                file=str(path),
            )
        raise SSRError("holds no episode records", file=str(path))
    if bad:
        skipped.append((path, bad))
    return records


def _command_of(table: str) -> str | None:
    """The command recorded in an earlier table.md (kept when the report is rebuilt)."""
    marker = "Command:\n\n```bash\n"
    i = table.find(marker)
    if i < 0:
        return None
    rest = table[i + len(marker) :]
    j = rest.find("\n```")
    return rest[:j] if j >= 0 else None
