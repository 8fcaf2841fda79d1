"""``python -m ssskit``: the same as the ``ssskit`` command (:func:`ssskit.cli.main`)."""

import sys

from .cli import main

sys.exit(main())
