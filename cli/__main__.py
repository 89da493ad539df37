"""``python -m jackson`` is the ``jackson`` command."""

import sys

from jackson.main import main

sys.exit(main())
