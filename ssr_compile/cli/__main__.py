"""``python -m ssr_compile.cli``: the same as ``ssr-compile``."""

import sys

from . import main

sys.exit(main())
