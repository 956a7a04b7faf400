from pathlib import Path

import numpy as np

from ssr_compile.examples import load_example
from ssr_compile.parse import parse_problem
from ssr_compile.policy import Episode
from ssr_compile.stream import StreamInfo, StreamsModule

XY = {"hall": (0.0, 0.0), "annex": (0.0, 4.0), "lab": (3.0, 0.0)}  # the places
DOORS = {"a": ("hall", "lab"), "b": ("hall", "annex"), "c": ("annex", "lab")}


class DoorWorld:
    """The truth: where the robot is, which doors are open, which one is jammed."""

    def __init__(self, seed):
        self.jammed = {"a"} if np.random.default_rng(seed).random() < 0.5 else set()
        self.at, self.opened = "hall", set()

    def observe(self):
        return {"ok": True, "at": self.at, "opened": sorted(self.opened)}

    def execute(self, step):  # step.name, step.args (object names), step.values
        if step.name == "open":
            door = step.args[0]
            if door in self.jammed:  # a failure is an observation, not an exception
                return {**self.observe(), "ok": False, "message": f"door {door} is jammed"}
            self.opened.add(door)
        elif step.name == "move":
            self.at = step.args[3]
        return self.observe()

    def goal_holds(self):  # the true state: for evaluation only
        return self.at == "lab"

    def close(self):
        pass


class DoorAgent:
    """The robot's side: where it is, the doors it opened and those it found jammed."""

    def __init__(self, example):
        self.domain, self.streams = example.domain, example.streams
        self.at, self.opened, self.jammed = "hall", set(), set()

    def update(self, step, observation):
        if step is not None and step.name == "open" and not observation["ok"]:
            self.jammed.add(step.args[0])  # learned from the failure: plan round it
        self.at, self.opened = observation["at"], set(observation["opened"])

    def problem(self):
        init = [f"(place {p})" for p in XY] + [f"(at {self.at})"]
        for d, (a, b) in DOORS.items():
            init += [f"(door {d} {a} {b})", f"(door {d} {b} {a})"]
            init += [f"(usable {d})"] if d not in self.jammed else []
            init += [f"(opened {d})"] if d in self.opened else []
        problem = parse_problem(f"""(define (problem now) (:domain doors)
            (:objects {" ".join([*XY, *DOORS])})
            (:init {" ".join(init)} (= (total-cost) 0))
            (:goal (at lab)) (:metric minimize (total-cost)))""")
        streams = StreamsModule(
            "doors",
            {"plan-motion": lambda a, b: ((a, b),)},  # a straight path between two places
            {"plan-motion": StreamInfo(kind="function")},
            values=dict(XY),  # the Python value of each place: its (x, y)
        )
        return problem, streams

    def is_constant(self, name):
        return name in XY or name in DOORS  # places and doors keep their meaning

    def summary(self):
        return f"at {self.at}; jammed: {', '.join(sorted(self.jammed)) or 'none known'}"


def make_episode(problem, seed):
    return Episode(DoorWorld(seed), DoorAgent(load_example(Path(__file__).parent)), "doors")
