"""``python -m volerr_pin.cli`` runs the ``volerr`` command."""

import sys

from . import main

sys.exit(main())
