"""Test-suite settings: property tests are derandomized so every run (and CI) sees the same
examples; a failure found once is found again."""

from hypothesis import settings

settings.register_profile("ssr", derandomize=True, deadline=None, print_blob=True)
settings.load_profile("ssr")
