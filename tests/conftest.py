"""Test-suite settings: property tests are derandomized so every run (and CI) sees the same
examples; a failure found once is found again."""

from hypothesis import settings

settings.register_profile("ssr", derandomize=True, deadline=None, print_blob=True)
settings.load_profile("ssr")


# ---------------------------------------------------------------- the shared corpus

import os  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def corpus_dir(sub: str = "") -> Path | None:
    """The shared test corpus (``../shared/corpus`` beside the repository, or
    ``$SSR_CORPUS``); None when absent."""
    candidates = [os.environ.get("SSR_CORPUS"), ROOT.parent / "shared" / "corpus"]
    for c in candidates:
        if c and (Path(c) / sub).exists():
            return Path(c) / sub
    return None


def require_corpus(sub: str = "") -> Path:
    """The corpus folder, or skip when this checkout has no shared folder beside it.

    A missing corpus *fails* when it should be there: with ``SSR_REQUIRE_CORPUS`` set, or
    under CI (``CI`` set) when ``../shared`` exists (the workplace layout without its corpus
    is a broken checkout, not a machine without the data)."""
    found = corpus_dir(sub)
    if found is None:
        msg = f"the shared corpus ({sub or 'corpus'}) is not at ../shared/corpus or $SSR_CORPUS"
        if os.environ.get("SSR_REQUIRE_CORPUS") or (
            os.environ.get("CI") and (ROOT.parent / "shared").is_dir()
        ):
            pytest.fail(msg)
        pytest.skip(msg)
    return found
