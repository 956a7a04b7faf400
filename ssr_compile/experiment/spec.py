"""What a sweep runs: its tasks (rows), variants (columns), seeds and shared settings, parsed
from the command line, and the episodes they make."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..catalog import TASKS, VARIANTS
from ..errors import SSRError
from ..policy import PolicySettings


def task_title(label: str) -> str:
    """A task's row title: a kitchen task capitalised as in Table I, others as given."""
    return label.capitalize() if label in TASKS else label


@dataclass(frozen=True)
class Task:
    """One row of the table: an example folder with an environment and one of its problems."""

    label: str  # as given on the command line (``inspect``, ``progress``, ``belief-detect:clear``)
    folder: str  # the example folder, absolute
    problem: str | None

    @property
    def title(self) -> str:
        return task_title(self.label)


def parse_variants(text: str) -> list[str]:
    names = [v.strip().lower() for v in text.split(",") if v.strip()]
    if not names:
        raise SSRError(f"--variants: empty; expected some of {','.join(VARIANTS)}")
    for v in names:
        if v not in VARIANTS:
            raise SSRError(
                f"--variants: unknown variant '{v}'; expected some of {','.join(VARIANTS)}"
            )
    return list(dict.fromkeys(names))


def kitchen_has_environment() -> bool:
    """Whether the kitchen example names a closed-loop environment (then Table I's tasks are
    the default of ``--tasks``)."""
    try:
        from ..examples import read_settings, resolve_folder

        folder = resolve_folder("kitchen")
        return folder is not None and bool(read_settings(folder).environment)
    except SSRError:
        return False


def parse_tasks(text: str) -> list[Task]:
    """``inspect,stow`` (kitchen tasks), ``progress``, ``belief-detect:clear`` (an example with
    an environment, ``:PROBLEM`` optional), or an example folder's path."""
    tasks: list[Task] = []
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise SSRError("--tasks: empty; expected e.g. inspect,stow,swap,cook or progress")
    for name in names:
        tasks.append(resolve_task(name))
    labels = [t.label for t in tasks]
    dup = next((x for x in labels if labels.count(x) > 1), None)
    if dup:
        raise SSRError(f"--tasks: '{dup}' is named twice")
    return tasks


def resolve_task(name: str) -> Task:
    from ..examples import resolve_folder

    if name.lower() in TASKS:
        target, problem = "kitchen", name.lower()
        label = name.lower()
    elif name.endswith(".toml") and Path(name).name != "example.toml":
        # a kitchen task file (checked by the CLI: the toolkit does not import the simulator)
        if not Path(name).is_file():
            raise SSRError(f"--tasks: no task file '{name}'")
        target, problem, label = "kitchen", str(Path(name).resolve()), name
    else:
        target, problem = name, None
        if ":" in name and not Path(name).exists():
            target, problem = name.rsplit(":", 1)
            problem = problem or None
        label = name
    folder = resolve_folder(target)
    if folder is None:
        known = ", ".join(TASKS)
        raise SSRError(
            f"--tasks: unknown task '{name}'; expected a kitchen task ({known}) or task "
            "file (.toml), a shipped example with an environment (progress, belief-detect[:PROBLEM]) or an example "
            "folder"
        )
    task = Task(label, str(folder.resolve()), problem)
    try:
        load_task(task)
    except SSRError as e:
        raise SSRError(f"--tasks: '{name}': {e.message}") from None
    return task


def load_task(task: Task):
    """(example, environment factory) of a task (its environment module may sit beside the
    folder's files: :meth:`~ssr_compile.examples.Example.environment_factory`)."""
    from ..examples import load_example

    example = load_example(Path(task.folder))
    return example, example.environment_factory()


@dataclass(frozen=True)
class Settings:
    """What every episode of a sweep shares (stored in each JSON line: a resumed sweep must
    use the same): the policy's settings -- each episode runs them with its own variant --
    and what only a sweep has, the limits of an episode's process."""

    policy: PolicySettings = field(default_factory=PolicySettings)
    wall_limit: float | None = None  # s; None: 2 × the planning budget + 120
    memory_mb: int = 4096  # address-space limit of an episode's process; 0: none

    @property
    def wall(self) -> float:
        return self.wall_limit if self.wall_limit is not None else 2 * self.policy.budget + 120

    def policy_key(self) -> dict:
        """The settings that change an episode's outcome (compared on resume)."""
        return {
            "budget": self.policy.budget,
            "max_cycles": self.policy.max_cycles,
            "constrained_time": self.policy.constrained_time,
            "unconstrained_time": self.policy.unconstrained_time,
            "planner": self.policy.planner,
        }


@dataclass(frozen=True)
class EpisodeSpec:
    """One episode of a sweep: a cell of the table (task, variant) and a seed."""

    task: Task
    variant: str
    seed: int
    settings: Settings = field(default_factory=Settings)

    @property
    def key(self) -> tuple[str, str, int]:
        return (self.task.label, self.variant, self.seed)

    def name(self) -> str:
        return f"{self.task.label}/{self.variant}/seed {self.seed}"


def episode_specs(
    tasks: list[Task], variants: list[str], seeds: list[int], settings: Settings
) -> list[EpisodeSpec]:
    """Seed-major order, so that a partial sweep has every cell of the table about equally far."""
    return [EpisodeSpec(t, v, s, settings) for s in seeds for t in tasks for v in variants]
