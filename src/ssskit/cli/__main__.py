"""``python -m ssskit.cli``: the same as the ``ssskit`` command."""

import sys

from . import main

sys.exit(main())
