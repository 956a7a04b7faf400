"""ssr-compile: the PDDLStream dialect of belief-space replanning, compiled to plain cost-PDDL.

Implements Garrett et al., "Online Replanning in Belief Space for Partially Observable Task and
Motion Problems" (ICRA 2020).  See DESIGN.md for the architecture.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("ssr-compile")
except PackageNotFoundError:  # running from a checkout that is not installed
    __version__ = "0.0.0+unknown"
