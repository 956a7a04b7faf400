"""ssr-compile: the PDDLStream dialect of belief-space replanning, compiled to plain cost-PDDL.

Implements Garrett et al., "Online Replanning in Belief Space for Partially Observable Task and
Motion Problems" (ICRA 2020).  See docs/design.md for the architecture.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("ssr-compile")
except PackageNotFoundError:  # running from a checkout that is not installed
    __version__ = "0.0.0+unknown"


# Top-level folders of the repository that install as subpackages of this one (pyproject.toml,
# ``[tool.setuptools.package-dir]``; tests/test_imports.py checks that the two lists agree).
_MAPPED_FOLDERS = ("grammar", "domains", "sim", "streams")


# In a source checkout (``python -m pytest`` from the repository root puts the checkout's
# ``ssr_compile/`` first on sys.path, even over an installed copy), the mapped folders sit
# beside this package, not inside it.  A finder resolves exactly those names to the checkout's
# folders, so the checkout imports the same ``ssr_compile.sim`` etc. an install does, and
# nothing else at the repository root (``tests/``, ``bench/``, ``tools/``) becomes a
# subpackage.
def _checkout_subpackages() -> None:
    import sys
    from importlib.util import spec_from_file_location
    from pathlib import Path

    here = Path(__file__).resolve().parent
    root = here.parent
    if (here / "sim").is_dir() or not (root / "pyproject.toml").is_file():
        return  # installed: the subpackages are real folders of this package
    folders = {
        f"{__name__}.{name}": root / name
        for name in _MAPPED_FOLDERS
        if (root / name / "__init__.py").is_file()
    }

    class CheckoutSubpackages:
        """Meta path finder for the mapped folders of this checkout."""

        @staticmethod
        def find_spec(fullname, path=None, target=None):
            folder = folders.get(fullname)
            if folder is None:
                return None
            return spec_from_file_location(
                fullname, folder / "__init__.py", submodule_search_locations=[str(folder)]
            )

    sys.meta_path.insert(0, CheckoutSubpackages)


_checkout_subpackages()
