"""``python -m rockjax.cli``: the ``rockjax`` command."""

import sys

from ._main import main

sys.exit(main())
