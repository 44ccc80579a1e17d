"""``python -m cptbt`` runs the command line."""

import sys

from cptbt.cli import main

sys.exit(main())
