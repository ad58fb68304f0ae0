"""``python -m rbenv``: the ``rbenv`` command without the name clash with Ruby's rbenv."""

import sys

from rbenv.agents.cli import main

sys.exit(main())
