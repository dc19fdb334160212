"""``python -m starid`` runs the ``starid`` command."""

import sys

from .cli import main

sys.exit(main())
