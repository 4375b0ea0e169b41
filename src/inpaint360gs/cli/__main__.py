"""``python -m inpaint360gs.cli`` = ``inpaint360gs``."""

import sys

from inpaint360gs.cli import main

sys.exit(main())
