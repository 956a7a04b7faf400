"""ssr-compile: the PDDLStream dialect of belief-space replanning, compiled to plain cost-PDDL.

Implements Garrett et al., "Online Replanning in Belief Space for Partially Observable Task and
Motion Problems" (ICRA 2020).  See DESIGN.md for the architecture.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("ssr-compile")
except PackageNotFoundError:  # running from a checkout that is not installed
    __version__ = "0.0.0+unknown"


# In a source checkout (``python -m pytest`` from the repository), the top-level folders
# ``sim/`` and ``streams/`` sit beside this package; installed, they are the subpackages
# ``ssr_compile.sim`` and ``ssr_compile.streams`` (pyproject.toml maps them).  Let the checkout
# resolve the same names.
def _checkout_subpackages() -> None:
    from pathlib import Path

    here = Path(__file__).resolve().parent
    root = here.parent
    if (here / "sim").is_dir() or not (root / "pyproject.toml").is_file():
        return
    if (root / "sim" / "__init__.py").is_file() and str(root) not in __path__:
        __path__.append(str(root))


_checkout_subpackages()
